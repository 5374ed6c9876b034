"""The reproduction's headline statistics and its generated words, on small synthetic tables.

No simulation here: the functions that turn the per-run numbers into the report's headline
table, per-method statistics and sentences are checked against hand-computed values.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.errors import ConfigError
from rinscal.experiments.paper.claims import (
    SUMMARY_COLUMNS,
    nav_method_table,
    spread,
    summary_table,
    uncompensated_wins_heldout,
    uncompensated_wins_nav,
)
from rinscal.experiments.paper.config import PAPER, VARIANTS, ReproConfig, load_plant, plant_info
from rinscal.presets import PRESETS
from rinscal.report.paper_report import (
    command_line,
    words_uncompensated_heldout,
    words_uncompensated_nav,
)

CHANNELS = ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]


def _residual(none: float, sectional_accel: list[float]) -> pd.DataFrame:
    """A held-out residual table: every gyro better than 'none'; the accelerometers given."""
    rows = []
    for log in ("repeat", "ramp"):
        rows.append({"log": log, "method": "none", **dict.fromkeys(CHANNELS, none)})
        for m in ("poly-t", "regression", "neural"):
            rows.append({"log": log, "method": m, **dict.fromkeys(CHANNELS, none / 2)})
        sec = dict.fromkeys(CHANNELS[:3], none / 2)
        sec.update(zip(CHANNELS[3:], sectional_accel, strict=True))
        rows.append({"log": log, "method": "sectional", **sec})
    return pd.DataFrame(rows)


def _maxerr(none: list[float], others: dict[str, list[float]]) -> pd.DataFrame:
    """A max-error table of 5 quasi-static, 5 swing and 3 vehicle runs."""
    groups = [("lab", "quasi-static")] * 5 + [("lab", "swing")] * 5 + [("vehicle", "vehicle")] * 3
    df = pd.DataFrame(
        {
            "experiment": [g[0] for g in groups],
            "scenario": [g[1] for g in groups],
            "number": [*range(1, 11), 1, 2, 3],
            "none": none,
        }
    )
    for v in VARIANTS:
        if v != "none":
            df[v] = others.get(v, [0.1] * 13)
    return df


def test_uncompensated_wins_are_named_per_method_and_channel() -> None:
    h = _residual(3.0, [10.0, 2.0, 4.0])  # sectional worse than none on accel_x and accel_z
    assert uncompensated_wins_heldout(h, "repeat") == {"sectional": ["accel_x", "accel_z"]}
    words = words_uncompensated_heldout(h, "repeat")
    assert words.startswith("On the held-out repeat start, no compensation beats")
    assert "method 1 (sectional) on accel_x and accel_z" in words
    assert "regression" not in words and "accel_y" not in words
    assert "chamber ramp" in words_uncompensated_heldout(h, "ramp")


def test_no_words_of_defeat_when_every_method_beats_uncompensated() -> None:
    h = _residual(3.0, [1.0, 2.0, 2.9])
    assert uncompensated_wins_heldout(h, "repeat") == {}
    words = words_uncompensated_heldout(h, "repeat")
    assert "no compensation beats" not in words
    assert "every method has a smaller thermal residual" in words


def test_navigation_words_say_where_uncompensated_has_the_smaller_mean_error() -> None:
    none = [1.0] * 5 + [0.2] * 5 + [1.0] * 3
    neural = [0.5] * 5 + [0.3] * 5 + [0.5] * 3  # worse than none in the swing runs only
    me = _maxerr(none, {"neural": neural})
    wins = uncompensated_wins_nav(me)
    assert set(wins) == {"lab swing"}
    assert wins["lab swing"]["neural"] == pytest.approx((0.2, 0.3))
    words = words_uncompensated_nav(me)
    assert "lab swing runs (n = 5)" in words
    assert "no compensation has a smaller mean maximum position error (0.200 nmi)" in words
    assert "method 3 (BP network) at 0.300 nmi" in words
    assert "sectional" not in words  # 0.1 < 0.2: method 1 beats it
    me_ok = _maxerr([1.0] * 13, {})
    assert uncompensated_wins_nav(me_ok) == {}
    assert "every method has a smaller mean maximum position error" in words_uncompensated_nav(
        me_ok
    )


def test_spread_is_mean_sample_sd_min_max_n() -> None:
    st = spread([1.0, 2.0, 6.0, float("nan")])
    assert st == {"n": 3, "mean": 3.0, "sd": pytest.approx(np.std([1, 2, 6], ddof=1)),
                  "min": 1.0, "max": 6.0}  # fmt: skip
    assert np.isnan(spread([4.0])["sd"]) and spread([])["n"] == 0


def test_headline_table_gives_mean_and_spread_before_the_best_case() -> None:
    sec = [1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0, 2.0, 0.5, 0.7, 0.5]
    reg = [0.4, 0.9, 1.0, 1.2, 1.0, 2.0, 1.0, 2.0, 3.0, 2.0, 0.3, 0.3, 0.3]
    neu = [0.4] * 10 + [0.2, 0.7, 0.6]
    t = summary_table(_maxerr([2.0] * 13, {"sectional": sec, "regression": reg, "neural": neu}))
    assert list(t.columns) == list(SUMMARY_COLUMNS)
    cols = list(t.columns)
    # a mean with its spread before any best case; the paper's 'up to' next to our maximum
    assert cols.index("rinscal: mean") < cols.index("rinscal: sd") < cols.index("rinscal: max")
    assert cols.index("paper: maximum ('up to')") == cols.index("rinscal: max") + 1
    qs = t[t["quantity"].str.startswith("lab quasi-static") & t["quantity"].str.contains("1 → 2")]
    row = qs.iloc[0]
    d = 100 * (1 - np.array(reg[:5]))  # decrease from 1.0
    assert row["n runs"] == 5
    assert row["rinscal: mean"] == pytest.approx(d.mean())  # 10 %, not the best run's 60 %
    assert row["rinscal: sd"] == pytest.approx(d.std(ddof=1))
    assert (row["rinscal: min"], row["rinscal: max"]) == pytest.approx((d.min(), d.max()))
    assert row["paper: maximum ('up to')"] == PAPER["lab_qs_m1_to_m2_pct"]
    assert np.isnan(row["paper: mean"])  # the paper publishes no mean for the lab runs
    veh = t[t["quantity"].str.startswith("vehicle: decrease")].iloc[0]
    assert veh["paper: mean"] == PAPER["vehicle_m1_to_m3_mean_pct"]
    assert veh["paper: maximum ('up to')"] == PAPER["vehicle_m1_to_m3_max_pct"]
    assert veh["rinscal: mean"] == pytest.approx(np.mean([60.0, 0.0, -20.0]))
    t10 = t[t["quantity"].str.startswith("vehicle: max position error, method 1")].iloc[0]
    assert t10["paper: mean"] == pytest.approx(np.mean(PAPER["table10_nmi"]["sectional"]))
    assert t10["rinscal: max"] == pytest.approx(0.7)


def test_nav_method_table_has_max_error_and_absolute_heading_statistics() -> None:
    me = _maxerr([float(i) for i in range(13)], {})
    heading = me[["experiment", "scenario", "number"]].copy()
    for v in VARIANTS:
        heading[v] = [(-1) ** i * 10.0 * i for i in range(13)]
    t = nav_method_table(me, heading)
    row = t[(t["runs"] == "lab + vehicle") & (t["variant"] == "none")].iloc[0]
    assert row["n runs"] == 13 and row["max error mean [nmi]"] == pytest.approx(6.0)
    assert row["|heading error| mean [arcsec]"] == pytest.approx(60.0)  # absolute values
    assert row["|heading error| min [arcsec]"] == 0.0
    sw = t[(t["runs"] == "lab swing") & (t["variant"] == "none")].iloc[0]
    assert sw["n runs"] == 5 and sw["max error max [nmi]"] == 9.0
    # a summary without the heading error leaves it blank instead of failing
    heading[list(VARIANTS)] = np.nan
    t = nav_method_table(me, heading)
    assert t["|heading error| mean [arcsec]"].isna().all() and (t["n heading"] == 0).all()


def test_plant_is_loaded_by_name_and_an_unknown_name_lists_the_presets() -> None:
    imu = load_plant("navigation_grade")
    info = plant_info("navigation_grade", imu)
    assert info["kind"] == "preset" and info["name"] == imu.name
    assert "navigation_grade" not in info["other_presets"]
    assert info["run_other"] == [f"--imu {p}" for p in PRESETS if p != "navigation_grade"]
    with pytest.raises(ConfigError, match="navigation_grade") as exc:
        load_plant("no_such_imu")
    assert all(p in str(exc.value) for p in PRESETS)


def test_plant_from_a_toml_file_is_named_by_its_path(tmp_path) -> None:
    from importlib import resources

    path = tmp_path / "my_imu.toml"
    path.write_text(resources.files("rinscal.data").joinpath("navigation_grade.toml").read_text())
    imu = load_plant(str(path))
    info = plant_info(str(path), imu)
    assert info["kind"] == "file" and info["spec"] == str(path) and info["name"] == imu.name
    assert info["run_other"] == [f"--imu {p}" for p in PRESETS]
    with pytest.raises(ConfigError, match="not found"):
        load_plant(str(tmp_path / "missing.toml"))


def test_cli_refuses_an_unknown_imu_before_doing_any_work(tmp_path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["reproduce", "--quick", "--imu", "no_such_imu",
                                   "--out", str(out)])  # fmt: skip
    assert res.exit_code == 2
    msg = " ".join(res.output.split())
    assert "no_such_imu" in msg and all(p in msg for p in PRESETS)
    assert not out.exists()


def test_config_and_command_line_carry_the_plant_and_alignment() -> None:
    cfg = ReproConfig.quick_preset(3, 2, imu="navigation_grade", align_s=300.0)
    assert cfg.quick and cfg.imu == "navigation_grade" and cfg.align_s == 300.0
    assert command_line(cfg) == (
        "rinscal reproduce --quick --seed 3 --imu navigation_grade --align-s 300"
    )
    late = ReproConfig.quick_preset(0, 1, align_start_s=120.0)
    assert command_line(late).endswith("--align-s 600 --align-start-s 120")
    # the exact command, as "How this was made" gives it: the study's units and --out
    # (quoted where the folder's name needs it)
    assert command_line(cfg, Path("/tmp/my run"), units=5).endswith(
        "--align-s 300 --units 5 --out '/tmp/my run'"
    )
    with pytest.raises(ConfigError, match="align_start_s"):
        ReproConfig.full(align_start_s=-1.0)
    with pytest.raises(ConfigError, match="alignment ends"):
        ReproConfig.quick_preset(align_start_s=3000.0, align_s=600.0)  # swing runs last 1 h


def test_alignment_settings_reach_the_navigation_filter() -> None:
    from rinscal.experiments.paper.navigation import alignment_config

    imu = load_plant("navigation_grade")
    a = alignment_config(imu, 300.0, 120.0)
    assert a.total_s == pytest.approx(300.0) and a.start_s == 120.0
    assert a.end_s == pytest.approx(420.0)

"""`rinscal navigate`: files written, numbers consistent, inputs never overwritten."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.cli.navigate import _OUTPUTS

runner = CliRunner()


def test_navigate_quasi_static_writes_errors_summary_and_plots(tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "qs"
    args = ["navigate", "--scenario", "quasi-static", "--hours", "0.3", "--rate", "10"]
    res = runner.invoke(app, [*args, "--seed", "4", "--out", str(out)])
    assert res.exit_code == 0, res.output
    # exactly the outputs the command guards against overwriting an input, none empty
    assert sorted(p.name for p in out.iterdir()) == sorted(_OUTPUTS)
    assert set(_OUTPUTS) >= {"errors.csv", "truth.csv", "summary.json", "position_error.png"}
    for name in _OUTPUTS:
        assert (out / name).stat().st_size > 0, name
    err = pd.read_csv(out / "errors.csv")
    summary = json.loads((out / "summary.json").read_text())
    assert set(err["variant"]) == {"none", "true"}
    # reported from the end of the 10-min alignment to the end, once per second
    none = err[err["variant"] == "none"]
    assert none["time_s"].iloc[0] == 601.0 and none["time_s"].iloc[-1] == 1080.0
    np.testing.assert_allclose(none["horizontal_m"], np.hypot(none["east_m"], none["north_m"]))
    np.testing.assert_allclose(none["horizontal_nmi"] * 1852.0, none["horizontal_m"])
    assert summary["variants"]["none"]["max_error_m"] == pytest.approx(
        none["horizontal_m"].max(), rel=1e-9
    )
    assert summary["seed"] == 4 and summary["scenario"] == "quasi-static"
    assert "max position error" in res.output
    # same seed, same numbers (deterministic); existing outputs are replaced atomically
    res2 = runner.invoke(app, [*args, "--seed", "4", "--out", str(out)])
    assert res2.exit_code == 0, res2.output
    pd.testing.assert_frame_equal(pd.read_csv(out / "errors.csv"), err)


def test_navigate_vehicle_reports_a_moving_truth(tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "veh"
    res = runner.invoke(
        app,
        [
            "navigate",
            "-s",
            "vehicle",
            "--hours",
            "0.15",
            "--rate",
            "20",
            "--no-oracle",
            "--out",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    truth = pd.read_csv(out / "truth.csv")
    err = pd.read_csv(out / "errors.csv")
    assert set(err["variant"]) == {"none"}
    speed = np.hypot(truth["v_e"], truth["v_n"])
    assert speed.max() > 10.0 and truth["alt_m"].max() > truth["alt_m"].min() + 1.0


def test_navigate_refuses_bad_input_and_never_overwrites_it(tmp_path) -> None:  # type: ignore[no-untyped-def]
    res = runner.invoke(app, ["navigate", "-s", "moon", "--out", str(tmp_path / "x")])
    assert res.exit_code == 2
    assert "unknown scenario 'moon'" in res.output
    res = runner.invoke(
        app, ["navigate", "-s", "ramp", "-m", str(tmp_path / "no.json"), "--out", str(tmp_path)]
    )
    assert res.exit_code == 2 and "not found" in res.output
    model = tmp_path / "summary.json"
    model.write_text("{}")
    res = runner.invoke(
        app,
        [
            "navigate",
            "-s",
            "quasi-static",
            "--hours",
            "0.3",
            "-m",
            str(model),
            "--out",
            str(tmp_path),
        ],
    )
    assert res.exit_code == 2 and "refusing to overwrite" in res.output
    assert model.read_text() == "{}"
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    res = runner.invoke(
        app,
        [
            "navigate",
            "-s",
            "quasi-static",
            "--hours",
            "0.3",
            "--rate",
            "10",
            "-m",
            str(bad),
            "--out",
            str(tmp_path / "o"),
        ],
    )
    assert res.exit_code == 2 and "bad.json" in res.output


def _preset_toml(path):  # type: ignore[no-untyped-def]
    from importlib import resources

    path.write_text(resources.files("rinscal.data").joinpath("navigation_grade.toml").read_text())
    return path


def test_navigate_imu_file_alignment_start_and_heading_at_nav_start(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """--imu FILE.toml, --align-start-s, --align-s: the alignment runs 120 s → 420 s after
    power-on, errors are reported from 421 s on, and the heading, pitch and roll errors at
    the navigation start are printed and written per variant. The old --imu-config still
    works (hidden) and gives the same numbers."""
    imu = _preset_toml(tmp_path / "unit.toml")
    common = ["navigate", "-s", "quasi-static", "--hours", "0.2", "--rate", "10", "--no-oracle"]
    align = ["--align-start-s", "120", "--align-s", "300", "--seed", "1"]
    out = tmp_path / "a"
    res = runner.invoke(app, [*common, *align, "--imu", str(imu), "--out", str(out)])
    assert res.exit_code == 0, res.output
    err = pd.read_csv(out / "errors.csv")
    summary = json.loads((out / "summary.json").read_text())
    assert err["time_s"].iloc[0] == 421.0 and err["time_s"].iloc[-1] == 720.0
    assert summary["alignment_start_s"] == 120.0
    assert summary["alignment_s"] == 300.0 and summary["navigation_start_s"] == 420.0
    assert summary["imu_spec"] == str(imu)
    att = summary["variants"]["none"]["attitude_error_at_nav_start"]
    assert set(att) == {"heading_arcsec", "pitch_arcsec", "roll_arcsec"}
    # the first row's Euler errors [rad], in arcsec (206264.8″ per rad)
    first = err.iloc[0]
    for key, col in (("heading", "heading_err"), ("pitch", "pitch_err"), ("roll", "roll_err")):
        assert att[f"{key}_arcsec"] == pytest.approx(first[col] * 180 / np.pi * 3600, rel=1e-6)
    assert f'heading {att["heading_arcsec"]:+.1f}"' in res.output
    assert f'roll {att["roll_arcsec"]:+.1f}"' in res.output
    assert "navigation from 420 s after power-on" in res.output
    old = runner.invoke(
        app, [*common, *align, "--imu-config", str(imu), "--out", str(tmp_path / "b")]
    )
    assert old.exit_code == 0, old.output
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "b" / "errors.csv"), err)


def test_navigate_refuses_bad_imu_and_alignment_options(tmp_path) -> None:  # type: ignore[no-untyped-def]
    base = ["navigate", "-s", "quasi-static", "--hours", "0.3", "--rate", "10"]
    out = ["--out", str(tmp_path / "o")]
    cases = [
        (["--align-s", "0"], "'--align-s': 0.0 is not in the range 60.0<=x<=7200.0"),
        (["--align-s", "-60"], "'--align-s'"),
        (["--align-s", "nan"], "--align-s must be > 0"),
        (["--align-start-s", "-1"], "'--align-start-s': -1.0 is not in the range"),
        (["--align-start-s", "inf"], "'--align-start-s'"),
        (["--align-start-s", "900"], "must end before the run"),
        (["--imu", "no_such_unit"], "neither a preset"),
        (["--imu", str(tmp_path / "missing.toml")], "not found"),
        (["--imu", "navigation_grade", "--imu-config", str(tmp_path / "x.toml")], "once"),
    ]
    for extra, message in cases:
        res = runner.invoke(app, [*base, *extra, *out])
        assert res.exit_code == 2, (extra, res.output)
        assert message in res.output, (extra, res.output)
    assert not (tmp_path / "o").exists()
    # an IMU file is an input like a model: never overwritten
    imu = _preset_toml(tmp_path / "truth.csv")
    res = runner.invoke(app, [*base, "--imu", str(imu), "--out", str(tmp_path)])
    assert res.exit_code == 2 and "refusing to overwrite" in res.output
    helptext = runner.invoke(app, ["navigate", "--help"]).output
    assert "--imu" in helptext and "--align-start-s" in helptext
    assert "--imu-config" not in helptext


def test_navigate_takes_every_policy_and_words_the_change(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Issue 21, item 9: --policy fallback as in compensate/evaluate; an improvement reads
    "less than uncompensated", a loss "more than", never a signed "+78 % vs"."""
    log = tmp_path / "soak.parquet"
    res = runner.invoke(
        app, ["simulate", "soak", "--hours", "0.5", "--rate", "0.2", "--out", str(log)]
    )
    assert res.exit_code == 0, res.output
    model = tmp_path / "m.json"
    res = runner.invoke(app, ["fit", str(log), "--method", "regression", "--out", str(model)])
    assert res.exit_code == 0, res.output
    args = ["navigate", "-s", "quasi-static", "--hours", "0.2", "--rate", "10", "--no-oracle"]
    res = runner.invoke(
        app, [*args, "-m", str(model), "--policy", "fallback", "--out", str(tmp_path / "n")]
    )
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "n" / "summary.json").read_text())
    (v,) = (v for v in summary["variants"].values() if "improvement_vs_none_pct" in v)
    pct = v["improvement_vs_none_pct"]
    word = "less" if pct >= 0 else "more"
    assert f"({abs(pct):.1f} % {word} than uncompensated)" in " ".join(res.output.split())
    assert "% vs uncompensated" not in res.output
    bad = runner.invoke(app, [*args, "--policy", "guess", "--out", str(tmp_path / "x")])
    assert bad.exit_code == 2 and "clamp, fallback, extrapolate, error" in bad.output

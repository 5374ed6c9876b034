"""The one navigation engine (:mod:`rinscal.nav.engine`): its correction step against the
textbook error of a constant accelerometer bias, and the one result type's summary and
folder."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from rinscal import earth, units
from rinscal.errors import ConfigError
from rinscal.nav.engine import Navigation, navigate_pieces
from rinscal.nav.rotation import RotationSchedule
from rinscal.sim.scenario import ScenarioConfig, constant_errors, run_scenario
from rinscal.sim.trajectory import StaticMotion

SITE = StaticMotion(heading_deg=0.0, lat_deg=32.06, alt_m=10.0)  # r x east, y north
BIAS = np.array([0.0, 0.0, 0.0, 100 * units.UG_TO_MPS2, 0.0, 0.0])  # east accelerometer
DURATION_S = 600.0


@pytest.fixture(scope="module")
def biased() -> Navigation:
    """10 min from the true initial state with an east accelerometer bias of 100 µg,
    uncompensated and with a correction that removes exactly that bias."""
    cfg = ScenarioConfig(
        "t", SITE, RotationSchedule.none(), DURATION_S, 50.0, align=None, out_dt_s=10.0
    )
    exact = constant_errors(BIAS)
    result = run_scenario(cfg, exact, {"none": None, "removed": lambda t, w, f: exact(t)})
    temps = pd.DataFrame(
        {"time_s": [0.0, 600.0], "chamber": 20.0, "outer": 20.0, "sensor_gx": 21.0}
    )
    return Navigation(result, temps, info={"seed": 0})


def test_an_uncompensated_bias_drives_the_schuler_error_and_a_removed_one_none(biased) -> None:  # type: ignore[no-untyped-def]
    """δp_E = (∇_E/ω_s²)(1 − cos ω_s t) (Titterton & Weston Ch. 12): 0.50 m at 600 s for
    100 µg; the correction removes it to round-off."""
    g = float(earth.gravity(SITE.lat0, SITE.alt0))
    ws = math.sqrt(g / earth.A)
    t = biased.errors["none"]["time_s"].to_numpy()
    expected = BIAS[3] / ws**2 * (1 - np.cos(ws * t))
    east = biased.errors["none"]["east_m"].to_numpy()
    assert abs(east[-1] - expected[-1]) < 0.03 * expected[-1]
    assert np.abs(biased.errors["removed"]["horizontal_m"].to_numpy()).max() < 1e-6


def test_the_summary_is_the_results_then_the_runs_and_save_writes_it(biased, tmp_path) -> None:  # type: ignore[no-untyped-def]
    s = biased.summary
    keys = list(s)
    assert keys[0] == "scenario" and keys[-1] == "seed"
    assert s["variants"]["none"]["max_error_m"] == pytest.approx(biased.max_error_m("none"))
    assert s["variants"]["removed"]["improvement_vs_none_pct"] > 99.99
    biased.save(tmp_path)
    assert json.loads((tmp_path / "summary.json").read_text()) == json.loads(
        json.dumps(s, default=float)
    )
    rows = pd.read_csv(tmp_path / "errors.csv")
    assert rows["variant"].tolist() == ["none"] * len(t := biased.errors["none"]) + [
        "removed"
    ] * len(t)
    assert np.array_equal(rows["east_m"].to_numpy()[: len(t)], t["east_m"].to_numpy())
    assert not list(tmp_path.glob("*.png"))  # no figure maker given: no figures


def test_a_recordings_summary_names_its_log_first_and_holds_its_report(biased) -> None:  # type: ignore[no-untyped-def]
    nav = Navigation(biased.result, biased.temperatures, report={"log": "run.parquet"})
    keys = list(nav.summary)
    assert keys[0] == "log" and keys[-1] == "recording" and "scenario" not in keys
    assert nav.summary["recording"] == {"log": "run.parquet"}


def test_the_engine_refuses_what_it_cannot_do() -> None:
    with pytest.raises(ConfigError, match="aligner or an initial state"):
        navigate_pieces([], lambda s: s, {"none": None}, dt=0.01, start_s=0.0, out_every=1)
    with pytest.raises(ConfigError, match="aiding"):
        navigate_pieces(
            [], lambda s: s, {"none": None}, dt=0.01, start_s=0.0, out_every=1,
            initial=lambda: None, aiding=[object()],
        )  # fmt: skip


def test_save_navigation_writes_the_commands_folder(biased, tmp_path) -> None:  # type: ignore[no-untyped-def]
    from rinscal.report.nav_plots import save_navigation

    save_navigation(biased, tmp_path)
    names = {"errors.csv", "truth.csv", "summary.json", "position_error.png", "trajectory.png",
             "temperatures.png"}  # fmt: skip
    assert {p.name for p in tmp_path.iterdir()} == names
    for png in tmp_path.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

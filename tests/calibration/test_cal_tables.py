"""The calibration experiments: held-out table on the simulated plant, the real log's legs."""

from __future__ import annotations

import numpy as np
import pytest

from rinscal.experiments.paper.calibration import (
    heldout_table,
    real_log_legs,
    real_log_table,
    tofupilot_mapping,
    wide,
)
from rinscal.io.tables import read_log
from tests._shared import real_log_path

REAL = real_log_path()


def test_heldout_table_on_the_quiet_plant(soak_quiet, repeat_quiet) -> None:
    log, _, meta = soak_quiet
    rlog, rtruth, _ = repeat_quiet
    tab = heldout_table(log, rlog, rtruth, meta, methods=("poly-t", "sectional", "regression"))
    assert len(tab) == 6 * 4  # channels x (uncompensated + 3 methods), one run
    w = wide(tab)
    assert list(w.columns) == ["uncompensated", "poly-t", "sectional", "regression"]
    true = rtruth[[f"bias_{c}" for c in ("gyro_x", "accel_z")]].to_numpy()
    np.testing.assert_allclose(w["uncompensated"].to_numpy()[[0, 5]], true.std(axis=0), rtol=1e-9)
    acc = w.index.get_level_values("channel").str.startswith("accel")
    # method 2 beats the baseline and the sectional method on held-out data
    assert (w["regression"][acc] < w["poly-t"][acc]).all()
    assert (w["regression"][acc] < w["sectional"][acc]).all()
    steps = wide(tab, "max_step")
    assert (steps["sectional"][acc] > 20 * steps["regression"][acc]).all()


def test_real_log_is_cut_at_its_turning_points() -> None:
    log = real_log_legs(read_log(REAL, tofupilot_mapping()))
    legs = log.groupby("run", sort=False)["temp_in"].agg(["first", "last", "min", "max", "size"])
    assert list(legs.index) == ["leg1_cool", "leg2_heat", "leg3_cool"]
    assert legs["size"].sum() == 8400
    # README: starts at 51.6 °C, cools to -17.5 °C, heats to 73.9 °C, cools to 39.8 °C
    assert legs.loc["leg1_cool", "first"] == pytest.approx(51.6, abs=0.1)
    assert legs.loc["leg2_heat", "min"] == pytest.approx(-17.5, abs=0.2)
    assert legs.loc["leg3_cool", "max"] == pytest.approx(73.9, abs=0.2)


def test_real_log_table_fits_on_two_legs_and_judges_the_third() -> None:
    tab, models = real_log_table(REAL, methods=("poly-t", "regression"))
    assert set(tab["run"]) == {"leg3_cool"} and set(tab["method"]) == {"poly-t", "regression"}
    assert not models["regression"].use_gradient  # one temperature: no ΔT
    # a MEMS accelerometer with a strong thermal drift: a cubic in T removes most of it
    acc = tab[(tab["method"] == "poly-t") & tab["channel"].str.startswith("accel")]
    assert (acc["ratio"] < 0.5).all()

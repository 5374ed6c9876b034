"""The mechanism table's heading-error prediction against the alignment filter itself.

A quasi-static run (heading 45°, 10 Hz) whose only sensor errors are a constant horizontal
gyro bias and a linear accelerometer bias ramp, navigated as the reproduction navigates
(:func:`rinscal.sim.scenario.run_scenario` with an uncompensated variant and an oracle that
subtracts the errors exactly) and fed to
:func:`rinscal.experiments.paper.mechanism.alignment_mechanism` as
:func:`rinscal.experiments.paper.navigation.run_navigation_job` feeds it.

The known answer, written out here from the geometry: the IMU's x axis points at azimuth
135°, its y axis at 45°. With the table still, gyrocompassing hands over
``δψ = (−ε_E + ∇̇_N/g) / (Ω cos L) + tan L ∇_E(end)/g`` (heading INS minus truth,
clockwise). With the table indexing through the four positions, the body-frame biases turn
with it: a constant bias is a square wave in the navigation frame, which the filter
separates from the tilt and estimates, so it leaves almost no heading error; a ramp is
followed by the filter's Gauss-Markov bias states, and what they leave is a fraction of the
fixed-IMU figure that the formula does not give: resolved with the attitude at each instant
it gives −23″ for the constant gyro bias (−1″ measured) and +200″ for a ramp case (+58″
measured); resolved with the hand-over attitude, as the table did before, ±557″ for a single
ramp (19-58″ measured). So the mechanism gives no prediction for such runs.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from rinscal import earth, units
from rinscal.experiments.paper.mechanism import (
    PREDICTED_COLUMN,
    _C_nr,
    alignment_mechanism,
    fixed_imu_heading_error,
    mechanism_summary,
    mechanism_table,
)
from rinscal.nav.align import AlignConfig
from rinscal.nav.rotation import RotationSchedule
from rinscal.report.paper_nav_sections import mechanism_words
from rinscal.sim.scenario import preset, run_scenario

EPS = 0.01 * units.DPH_TO_RPS  # constant gyro bias [rad/s]
RAMP = 10.0 * units.UG_TO_MPS2 / 60.0  # accelerometer bias rate [m/s³]
AZ_X, AZ_Y = math.radians(135.0), math.radians(45.0)  # azimuths of the IMU's x and y axes


def _errors(gyro: tuple[float, float], ramp: tuple[float, float]):
    """Constant x/y gyro biases (multiples of EPS) and x/y accelerometer ramps (of RAMP)."""

    def err(t, w=None, f=None):
        e = np.zeros((np.shape(t)[0], 6))
        e[:, 0:2] = np.multiply(gyro, EPS)
        e[:, 3:5] = np.outer(t, np.multiply(ramp, RAMP))
        return e

    return err


def _run(err, indexing: bool) -> SimpleNamespace:
    """One quasi-static run as the reproduction runs it: measured heading [″] of the
    uncompensated variant and the mechanism numbers, wrapped like a NavRunResult."""
    sched = RotationSchedule.four_position() if indexing else RotationSchedule.none()
    cfg = preset("quasi-static", hours=0.2, rate_hz=10.0, align=AlignConfig(), schedule=sched)
    cfg = replace(cfg, out_dt_s=10.0)
    res = run_scenario(cfg, err, {"none": None, "true": lambda t, w, f: err(t)})
    grid = np.arange(cfg.align_start_s, cfg.duration_s - 1.0, 1.0)
    d = err(grid)
    mech = alignment_mechanism(cfg, grid, {"none": d, "true": np.zeros_like(d)}, np.zeros(6))
    job = SimpleNamespace(experiment="lab", scenario="quasi-static", index=1)
    return SimpleNamespace(job=job, summary=res.summary(), mechanism=mech, cfg=cfg)


def _measured(r) -> float:
    return r.summary["variants"]["none"]["attitude_error_at_nav_start"]["heading_arcsec"]


def _textbook(cfg, gyro, ramp) -> float:
    """The fixed-IMU gyrocompass heading error written out from the geometry [″]."""
    lat = cfg.trajectory.lat0
    g = float(earth.gravity(lat, cfg.trajectory.alt0))
    eps_e = EPS * (gyro[0] * math.sin(AZ_X) + gyro[1] * math.sin(AZ_Y))
    rate_n = RAMP * (ramp[0] * math.cos(AZ_X) + ramp[1] * math.cos(AZ_Y))
    acc_e_end = RAMP * cfg.nav_start_s * (ramp[0] * math.sin(AZ_X) + ramp[1] * math.sin(AZ_Y))
    d = (-eps_e + rate_n / g) / (earth.RATE * math.cos(lat)) + math.tan(lat) * acc_e_end / g
    return d / units.ARCSEC_TO_RAD


CASES = [((1.0, 0.0), (0.0, 1.0)), ((0.0, 1.0), (-1.0, 0.0)), ((1.0, -1.0), (1.0, 1.0))]


@pytest.mark.parametrize(("gyro", "ramp"), CASES)
def test_table_still_prediction_matches_the_filter_within_10_percent(gyro, ramp) -> None:
    r = _run(_errors(gyro, ramp), indexing=False)
    expected = _textbook(r.cfg, gyro, ramp)
    measured = _measured(r)
    predicted = r.mechanism["none"]["predicted_heading_arcsec"]
    assert abs(expected) > 15.0  # the smallest case: +18″ of two near-cancelling terms
    assert measured == pytest.approx(expected, rel=0.10)
    assert predicted == pytest.approx(measured, rel=0.10)
    assert predicted == pytest.approx(expected, rel=0.02)  # same physics, same geometry
    table = mechanism_table([r])
    row = table[table["variant"] == "none"].iloc[0]
    assert row[PREDICTED_COLUMN] == pytest.approx(predicted)
    assert row["thermal part of δψ [″]"] == pytest.approx(measured, abs=1.0)  # oracle ≈ 0″
    # the residual's rate in the IMU frame: |ramp| × 10 µg/min
    assert row["accel rate, IMU x-y [µg/min]"] == pytest.approx(10.0 * math.hypot(*ramp))


def test_indexing_table_the_filter_takes_up_the_biases_and_no_prediction_is_made() -> None:
    gyro, ramp = CASES[1]
    cfg = _run(_errors(gyro, (0.0, 0.0)), indexing=False).cfg
    fixed_gyro = _textbook(cfg, gyro, (0.0, 0.0))  # ≈ −114″
    fixed_both = _textbook(cfg, gyro, ramp)  # ≈ +270″
    only_gyro = _run(_errors(gyro, (0.0, 0.0)), indexing=True)
    both = _run(_errors(gyro, ramp), indexing=True)
    # a constant body-frame bias turns with the table and is estimated: almost nothing left
    assert abs(_measured(only_gyro)) < 0.05 * abs(fixed_gyro)
    # a ramp is followed by the bias states: a fraction of the fixed-IMU figure is left
    assert 0.0 < abs(_measured(both)) < 0.3 * abs(fixed_both)
    assert math.isnan(both.mechanism["none"]["predicted_heading_arcsec"])
    # why none is made: the formula with each instant's attitude (table angle included)
    # misses the filter by far more than 10 % (−23″ against −1″; +200″ against +58″)
    for r, g_, ra in ((only_gyro, gyro, (0.0, 0.0)), (both, gyro, ramp)):
        assert abs(_formula_at_each_instant(r.cfg, _errors(g_, ra)) - _measured(r)) > 2 * abs(
            _measured(r)
        )
    table = mechanism_table([only_gyro, both])
    assert PREDICTED_COLUMN not in table  # no run held its table still
    s = mechanism_summary(table, _decomposition(), table.iloc[:0])
    assert s["n_predicted"] == 0
    words = mechanism_words({**s, "n_runs": 2})
    assert "In 2 of 2 runs the table indexes" in words and "predicts" not in words


def test_summary_words_follow_the_runs_with_a_prediction() -> None:
    still = _run(_errors(*CASES[0]), indexing=False)
    turning = _run(_errors(*CASES[0]), indexing=True)
    table = mechanism_table([still, turning])
    s = mechanism_summary(table, _decomposition(), table.iloc[:0])
    assert s["n_predicted"] == 1 and s["same_sign"] == 1
    assert s["attenuation"] == pytest.approx(1.0, abs=0.1)  # measured ≈ predicted
    words = mechanism_words({**s, "n_runs": 2})
    assert "In 1 of 2 runs the table held still" in words
    assert "In 1 of 2 runs the table indexes" in words


def _formula_at_each_instant(cfg, err) -> float:
    """The fixed-IMU formula on the residual resolved with the true attitude at each second
    of the fine alignment, whatever the table does [″]."""
    lat = cfg.trajectory.lat0
    g = float(earth.gravity(lat, cfg.trajectory.alt0))
    t = np.arange(cfg.align_start_s + cfg.align.coarse_s, cfg.nav_start_s + 1e-9, 1.0)
    return fixed_imu_heading_error(lat, g, t, _C_nr(cfg, t), err(t)) / units.ARCSEC_TO_RAD


def _decomposition():
    """An oracle decomposition with no run (the summary's oracle part is not tested here)."""
    cols = ["run", "none [nmi]", "oracle [nmi]", "oracle w/o offsets [nmi]", "x", "angle"]
    return pd.DataFrame(columns=cols, dtype=float)

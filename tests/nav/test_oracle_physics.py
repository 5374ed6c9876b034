"""Physics of the oracle (the true thermal errors removed): what it must and must not do.

(i)   With every random error off (noise, bias random walk, outliers, turn-on offsets) and
      the size effect off, the oracle's raw signal is the ideal IMU's: it navigates to the
      ideal IMU's result, whose only error is the alignment's numerical floor (millimetres:
      the filter converges on error-free data, and 10 Hz integration of a static IMU is
      exact to rounding).
(ii)  With the thermal errors off, the oracle subtracts zero: it equals no compensation bit
      for bit; a model fitted on such a plant can only be wrong by its fit error, about a
      constant, which the rotating alignment estimates (horizontal) and so costs next to
      nothing.
(iii) Over independent cold starts (different seeds: turn-on offsets and noise drawn
      anew) the oracle beats no compensation: the paired differences none − oracle of the
      maximum error have a Student-t 95 % interval above zero. A single run may lose (the
      reproduction's report explains which and why); the mean over units may not.

Why 32 units, not 8: at one lab temperature the thermal part is almost the same vector on
every unit, while the turn-on offsets (the vertical gyro's above all, which neither the
rotation nor the alignment removes) point anywhere; the paired differences are bimodal,
about +0.55 nmi on three units in four and −0.55 nmi on the fourth (2 h runs). Eight or
sixteen units leave the interval across zero (measured: [−0.04, 0.62] and [−0.06, ...]
nmi); 32 resolve it ([0.20, 0.48] nmi) in about 10 s.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from rinscal import units
from rinscal.sim.config import load_imu
from rinscal.sim.field import ChamberProfile
from rinscal.sim.scenario import (
    ThermalPlant,
    align_for,
    constant_errors,
    oracle_compensator,
    preset,
    run_scenario,
)


def _setup(hours: float = 1.0, lab_c: float = 20.0):
    imu = load_imu("paper")
    imu = replace(imu, effects=replace(imu.effects, lever_arm=False))
    sc = preset("quasi-static", hours=hours, rate_hz=10.0, align=align_for(imu, 600.0))
    return imu, replace(sc, out_dt_s=10.0, chamber=ChamberProfile.constant(lab_c))


def test_without_random_errors_the_oracle_navigates_to_the_ideal_imu() -> None:
    imu, sc = _setup()
    ideal = run_scenario(sc, None, {"none": None}).errors["none"]
    plant = ThermalPlant.for_scenario(imu, sc, seed=3, noise=False, turn_on=False)
    res = run_scenario(sc, plant, {"none": None, "true": oracle_compensator(plant)})
    orc, none = res.errors["true"], res.errors["none"]
    # the thermal plant matters: uncompensated it drifts by hundreds of metres in 1 h
    assert none["horizontal_m"].max() > 100.0
    # the oracle is the ideal IMU (the same increments up to rounding)
    d = np.hypot(orc["east_m"] - ideal["east_m"], orc["north_m"] - ideal["north_m"])
    assert d.max() < 1e-3
    # and the ideal IMU's error is the alignment's floor: < 0.1 m, < 0.1″ of heading
    assert orc["horizontal_m"].max() < 0.1
    assert abs(orc["heading_err"].iloc[0]) / units.ARCSEC_TO_RAD < 0.1


def test_without_thermal_errors_the_oracle_is_no_compensation() -> None:
    imu, sc = _setup()
    plant = ThermalPlant.for_scenario(imu, sc, seed=5, thermal=False)
    # a thermal model fitted on this plant predicts its fit error: a constant, here 20 µg
    # and 0.002 °/h on the horizontal channels (typical soak-fit residual means)
    fit_error = np.array([0.002] * 2 + [0.0] + [0.0] * 3) * units.DPH_TO_RPS
    fit_error[3:5] = 20.0 * units.UG_TO_MPS2
    comps = {
        "none": None,
        "true": oracle_compensator(plant),
        "model": constant_errors(fit_error),
    }
    res = run_scenario(sc, plant, comps)
    none, orc, mod = (res.errors[v] for v in ("none", "true", "model"))
    for c in ("east_m", "north_m", "heading_err", "v_e_err", "v_n_err"):
        np.testing.assert_array_equal(orc[c].to_numpy(), none[c].to_numpy())
    # the constant model error is taken up by the rotating alignment: within a few per
    # cent of the oracle's error (noise and offsets are the same raw output)
    gap = np.hypot(mod["east_m"] - orc["east_m"], mod["north_m"] - orc["north_m"]).max()
    assert gap < 0.1 * orc["horizontal_m"].max()


def _paired_differences(n_units: int, hours: float) -> np.ndarray:
    imu, sc = _setup(hours=hours)
    out = []
    for seed in range(n_units):
        plant = ThermalPlant.for_scenario(imu, sc, seed=1000 + seed)
        res = run_scenario(sc, plant, {"none": None, "true": oracle_compensator(plant)})
        m = {v: res.errors[v]["horizontal_m"].max() / units.NMI_TO_M for v in ("none", "true")}
        out.append(m["none"] - m["true"])
    return np.asarray(out)


def _t_interval(d: np.ndarray) -> tuple[float, float]:
    half = stats.t.ppf(0.975, d.size - 1) * d.std(ddof=1) / np.sqrt(d.size)
    return float(d.mean() - half), float(d.mean() + half)


def test_over_units_the_oracle_beats_no_compensation() -> None:
    d = _paired_differences(n_units=32, hours=2.0)
    lo, hi = _t_interval(d)
    assert d.mean() > 0
    assert lo > 0, f"none − oracle [nmi]: {np.round(d, 3)}, 95 % interval [{lo:.3f}, {hi:.3f}]"


@pytest.mark.slow
def test_over_many_units_the_oracle_beats_no_compensation() -> None:
    d = _paired_differences(n_units=64, hours=3.0)
    lo, _ = _t_interval(d)
    assert d.mean() > 0 and lo > 0

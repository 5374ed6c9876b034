"""What the four-position modulation leaves: rotation-synchronous biases and the cycle mean.

A bias ``b_r`` fixed in the rotating frame ``r`` is, seen in the body, ``C_br(φ) b_r``
(Eqs. 6-7). Over a cycle of the schedule its mean is the body-frame bias the navigation
really integrates; the rest only ripples. Two consequences checked here, each against the
cycle mean of a function of the encoder angle computed by quadrature of the schedule's
trapezoidal-rate moves (written out below from positions, dwell, rate and acceleration,
independently of :class:`RotationSchedule`):

* a bias ``b cos φ`` on the x gyro (rotation-synchronous: heat or a magnetic field fixed in
  the body, seen by a rotating sensor) is, in the body, ``b (cos²φ, cos φ sin φ)``, whose
  cycle mean is ``b/2`` along body x less what the moves take away: the modulation does
  *not* cancel it, and the position error grows as for a constant body-frame bias of about
  ``b/2``;
* a constant x bias is cancelled only to ``⟨cos φ⟩`` (the moves −135° → 45° and
  135° → −45° both sweep through cos φ > 0): about 5.45 % with the 60 s dwell, 10 °/s and
  10 °/s² of the default schedule.

The gyro is used (not the accelerometer) because a gyro bias makes the error *grow*
(``R ε t``), whereas the ripple around the cycle mean only adds Schuler oscillations with
zero phase at whole Schuler periods, where the errors are compared.
"""

from __future__ import annotations

import math

import numpy as np

from rinscal import units
from rinscal.nav.rotation import RotationSchedule
from rinscal.sim.scenario import ScenarioConfig, constant_errors, run_scenario
from rinscal.sim.trajectory import StaticMotion
from tests.nav._modulation import ACCEL_DPS2, DWELL_S, POSITIONS_DEG, RATE_DPS, cycle_mean

DPH = units.DPH_TO_RPS
SITE = StaticMotion(heading_deg=45.0)
#: WGS84 (own constants, not the package's): Schuler period at the site
_A, _E2 = 6378137.0, 6.69437999014e-3


def _schuler_period() -> float:
    s2 = math.sin(SITE.lat0) ** 2
    r = _A / math.sqrt(1 - _E2 * s2) + SITE.alt0
    g = 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - _E2 * s2)
    return 2 * math.pi * math.sqrt(r / g)


def _run(errors, hours: float):  # type: ignore[no-untyped-def]
    sched = RotationSchedule.four_position(DWELL_S, RATE_DPS, ACCEL_DPS2, POSITIONS_DEG)
    cfg = ScenarioConfig("m", SITE, sched, hours * 3600.0, 10.0, align=None, out_dt_s=1.0)
    return run_scenario(cfg, errors).errors["none"], sched


def _body_fixed(sched: RotationSchedule, ch: int, bx: float, by: float):  # type: ignore[no-untyped-def]
    """Error source of a constant body-frame bias (bx, by) on sensor triad ``ch`` (0 gyro,
    3 accel), resolved in ``r``: C_rb(φ) (bx, by)."""

    def errors(t: np.ndarray, *_signal: np.ndarray) -> np.ndarray:
        p = sched.angle(t)
        e = np.zeros((t.shape[0], 6))
        e[:, ch] = bx * np.cos(p) + by * np.sin(p)
        e[:, ch + 1] = -bx * np.sin(p) + by * np.cos(p)
        return e

    return errors


def _at(df, t: float) -> np.ndarray:  # type: ignore[no-untyped-def]
    i = int(np.argmin(np.abs(df["time_s"].to_numpy() - t)))
    return df[["east_m", "north_m"]].to_numpy()[i]


def test_cycle_mean_of_the_schedule_leaves_about_five_percent_of_a_constant_x_bias() -> None:
    """⟨cos φ⟩ over the default cycle ≈ 5.45 %, ⟨sin φ⟩ = 0; the schedule agrees."""
    mc, cycle = cycle_mean(math.cos)
    ms, _ = cycle_mean(math.sin)
    # the cycle: 4 dwells, two 180° moves (1 + 17 + 1 s), two 90° moves (1 + 8 + 1 s)
    assert cycle == 4 * 60.0 + 2 * 19.0 + 2 * 10.0
    assert 0.0540 < mc < 0.0550 and abs(ms) < 1e-12
    sched = RotationSchedule.four_position()
    assert sched.period == cycle
    n = 400_000
    t = (np.arange(n) + 0.5) * (cycle / n)  # midpoint rule over one cycle
    phi = sched.angle(t)
    assert abs(np.mean(np.cos(phi)) - mc) < 1e-6
    assert abs(np.mean(np.sin(phi)) - ms) < 1e-6
    # shorter dwells leave more: the moves are a larger share of the cycle
    assert cycle_mean(math.cos, dwell_s=20.0)[0] > 2 * mc


def test_constant_x_gyro_bias_navigates_as_its_cycle_mean_fixed_in_the_body() -> None:
    """A constant x-gyro bias b in r, four-position: the position error equals that of the
    constant body-frame bias b (⟨cos φ⟩, ⟨sin φ⟩) within 2 % at two Schuler periods."""
    b = 0.1 * DPH
    mc, _ = cycle_mean(math.cos)
    ms, _ = cycle_mean(math.sin)
    ts = 2 * _schuler_period()
    rot, sched = _run(constant_errors(np.array([b, 0, 0, 0, 0, 0.0])), ts / 3600 + 0.05)
    eq, _ = _run(_body_fixed(sched, 0, b * mc, b * ms), ts / 3600 + 0.05)
    p_rot, p_eq = _at(rot, ts), _at(eq, ts)
    assert np.hypot(*p_eq) > 1000.0  # R ε t with ε = 5.4 % of 0.1 °/h over 2.8 h
    assert np.hypot(*(p_rot - p_eq)) < 0.02 * np.hypot(*p_eq)
    # and the modulation did cut the bias ~18×: the same bias fixed in the body
    fixed, _ = _run(_body_fixed(sched, 0, b, 0.0), ts / 3600 + 0.05)
    ratio = np.hypot(*p_rot) / np.hypot(*_at(fixed, ts))
    assert abs(ratio - mc) < 0.05 * mc


def test_rotation_synchronous_bias_is_not_cancelled() -> None:
    """A bias b cos φ on the x gyro (in r) is not modulated away: the position error grows
    as for a constant body-frame bias of b/2 (within 5 %), more exactly of b ⟨cos²φ⟩ (the
    moves take a little; within 1 %)."""
    b = 0.05 * DPH
    ts = 2 * _schuler_period()
    sched = RotationSchedule.four_position(DWELL_S, RATE_DPS, ACCEL_DPS2, POSITIONS_DEG)

    def synchronous(t: np.ndarray, *_signal: np.ndarray) -> np.ndarray:
        e = np.zeros((t.shape[0], 6))
        e[:, 0] = b * np.cos(sched.angle(t))
        return e

    hours = ts / 3600 + 0.05
    sync, _ = _run(synchronous, hours)
    half, _ = _run(_body_fixed(sched, 0, 0.5 * b, 0.0), hours)
    p_sync, p_half = _at(sync, ts), _at(half, ts)
    assert np.hypot(*p_half) > 5000.0
    assert np.hypot(*(p_sync - p_half)) < 0.05 * np.hypot(*p_half)
    c2, _ = cycle_mean(lambda p: math.cos(p) ** 2)
    cs, _ = cycle_mean(lambda p: math.cos(p) * math.sin(p))
    assert 0.47 < c2 < 0.49 and abs(cs) < 1e-12
    exact, _ = _run(_body_fixed(sched, 0, b * c2, b * cs), hours)
    p_exact = _at(exact, ts)
    assert np.hypot(*(p_sync - p_exact)) < 0.01 * np.hypot(*p_exact)
    # whereas a constant bias of the same size is cut to ⟨cos φ⟩ ≈ 5 %
    const, _ = _run(constant_errors(np.array([b, 0, 0, 0, 0, 0.0])), hours)
    assert np.hypot(*_at(const, ts)) < 0.15 * np.hypot(*p_sync)

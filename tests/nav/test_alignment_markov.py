"""Alignment with Gauss-Markov bias states, a configurable start, and what a bias step costs.

The issue: with random-constant bias states, a bias that changes during a cold-start
alignment is aliased into heading (a 20 µg accelerometer step in the middle of the 10 min
alignment cost −58 arcsec of heading), while the same step after the alignment is modulated
away by the rotation. The bias states are now first-order Gauss-Markov processes.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rinscal import units
from rinscal.errors import ConfigError
from rinscal.nav.align import AlignConfig
from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.sim.config import ImuConfig
from rinscal.sim.scenario import ScenarioConfig, align_for, preset, run_scenario
from rinscal.sim.trajectory import StaticMotion, vehicle_route
from tests.nav._modulation import cycle_mean

DPH = units.DPH_TO_RPS
UG = units.UG_TO_MPS2
AS = units.ARCSEC_TO_RAD
SITE = StaticMotion(heading_deg=45.0)
FOUR = RotationSchedule.four_position()
#: the filter without process noise on its bias states (as before the Markov model)
NO_MARKOV = AlignConfig(gyro_bias_markov_sd=0.0, accel_bias_markov_sd=0.0)


def _step(channel: int, t0: float, size: float):  # type: ignore[no-untyped-def]
    """Error source: a bias of ``size`` on ``channel`` (r frame) from ``t0`` on."""

    def errors(t: np.ndarray, *_signal: np.ndarray) -> np.ndarray:
        e = np.zeros((t.shape[0], 6))
        e[:, channel] = np.where(t >= t0, size, 0.0)
        return e

    return errors


def _run(errors, align=None, schedule=FOUR, hours: float = 1.5, out_dt_s: float = 10.0):  # type: ignore[no-untyped-def]
    al = AlignConfig() if align is None else align
    cfg = ScenarioConfig("s", SITE, schedule, hours * 3600, 10.0, align=al, out_dt_s=out_dt_s)
    return run_scenario(cfg, errors)


# --------------------------------------------------------------------------- settings
@pytest.mark.parametrize(
    ("name", "bad"),
    [
        ("start_s", -1.0),
        ("start_s", math.nan),
        ("start_s", math.inf),
        ("gyro_bias_tau_s", 0.0),
        ("gyro_bias_tau_s", -600.0),
        ("gyro_bias_tau_s", math.inf),
        ("gyro_bias_tau_s", math.nan),
        ("gyro_bias_markov_sd", -1e-9),
        ("gyro_bias_markov_sd", math.nan),
        ("gyro_bias_markov_sd", math.inf),
        ("accel_bias_tau_s", 0.0),
        ("accel_bias_tau_s", -1.0),
        ("accel_bias_tau_s", math.inf),
        ("accel_bias_markov_sd", -1e-6),
        ("accel_bias_markov_sd", math.nan),
    ],
)
def test_new_alignment_settings_are_validated(name: str, bad: float) -> None:
    with pytest.raises(ConfigError, match=f"alignment: {name} must be"):
        AlignConfig(**{name: bad})


def test_default_markov_settings_suit_a_fog_and_quartz_unit() -> None:
    """Defaults: 0.003 °/h and 10 µg with a correlation time of an hour; zero switches the
    process model off. The end of the alignment is start + coarse + fine."""
    c = AlignConfig()
    assert c.gyro_bias_markov_sd == pytest.approx(0.003 * DPH)
    assert c.accel_bias_markov_sd == pytest.approx(10 * UG)
    assert c.gyro_bias_tau_s == c.accel_bias_tau_s == 3600.0
    assert c.start_s == 0.0
    c = AlignConfig(start_s=120.0, coarse_s=60.0, fine_s=240.0)
    assert (c.total_s, c.end_s) == (300.0, 420.0)
    assert NO_MARKOV.gyro_bias_markov_sd == NO_MARKOV.accel_bias_markov_sd == 0.0


def test_align_for_passes_start_and_markov_settings() -> None:
    imu = ImuConfig.navigation_grade()
    a = align_for(imu, total_s=300.0, start_s=120.0)
    assert (a.start_s, a.coarse_s, a.fine_s, a.end_s) == (120.0, 60.0, 240.0, 420.0)
    d = AlignConfig()
    # the preset's bias random walk is far below the defaults' driving noise: defaults kept
    assert a.gyro_bias_markov_sd == d.gyro_bias_markov_sd
    assert a.accel_bias_markov_sd == d.accel_bias_markov_sd
    assert a.gyro_noise_density == pytest.approx(imu.noise.gyro_arw_deg_rth * units.DPRH_TO_RPRS)
    # a plant with a poor accelerometer (100 µg/√h of bias random walk): the filter's
    # driving noise 2σ²/τ is raised to it, σ = 100 µg/√h · √(τ/2) = 100/60 µg/√s · √1800 s
    noisy = dataclasses.replace(
        imu, noise=dataclasses.replace(imu.noise, accel_bias_rw_ug_rth=100.0)
    )
    a = align_for(noisy)
    assert a.accel_bias_markov_sd == pytest.approx(100.0 / 60.0 * math.sqrt(1800.0) * UG)
    # given values are used as they are
    a = align_for(noisy, accel_bias_markov_sd=0.0, gyro_bias_tau_s=900.0)
    assert a.accel_bias_markov_sd == 0.0 and a.gyro_bias_tau_s == 900.0
    with pytest.raises(ConfigError, match="start_s"):
        align_for(imu, start_s=-5.0)
    with pytest.raises(ConfigError, match="alignment time"):
        align_for(imu, total_s=0.0)


def test_bias_state_variance_follows_the_gauss_markov_closed_form() -> None:
    """The vertical accelerometer bias is not observable from horizontal zero velocity on a
    level base: its filter variance evolves by the process model alone,
    P(T) = P0 e^(−2T/τ) + σ² (1 − e^(−2T/τ)) over the fine alignment T; and stays P0 for
    random constants."""
    p0, sd, tau = 100 * UG, 30 * UG, 300.0
    al = AlignConfig(accel_bias_sd=p0, accel_bias_markov_sd=sd, accel_bias_tau_s=tau)
    res = _run(None, al, hours=0.2).alignment["none"]
    decay = math.exp(-2 * al.fine_s / tau)
    expected = math.sqrt(p0**2 * decay + sd**2 * (1 - decay))
    assert expected < 0.4 * p0
    assert res.accel_bias_sd[2] == pytest.approx(expected, rel=1e-3)
    res = _run(None, dataclasses.replace(al, accel_bias_markov_sd=0.0), hours=0.2)
    assert res.alignment["none"].accel_bias_sd[2] == pytest.approx(p0, rel=1e-6)


# --------------------------------------------------------------------------- start
def test_samples_before_the_alignment_start_are_ignored() -> None:
    """Whatever the IMU does before the alignment starts is ignored: an error source that is
    wild until then (1 °/h and 1 mg) gives exactly the run of an ideal IMU. Errors are
    reported from the navigation start (alignment start + length) on."""
    al = AlignConfig(start_s=150.0, coarse_s=60.0, fine_s=240.0)
    cfg = ScenarioConfig("w", SITE, FOUR, 900.0, 10.0, align=al, out_dt_s=1.0)
    assert cfg.nav_start_s == 450.0 and cfg.align_start_s == 150.0

    def wild_until_start(t: np.ndarray, *_signal: np.ndarray) -> np.ndarray:
        e = np.zeros((t.shape[0], 6))
        e[t < 150.0] = [DPH, -DPH, DPH, 1000 * UG, -1000 * UG, 1000 * UG]
        return e

    wild = run_scenario(cfg, wild_until_start)
    ideal = run_scenario(cfg)
    np.testing.assert_array_equal(wild.errors["none"].to_numpy(), ideal.errors["none"].to_numpy())
    t = wild.errors["none"]["time_s"].to_numpy()
    assert t[0] == 451.0 and t[-1] == 900.0 and np.all(np.diff(t) == 1.0)
    np.testing.assert_array_equal(wild.truth["time_s"].to_numpy(), t)
    s = wild.summary()
    assert (s["alignment_start_s"], s["alignment_s"], s["navigation_start_s"]) == (
        150.0,
        300.0,
        450.0,
    )
    # the same wild start inside the alignment ruins it
    early = run_scenario(dataclasses.replace(cfg, align=dataclasses.replace(al, start_s=0.0)))
    assert early.errors["none"]["time_s"].iloc[0] == 301.0
    bad = run_scenario(
        dataclasses.replace(cfg, align=dataclasses.replace(al, start_s=100.0)), wild_until_start
    )
    assert bad.max_error_m("none") > 100 * wild.max_error_m("none") + 1.0


def test_carrier_must_stand_still_until_the_alignment_ends() -> None:
    al = AlignConfig(start_s=300.0, coarse_s=60.0, fine_s=240.0)
    cfg = preset("vehicle", hours=0.05, rate_hz=10.0, align=al)
    assert cfg.nav_start_s == 600.0
    assert cfg.trajectory.stationary_until == 600.0
    v = cfg.trajectory.kinematics(np.array([0.0, 599.0, 700.0])).v_n
    assert np.all(v[:2] == 0.0) and np.hypot(*v[2, :2]) > 1.0
    moving = vehicle_route(duration_s=600.0, stationary_s=500.0)
    with pytest.raises(ConfigError, match=r"moves at 500\.0 s, before the alignment ends at 600"):
        ScenarioConfig("v", moving, FOUR, 1100.0, 10.0, align=al)
    with pytest.raises(ConfigError, match="must end before the run"):
        ScenarioConfig("q", SITE, FOUR, 600.0, 10.0, align=al)


# --------------------------------------------------------------------------- bias steps
def test_bias_step_after_the_alignment_is_modulated_by_the_rotation() -> None:
    """A 20 µg x-accelerometer step half an hour into the run: with the four-position
    rotation it costs under a tenth of the same step without rotation; to be exact, the
    cycle mean ⟨cos φ⟩ ≈ 5.45 % of it (the part the modulation leaves), within 10 %."""
    step = _step(3, 1800.0, 20 * UG)
    rot = _run(step).max_error_m("none")
    still = _run(step, schedule=RotationSchedule.none()).max_error_m("none")
    # without rotation: the Schuler peak 2∇/ω_s² ≈ 255 m of a constant bias
    assert 240.0 < still < 270.0
    assert rot < 0.1 * still
    mc, _ = cycle_mean(math.cos)
    assert rot / still == pytest.approx(mc, rel=0.10)


def test_bias_step_inside_the_alignment_costs_heading() -> None:
    """The same step in the middle of the alignment (300 s) costs more than after it (1800 s),
    through the heading error that the summary reports at the navigation start; the
    Gauss-Markov bias states cut that heading error and the position error ≥ 4× against
    the random-constant filter (−58.5 → −9.5 arcsec, 0.33 → 0.05 nmi in 1.5 h), less with
    a smaller σ (5 µg: −21 arcsec)."""
    inside = _run(_step(3, 300.0, 20 * UG), out_dt_s=1.0)
    after = _run(_step(3, 1800.0, 20 * UG), out_dt_s=1.0)
    h_in = inside.summary()["variants"]["none"]["attitude_error_at_nav_start"]
    h_after = after.summary()["variants"]["none"]["attitude_error_at_nav_start"]
    assert set(h_in) == {"heading_arcsec", "pitch_arcsec", "roll_arcsec"}
    assert abs(h_after["heading_arcsec"]) < 0.05  # the alignment saw an ideal IMU
    assert abs(h_in["heading_arcsec"]) > 3.0
    assert inside.max_error_m("none") > 3 * after.max_error_m("none")
    # the summary's heading error, independently: the aligned C_nr through the encoder
    # angle at the navigation start, heading = atan2(C_nb[0,1], C_nb[1,1]) against 45°
    res = inside.alignment["none"]
    C_nb = res.C_nr @ C_br(FOUR.angle(600.0)[0]).T
    heading = math.atan2(C_nb[0, 1], C_nb[1, 1])
    assert (heading - math.radians(45.0)) / AS == pytest.approx(h_in["heading_arcsec"], abs=0.05)
    # the filter without process noise on its biases aliases the step into heading
    old = _run(_step(3, 300.0, 20 * UG), NO_MARKOV, out_dt_s=1.0)
    h_old = old.summary()["variants"]["none"]["attitude_error_at_nav_start"]["heading_arcsec"]
    assert abs(h_old) > 4 * abs(h_in["heading_arcsec"])
    assert abs(h_old) > 40.0
    assert old.max_error_m("none") > 4 * inside.max_error_m("none")
    tight = dataclasses.replace(AlignConfig(), accel_bias_markov_sd=5 * UG)
    narrow = _run(_step(3, 300.0, 20 * UG), tight, out_dt_s=1.0).summary()["variants"]["none"]
    h_narrow = narrow["attitude_error_at_nav_start"]["heading_arcsec"]
    assert abs(h_in["heading_arcsec"]) < 0.6 * abs(h_narrow) < 0.6 * abs(h_old)

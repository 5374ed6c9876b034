"""Self-alignment: inertial-frame coarse stage and zero-velocity Kalman filter."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rinscal import earth, units
from rinscal.nav.align import AlignConfig, InertialCoarseAlign, wahba
from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.nav.strapdown import rotvec_to_dcm
from rinscal.sim.ideal_imu import ImuSynthesizer
from rinscal.sim.scenario import ScenarioConfig, constant_errors, run_scenario
from rinscal.sim.trajectory import C_nb_from_euler, StaticMotion, SwingMotion

DPH = units.DPH_TO_RPS
UG = units.UG_TO_MPS2
AS = units.ARCSEC_TO_RAD
BIAS = np.array([0.01 * DPH, -0.008 * DPH, 0.005 * DPH, 50 * UG, -40 * UG, 30 * UG])


def test_wahba_recovers_a_rotation() -> None:
    rng = np.random.default_rng(0)
    C = rotvec_to_dcm([0.3, -1.1, 2.0])
    b = rng.normal(size=(10, 3))
    np.testing.assert_allclose(wahba(b @ C.T, b), C, atol=1e-12)


@pytest.mark.parametrize(
    "traj", [StaticMotion(heading_deg=45.0), SwingMotion()], ids=["static", "swing"]
)
def test_inertial_frame_coarse_alignment_works_on_a_moving_base(traj) -> None:  # type: ignore[no-untyped-def]
    """Ideal IMU, turntable rotating: 90 s give the attitude to better than 5 arcsec.

    (The heading comes from the small Earth-rotation curvature of the integrated specific
    force; the integrator's own O(dt⁴) sculling error on the swinging base is what remains.)
    """
    sched = RotationSchedule.four_position(dwell_s=20.0)
    syn = ImuSynthesizer(traj, sched, rate_hz=50.0)
    ch = syn.next_chunk(50 * 90)
    co = InertialCoarseAlign(traj.lat0, traj.alt0, 1 / 50)
    co.feed(ch.dtheta, ch.dv)
    C = co.solve()
    C_true = C_nb_from_euler(ch.euler[-1]) @ C_br(ch.encoder[-1])
    M = C_true @ C.T
    err = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
    assert np.max(np.abs(err[:2])) < 1e-7
    assert abs(err[2]) < 5 * AS


def _align(traj, sched, errors, rate: float = 50.0, align=None):  # type: ignore[no-untyped-def]
    al = AlignConfig() if align is None else align
    cfg = ScenarioConfig("align", traj, sched, 700.0, rate, align=al, out_dt_s=1.0)
    r = run_scenario(cfg, errors)
    att = r.errors["none"][["att_e", "att_n", "att_u"]].to_numpy()[0]
    return att, r.alignment["none"]


#: the filter without process noise on its bias states (random constants)
NO_MARKOV = AlignConfig(gyro_bias_markov_sd=0.0, accel_bias_markov_sd=0.0)


def test_unrotated_alignment_reaches_the_classical_limits() -> None:
    """Static, no rotation: tilt φ_E = −∇_N/g, φ_N = ∇_E/g; heading ψ = −ε_E/(Ω cos L).

    Without rotation the horizontal biases are not observable: the bias states being random
    constants (no process noise), the filter leaves them at zero and the classical limits
    hold for the whole bias. With Gauss-Markov bias states it moves part of the level error
    into its (unobservable) bias estimate, and the same limits hold for what it leaves,
    the true bias minus its estimate: the zero-velocity update makes tilt and residual bias
    cancel whatever the split.
    """
    traj = StaticMotion(heading_deg=0.0)  # r x east, y north
    g = float(earth.gravity(traj.lat0, traj.alt0))
    om = earth.RATE * math.cos(traj.lat0)
    att, res = _align(traj, RotationSchedule.none(), constant_errors(BIAS), align=NO_MARKOV)
    np.testing.assert_allclose(att[0], -BIAS[4] / g, rtol=0.05)
    np.testing.assert_allclose(att[1], BIAS[3] / g, rtol=0.05)
    np.testing.assert_allclose(att[2], -BIAS[0] / om, rtol=0.10)
    assert abs(att[2]) > 100 * AS
    att, res = _align(traj, RotationSchedule.none(), constant_errors(BIAS))
    left = BIAS - np.concatenate([res.gyro_bias, res.accel_bias])
    assert abs(left[3] - BIAS[3]) > 0.05 * abs(BIAS[3])  # it did move some into the estimate
    np.testing.assert_allclose(att[0], -left[4] / g, rtol=0.02)
    np.testing.assert_allclose(att[1], left[3] / g, rtol=0.02)
    np.testing.assert_allclose(att[2], -left[0] / om, rtol=0.10)


@pytest.mark.parametrize(
    "traj", [StaticMotion(heading_deg=45.0), SwingMotion()], ids=["static", "swing"]
)
def test_four_position_alignment_estimates_horizontal_biases(traj) -> None:  # type: ignore[no-untyped-def]
    """With the table turning, horizontal biases become observable and are estimated; the
    attitude is then far better than the classical limits above."""
    rng = np.random.default_rng(7)
    dt = 1 / 50
    white = np.array([0.001 * units.DPRH_TO_RPRS] * 3 + [10 * UG] * 3) / math.sqrt(dt)

    def errors(t: np.ndarray, *_signal: np.ndarray) -> np.ndarray:
        return BIAS + white * rng.standard_normal((t.shape[0], 6))

    att, res = _align(traj, RotationSchedule.four_position(), errors)
    assert np.all(np.abs(att[:2]) < 1.0 * AS)
    assert abs(att[2]) < 60.0 * AS  # the unrotated limit is 160 arcsec
    assert abs(att[2]) < 3 * res.attitude_sd[2]
    # estimates agree with the truth within 3 filter sigmas, and the sigmas are small
    assert np.all(np.abs(res.gyro_bias[:2] - BIAS[:2]) < 3 * res.gyro_bias_sd[:2])
    assert np.all(res.gyro_bias_sd[:2] < AlignConfig().gyro_bias_sd / 4)  # observable
    assert np.all(np.abs(res.accel_bias[:2] - BIAS[3:5]) < 3 * res.accel_bias_sd[:2])
    np.testing.assert_allclose(res.accel_bias[:2], BIAS[3:5], rtol=0.05)


def test_alignment_config_validation() -> None:
    from rinscal.errors import ConfigError

    with pytest.raises(ConfigError, match="coarse_s"):
        AlignConfig(coarse_s=0.0)
    traj = StaticMotion()
    with pytest.raises(ConfigError, match="alignment"):
        ScenarioConfig("x", traj, RotationSchedule.none(), 500.0, 10.0, align=AlignConfig())

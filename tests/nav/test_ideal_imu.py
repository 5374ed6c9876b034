"""Exact ideal-IMU synthesis and the strapdown integrator closing the loop on it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rinscal import earth
from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.sim.ideal_imu import ImuSynthesizer, body_signals
from rinscal.sim.scenario import ScenarioConfig, run_scenario
from rinscal.sim.trajectory import (
    C_nb_from_euler,
    StaticMotion,
    SwingMotion,
    body_rate_from_euler,
    euler_from_C_nb,
    vehicle_route,
)

D2R = math.pi / 180


def test_vectorised_euler_matches_earth_module_and_inverts() -> None:
    rng = np.random.default_rng(3)
    e = rng.uniform([-math.pi, -1.2, -math.pi], [math.pi, 1.2, math.pi], size=(50, 3))
    C = C_nb_from_euler(e)
    for k in range(5):
        np.testing.assert_allclose(C[k], earth.C_nb_from_euler(*e[k]), atol=1e-15)
    np.testing.assert_allclose(euler_from_C_nb(C), e, atol=1e-12)
    # heading 90° points the body y (forward) axis east
    np.testing.assert_allclose(C_nb_from_euler([90 * D2R, 0, 0]) @ [0, 1, 0], [1, 0, 0], atol=1e-15)


def test_body_rate_from_euler_matches_attitude_derivative() -> None:
    """ω_nb^b from Euler rates equals vee(C_bn dC_nb/dt) by finite differences."""
    sw = SwingMotion(amplitude_deg=(20.0, 15.0, 25.0), period_s=(7.0, 5.0, 3.0))
    t = np.array([0.3, 1.7, 4.1])
    h = 1e-6
    kin = sw.kinematics(t)
    w = body_rate_from_euler(kin.euler, kin.euler_rate)
    Cp = C_nb_from_euler(sw.kinematics(t + h).euler)
    Cm = C_nb_from_euler(sw.kinematics(t - h).euler)
    C = C_nb_from_euler(kin.euler)
    W = np.einsum("mji,mjk->mik", C, (Cp - Cm) / (2 * h))
    np.testing.assert_allclose(np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1), w, atol=1e-8)


@pytest.mark.parametrize("heading_deg, encoder_deg", [(0.0, 0.0), (45.0, -135.0), (-70.0, 33.0)])
def test_static_ideal_imu_is_exactly_earth_rate_and_gravity(
    heading_deg: float, encoder_deg: float
) -> None:
    st = StaticMotion(heading_deg=heading_deg, lat_deg=32.06, alt_m=10.0)
    syn = ImuSynthesizer(st, RotationSchedule.none(encoder_deg), rate_hz=100.0)
    ch = syn.next_chunk(50)
    # the r-frame y axis points at heading + (−encoder) (encoder turns r counter-clockwise)
    w, f = earth.static_outputs_r(st.lat0, (heading_deg - encoder_deg) * D2R, st.alt_m)
    np.testing.assert_allclose(ch.dtheta, np.tile(w * 0.01, (50, 1)), rtol=0, atol=1e-20)
    np.testing.assert_allclose(ch.dv, np.tile(f * 0.01, (50, 1)), rtol=0, atol=1e-15)
    assert np.linalg.norm(ch.dtheta[0]) / 0.01 == pytest.approx(earth.RATE, rel=1e-14)
    assert np.linalg.norm(ch.dv[0]) / 0.01 == pytest.approx(earth.gravity(st.lat0, 10.0), rel=1e-14)


def test_rotating_table_increments_match_fine_numerical_integration() -> None:
    """Increments during a table move equal a 2000-point midpoint integration of Eqs. 2-3."""
    st = StaticMotion(heading_deg=45.0)
    sch = RotationSchedule.four_position(dwell_s=1.0, rate_dps=20.0, accel_dps2=30.0)
    syn = ImuSynthesizer(st, sch, rate_hz=10.0)
    ch = syn.next_chunk(40)
    kin = st.kinematics(np.zeros(1))
    w_b, f_b = body_signals(kin, np.array([st.lat0]), np.array([st.alt0]))
    for k in (9, 10, 11, 17, 25):
        ta, tb = k * 0.1, (k + 1) * 0.1
        tt = ta + (np.arange(2000) + 0.5) * (tb - ta) / 2000
        phi, rate, _ = sch.evaluate(tt)
        C_rb = np.swapaxes(C_br(phi), 1, 2)
        wr = C_rb @ w_b[0] + rate[:, None] * np.array([0, 0, 1.0])
        fr = C_rb @ f_b[0]
        np.testing.assert_allclose(ch.dtheta[k], wr.mean(0) * 0.1, rtol=1e-6, atol=1e-13)
        np.testing.assert_allclose(ch.dv[k], fr.mean(0) * 0.1, rtol=1e-6, atol=1e-9)


def test_vehicle_truth_position_integrates_velocity() -> None:
    route = vehicle_route(duration_s=1200.0, stationary_s=30.0)
    syn = ImuSynthesizer(route, RotationSchedule.none(), rate_hz=20.0)
    chunks = list(syn.chunks(1230.0, chunk_s=60.0))
    lat = np.concatenate([c.lat for c in chunks])
    lon = np.concatenate([c.lon for c in chunks])
    alt = np.concatenate([c.alt for c in chunks])
    v = np.concatenate([c.v_n for c in chunks])
    rn, re = earth.principal_radii(lat)
    # central differences of the position equal the velocity
    vn = np.gradient(lat, 0.05)[1:-1] * (rn + alt)[1:-1]
    ve = np.gradient(lon, 0.05)[1:-1] * ((re + alt) * np.cos(lat))[1:-1]
    vu = np.gradient(alt, 0.05)[1:-1]
    np.testing.assert_allclose(np.c_[ve, vn, vu], v[1:-1], atol=2e-3)
    speed = np.linalg.norm(v, axis=1)
    assert speed.max() > 15.0 and np.all(speed[: 29 * 20] == 0.0)
    assert alt.max() - alt.min() > 5.0  # up- and downhill


def _run_ideal(traj, sched, hours: float, rate: float) -> np.ndarray:  # type: ignore[no-untyped-def]
    cfg = ScenarioConfig("ideal", traj, sched, hours * 3600.0, rate, align=None)
    return run_scenario(cfg).errors["none"]["horizontal_m"].to_numpy()


def test_ideal_four_position_2h_100hz_below_1mm() -> None:
    """Issue requirement: ideal IMU, four-position modulation, 2 h at 100 Hz: < 1 mm."""
    err = _run_ideal(StaticMotion(), RotationSchedule.four_position(), 2.0, 100.0)
    assert err.size == 7200
    assert err.max() < 1e-3


@pytest.mark.parametrize(
    "sched",
    [RotationSchedule.four_position(accel_dps2=None), RotationSchedule.continuous(6.0)],
    ids=["constant-rate-moves", "continuous"],
)
def test_ideal_rotating_imu_other_schedules(sched: RotationSchedule) -> None:
    err = _run_ideal(StaticMotion(), sched, 1.0, 50.0)
    assert err.max() < 1e-3


def test_ideal_vehicle_and_swing_close_the_loop() -> None:
    """Moving carriers: the residual is the integrator's own algorithm error (O(dt⁴))."""
    route = vehicle_route(duration_s=1800.0, stationary_s=60.0)
    assert _run_ideal(route, RotationSchedule.four_position(), 1860 / 3600, 100.0).max() < 0.01
    e50 = _run_ideal(SwingMotion(), RotationSchedule.none(), 0.25, 50.0).max()
    e100 = _run_ideal(SwingMotion(), RotationSchedule.none(), 0.25, 100.0).max()
    assert e100 < 0.05
    assert e50 / e100 > 8.0  # fourth-order: halving the step cuts the error ~16×

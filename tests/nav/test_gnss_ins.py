"""Aided navigation (issue 37, item 4): the error model against the strapdown, zero velocity
as a measurement against today's alignment, in-motion alignment on a GNSS track with no
heading given and no stop, GNSS-aided navigation, and pyins' filter on the same data.

The drive (``tests/nav/_drive.py``): the ``paper`` IMU, warm, strapped down in a car that
never stops (10-18 m/s, a 90°, a −120° and a 45° turn, two speed changes and a hill every
two minutes), increments at 50 Hz, GNSS positions at 1 Hz with 1.5 m white noise per
coordinate drawn in the test. No heading is given anywhere.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from rinscal import earth
from rinscal.nav.aiding import (
    ATT,
    GnssTrack,
    KnownPosition,
    NavState,
    ZeroVelocity,
    enu_difference,
)
from rinscal.nav.align import AlignConfig, Aligner, InertialCoarseAlign
from rinscal.nav.gnss_ins import (
    AidedInertial,
    ImuNoise,
    InitialSd,
    initial_covariance,
    run_aided,
)
from rinscal.nav.inmotion import coarse_in_motion, navigate_aided
from rinscal.nav.rotation import RotationSchedule
from rinscal.nav.strapdown import Strapdown, rotvec_to_dcm
from rinscal.sim.config import load_imu
from rinscal.sim.ideal_imu import static_increments
from rinscal.sim.trajectory import euler_from_C_nb
from tests.nav._drive import GNSS_SD_M, Drive, paper_noise, simulate_drive

HEADING_BOUND_DEG = 0.1  # the bound after 5 min


def _vee_phi(C_true: np.ndarray, C_est: np.ndarray) -> np.ndarray:
    """φ with C_est = (I − [φ×]) C_true, (..., 3) [rad]."""
    M = np.einsum("...ij,...kj->...ik", C_true, C_est)
    return 0.5 * np.stack(
        [M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]],
        axis=-1,
    )


def _heading_error_deg(drive: Drive, t: np.ndarray, C_nr: np.ndarray) -> np.ndarray:
    """Heading of the IMU frame minus the truth at times ``t`` [deg] (the body's heading
    error too: the table turns both attitudes alike about the body's z axis)."""
    k = np.searchsorted(drive.t, np.round(t, 6))
    d = euler_from_C_nb(C_nr)[..., 0] - euler_from_C_nb(drive.C_nr[k])[..., 0]
    return np.degrees((d + math.pi) % (2 * math.pi) - math.pi)


def _position_error_m(drive: Drive, t: np.ndarray, lat, lon, alt) -> np.ndarray:
    """ENU position error against the truth at times ``t`` (whole seconds), (m, 3) [m]."""
    k = np.searchsorted(drive.t, np.round(t, 6))
    assert np.allclose(drive.t[k], t, atol=1e-6)
    return enu_difference(lat, lon, alt, drive.lat[k], drive.lon[k], drive.alt[k])


# --------------------------------------------------------------------------- error model
def test_error_model_predicts_the_strapdown_error_growth() -> None:
    """Φ of the filter, propagated second by second along a turning, accelerating drive,
    predicts how the strapdown's errors from perturbed initial conditions and biases
    actually grow (ideal IMU, 120 s)."""
    d = simulate_drive(121.0, seed=0, thermal=False, noise=False, turn_on=False)
    per_s = round(1.0 / d.dt)
    i0 = per_s  # start at the first truth row (t = 1 s)

    def nav(C: np.ndarray, dr: np.ndarray, dv0: np.ndarray) -> Strapdown:
        rn, re = earth.principal_radii(d.lat[0])
        return Strapdown(
            d.lat[0] + dr[1] / (rn + d.alt[0]),
            d.lon[0] + dr[0] / ((re + d.alt[0]) * math.cos(d.lat[0])),
            d.alt[0] + dr[2],
            d.v_n[0] + dv0,
            C,
            d.dt,
            "free",
        )

    x0 = np.array([3.0, -2.0, 1.0, 0.05, -0.03, 0.02, 1e-4, -2e-4, 5e-4])
    eps = np.radians(np.array([0.5, -0.3, 0.8]) / 3600.0)  # gyro biases [rad/s]
    nabla = np.array([200.0, -300.0, 100.0]) * 9.80665e-6  # accelerometer biases [m/s²]
    ref = nav(d.C_nr[0], np.zeros(3), np.zeros(3))
    pert = nav(rotvec_to_dcm(-x0[6:9]) @ d.C_nr[0], x0[0:3], x0[3:6])
    noise = ImuNoise(0.0, 0.0, 0.0, 0.0)
    filt = AidedInertial(ref, np.zeros((15, 15)), noise)
    x = np.concatenate([x0, eps, nabla])
    err_max = np.zeros(3)
    for s in range(120):
        sl = slice(i0 + s * per_s, i0 + (s + 1) * per_s)
        x = filt.propagate(d.dtheta[sl], d.dv[sl]) @ x
        pert.run(d.dtheta[sl] + eps * d.dt, d.dv[sl] + nabla * d.dt)
        actual = np.concatenate(
            [
                enu_difference(pert.lat, pert.lon, pert.alt, ref.lat, ref.lon, ref.alt),
                pert.v_n - ref.v_n,
                _vee_phi(ref.C_nr, pert.C_nr),
            ]
        )
        err_max = np.maximum(err_max, np.abs(actual - x[:9]).reshape(3, 3).max(axis=1))
    # after 2 min the errors are 16 m, 0.19 m/s and 1.8e-4 rad ...
    assert np.abs(actual[0:3]).max() > 10.0
    assert np.abs(actual[3:6]).max() > 0.1
    assert np.abs(actual[6:9]).max() > 1e-4
    # ... and the model is right to within 0.2 % of them at every second (measured:
    # 0.03 %, 0.05 %, 0.02 %; what is left is second order in the errors)
    assert err_max[0] < 0.002 * np.abs(actual[0:3]).max()
    assert err_max[1] < 0.002 * np.abs(actual[3:6]).max()
    assert err_max[2] < 0.002 * np.abs(actual[6:9]).max()


# --------------------------------------------------------------------------- zero velocity
def test_zero_velocity_as_a_measurement_aligns_like_the_aligner() -> None:
    """Today's stationary alignment expressed as measurements (zero velocity and the known
    site) leaves the heading error an east gyro bias must leave, −ε_E/(Ω cos L) (the
    bias is indistinguishable from the heading at rest), as the Aligner does."""
    lat, lon, alt, dt = math.radians(32.06), math.radians(118.78), 10.0, 0.1
    n = round(600.0 / dt)
    w, f = static_increments(lat, 0.0, 0.0, dt, alt)  # r x east, y north
    eps_e = math.radians(0.01 / 3600.0)
    dtheta = np.tile(w + np.array([eps_e, 0.0, 0.0]) * dt, (n, 1))
    dv = np.tile(f, (n, 1))
    expected = -eps_e / (earth.RATE * math.cos(lat))  # −161.81″
    cfg = AlignConfig(gyro_bias_markov_sd=0.0, accel_bias_markov_sd=0.0)
    al = Aligner(lat, lon, alt, dt, cfg)
    al.feed(dtheta, dv)
    phi_aligner = _vee_phi(np.eye(3), al.result().C_nr)
    # ours: the same coarse stage, then the filter with the two measurements
    n_c = round(cfg.coarse_s / dt)
    coarse = InertialCoarseAlign(lat, alt, dt)
    coarse.feed(dtheta[:n_c], dv[:n_c])
    nav = Strapdown(lat, lon, alt, np.zeros(3), coarse.solve(), dt, "free")
    noise = ImuNoise(
        cfg.gyro_noise_density, cfg.accel_noise_density, cfg.gyro_bias_sd, cfg.accel_bias_sd
    )
    P0 = initial_covariance(InitialSd(0.01, 0.01, cfg.level_sd, cfg.heading_sd), noise)
    times = n_c * dt + np.arange(1, round(cfg.fine_s / cfg.kf_interval_s) + 1) * 0.5
    zv = ZeroVelocity(times, cfg.velocity_meas_sd, horizontal=False)
    site = KnownPosition(times, lat, lon, alt, 0.01)
    out = run_aided(
        AidedInertial(nav, P0, noise), dtheta[n_c:], dv[n_c:], n_c * dt, [zv, site], 0.5
    )
    phi_ours = _vee_phi(np.eye(3), out.C_nr[-1])
    # measured: −161.8119″ both (the formula: −161.8119″), 4e-7″ apart
    assert phi_ours[2] == pytest.approx(expected, rel=1e-3)
    assert phi_aligner[2] == pytest.approx(expected, rel=1e-3)
    assert abs(phi_ours[2] - phi_aligner[2]) < 0.01 * math.radians(1 / 3600)
    # the tilt is held by gravity (no accelerometer bias): 1e-4″ measured
    assert np.abs(phi_ours[:2]).max() < 0.01 * math.radians(1 / 3600)


def test_gnss_lever_arm_jacobian_is_the_derivative_of_the_residual() -> None:
    """With a lever arm, an attitude error moves the predicted antenna by (C l) × φ, and
    the Jacobian says so (finite difference of the residual)."""
    lat, lon, alt = math.radians(32.0), math.radians(118.0), 10.0
    C = rotvec_to_dcm([0.1, -0.2, 0.7])
    arm = np.array([0.4, 1.2, 0.9])
    omega = np.array([0.05, -0.02, 0.3])
    track = GnssTrack(
        [1.0], [lat], [lon], [alt], 1.5, v_n=[[3.0, 4.0, 0.0]], velocity_sd=0.1, lever_arm_r=arm
    )
    v = np.array([3.1, 3.9, 0.05])

    def residual(phi: np.ndarray) -> np.ndarray:
        st = NavState(1.0, lat, lon, alt, v, rotvec_to_dcm(-phi) @ C, omega)
        return track.linearise(0, st).residual

    H = track.linearise(0, NavState(1.0, lat, lon, alt, v, C, omega)).H
    h = 1e-6
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        numeric = (residual(e) - residual(-e)) / (2 * h)
        assert np.allclose(numeric, H[:, ATT][:, j], atol=1e-6)
    # and the antenna position itself: the IMU sits one arm behind the antenna
    y0 = residual(np.zeros(3))
    assert np.allclose(y0[:3], C @ arm, atol=1e-6)


# --------------------------------------------------------------------------- in motion
def test_coarse_in_motion_on_an_ideal_imu_and_exact_track() -> None:
    """OBA with no heading given: on an ideal IMU and an exact track its only errors are
    the track velocity's five-point derivative (it misses by 0.57 v″ Δt², up to 0.3 m/s
    within the speed steps) and the trapezoid integral: 0.015° measured, under 0.03°."""
    d = simulate_drive(125.0, seed=0, thermal=False, noise=False, turn_on=False)
    exact = GnssTrack(d.t, d.lat, d.lon, d.alt, 1.0)
    c = coarse_in_motion(d.dtheta, d.dv, d.dt, 0.0, exact, 60.0)
    k = np.searchsorted(d.t, c.t)
    phi = _vee_phi(d.C_nr[k], c.C_nr)
    assert np.abs(phi).max() < math.radians(0.03)
    # the window holds a speed change of 8 m/s and a 90° turn at 10 m/s ...
    assert c.heading_strength > 5.0
    # ... while a drive too short for a manoeuvre (straight at 10 m/s) gives nothing to
    # take a heading from: the strength says so
    straight = simulate_drive(60.0, seed=0, thermal=False, noise=False, turn_on=False)
    c0 = coarse_in_motion(
        straight.dtheta,
        straight.dv,
        straight.dt,
        0.0,
        GnssTrack(straight.t, straight.lat, straight.lon, straight.alt, 1.0),
        60.0,
    )
    assert c0.heading_strength < 0.05 * c.heading_strength


@pytest.fixture(scope="module")
def drive5() -> Drive:
    return simulate_drive(300.0, seed=1)


def test_in_motion_alignment_and_aided_navigation_5_min(drive5: Drive) -> None:
    """The issue's check, short: no stop, no heading, 1.5 m GNSS at 1 Hz: heading within
    0.1° at 5 min, the position error RMS within σ and its maximum within 3σ."""
    d = drive5
    res = navigate_aided(d.dtheta, d.dv, d.dt, d.track, paper_noise(load_imu("paper")))
    a = res.aided
    # the coarse stage alone is within a few degrees (the filter's prior says 3°)
    h_coarse = _heading_error_deg(d, np.array([res.coarse.t]), res.coarse.C_nr[None])[0]
    assert abs(h_coarse) < 3.0
    h = _heading_error_deg(d, a.t[a.updated], a.C_nr[a.updated])
    assert abs(h[-1]) < HEADING_BOUND_DEG
    assert math.degrees(a.sd[-1, 8]) < 0.5 * HEADING_BOUND_DEG
    e = _position_error_m(d, a.t[a.updated], a.lat[a.updated], a.lon[a.updated], a.alt[a.updated])
    r = np.linalg.norm(e, axis=1)
    assert np.sqrt(np.mean(r**2)) <= GNSS_SD_M
    assert r.max() <= 3 * GNSS_SD_M
    # the filter is consistent: the fixes' residuals over their predicted σ have zero mean
    # and unit variance (about 300 fixes: each component's sample sd is known to ±4 %;
    # measured 1.06, 0.96, 1.00)
    nu = a.residuals["GnssTrack"]
    assert nu.shape == (a.updated.sum(), 3)
    assert np.abs(nu.mean(axis=0)).max() < 3 / math.sqrt(nu.shape[0])
    assert np.all(np.abs(nu.std(axis=0) - 1.0) < 0.1)


def test_track_velocities_sharpen_the_heading(drive5: Drive) -> None:
    """Velocities from the track (0.05 m/s white noise) see the heading error's velocity
    ``f^n × φ`` directly instead of through its integral: on the same drive the filter's
    heading σ at 5 min drops and the heading stays within the bound."""
    d = drive5
    noise = paper_noise(load_imu("paper"))
    rng = np.random.default_rng(7)
    with_v = GnssTrack(
        d.t,
        d.noisy[:, 0],
        d.noisy[:, 1],
        d.noisy[:, 2],
        GNSS_SD_M,
        v_n=d.v_n + rng.normal(0.0, 0.05, d.v_n.shape),
        velocity_sd=0.05,
    )
    a_p = navigate_aided(d.dtheta, d.dv, d.dt, d.track, noise).aided
    a_v = navigate_aided(d.dtheta, d.dv, d.dt, with_v, noise).aided
    assert a_v.sd[-1, 8] < 0.6 * a_p.sd[-1, 8]  # measured: 0.018° against 0.036°
    u = a_v.updated
    assert abs(_heading_error_deg(d, a_v.t[u][-1:], a_v.C_nr[u][-1:])[0]) < HEADING_BOUND_DEG


def test_a_fix_between_samples_is_compared_where_the_ins_was_then() -> None:
    """A measurement between samples sees the INS position carried by its velocity to the
    measurement's time: ``v τ`` in metres, east, north and up."""
    lat, lon, alt = math.radians(32.0), math.radians(118.0), 10.0
    v = np.array([12.0, -5.0, 0.4])
    nav = Strapdown(lat, lon, alt, v, np.eye(3), 0.02, "free")
    filt = AidedInertial(nav, np.eye(15), ImuNoise(0.0, 0.0, 0.0, 0.0))
    s0, s1 = filt.state(1.0), filt.state(1.007, 0.007)
    moved = enu_difference(s1.lat, s1.lon, s1.alt, s0.lat, s0.lon, s0.alt)
    assert np.allclose(moved, v * 0.007, atol=1e-6)


def test_in_motion_alignment_with_the_table_turning() -> None:
    """The rotational INS: the four-position table turns the IMU under the car (its heat
    reaching the sensors by the encoder angle); the gyros follow the turns, no encoder
    angle is given, and the heading is within the bound at 5 min."""
    d = simulate_drive(300.0, seed=1, schedule=RotationSchedule.four_position())
    res = navigate_aided(d.dtheta, d.dv, d.dt, d.track, paper_noise(load_imu("paper")))
    a = res.aided
    u = a.updated
    assert abs(_heading_error_deg(d, a.t[u][-1:], a.C_nr[u][-1:])[0]) < HEADING_BOUND_DEG
    e = np.linalg.norm(_position_error_m(d, a.t[u], a.lat[u], a.lon[u], a.alt[u]), axis=1)
    assert np.sqrt(np.mean(e**2)) <= GNSS_SD_M
    assert e.max() <= 3 * GNSS_SD_M


# --------------------------------------------------------------------------- pyins
_P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # ENU/RFU ↔ NED/FRD


def _pyins_aided(d: Drive, start_index: int, C_nr, lat, lon, alt, v_n, noise: ImuNoise):
    """pyins' feedback filter from the same start, the same increments and the same
    fixes, the same priors and noise; its trajectory (time-indexed, degrees, NED)."""
    pytest.importorskip("pyins")
    from pyins import filters, inertial_sensor, measurements
    from pyins import strapdown as pstrap
    from pyins import transform as ptrans

    i = start_index
    gyro = d.dtheta[i - 1 :] @ _P.T  # one "before" sample for pyins' coning
    accel = d.dv[i - 1 :] @ _P.T
    t = (i + np.arange(gyro.shape[0])) * d.dt
    cols = ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]
    inc = pstrap.compute_increments_from_imu(
        pd.DataFrame(np.hstack([gyro, accel]), index=t, columns=cols), "increment"
    )
    rph = ptrans.mat_to_rph(_P @ C_nr @ _P.T)
    pva = pd.Series(
        {
            "lat": math.degrees(lat),
            "lon": math.degrees(lon),
            "alt": alt,
            "VN": v_n[1],
            "VE": v_n[0],
            "VD": -v_n[2],
            "roll": rph[0],
            "pitch": rph[1],
            "heading": rph[2],
        },
        name=i * d.dt,
    )
    sel = d.t > i * d.dt
    fixes = pd.DataFrame(
        {
            "lat": np.degrees(d.noisy[sel, 0]),
            "lon": np.degrees(d.noisy[sel, 1]),
            "alt": d.noisy[sel, 2],
        },
        index=d.t[sel],
    )
    gm = inertial_sensor.EstimationModel(
        bias_sd=noise.gyro_bias_sd, noise=noise.gyro_noise_density, bias_walk=noise.gyro_bias_rw
    )
    am = inertial_sensor.EstimationModel(
        bias_sd=noise.accel_bias_sd,
        noise=noise.accel_noise_density,
        bias_walk=noise.accel_bias_rw,
    )
    out = filters.run_feedback_filter(
        pva,
        GNSS_SD_M,
        0.5,
        0.5,
        3.0,
        inc,
        gm,
        am,
        [measurements.Position(fixes, GNSS_SD_M)],
        time_step=1.0,
    )
    tr = out.trajectory
    return tr.iloc[tr.index.get_indexer(d.t[sel], method="nearest")], d.t[sel]


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::DeprecationWarning", "ignore::FutureWarning")
def test_pyins_filter_agrees_on_the_5_min_drive(drive5: Drive) -> None:
    """pyins' feedback filter, started from our coarse solution with our priors and
    noise, on the same increments and fixes: the same heading at 5 min (within 0.02°),
    the same position accuracy (within 10 %). About 30 s: pyins steps in pandas."""
    d = drive5
    noise = paper_noise(load_imu("paper"))
    res = navigate_aided(d.dtheta, d.dv, d.dt, d.track, noise)
    c, a = res.coarse, res.aided
    tr, t = _pyins_aided(d, c.index, c.C_nr, c.lat, c.lon, c.alt, c.v_n, noise)
    k = np.searchsorted(d.t, np.round(t, 6))
    h_py = (tr.heading.to_numpy() - np.degrees(euler_from_C_nb(d.C_nr[k])[:, 0]) + 180) % 360
    h_py -= 180
    h_ours = _heading_error_deg(d, a.t[a.updated], a.C_nr[a.updated])
    assert abs(h_py[-1]) < HEADING_BOUND_DEG
    assert abs(h_py[-1] - h_ours[-1]) < 0.02
    e_py = _position_error_m(
        d, t, np.radians(tr.lat.to_numpy()), np.radians(tr.lon.to_numpy()), tr.alt.to_numpy()
    )
    e_ours = _position_error_m(
        d, a.t[a.updated], a.lat[a.updated], a.lon[a.updated], a.alt[a.updated]
    )
    rms_py = np.sqrt(np.mean(np.sum(e_py**2, axis=1)))
    rms_ours = np.sqrt(np.mean(np.sum(e_ours**2, axis=1)))
    assert rms_py <= GNSS_SD_M
    assert rms_ours == pytest.approx(rms_py, rel=0.1)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::DeprecationWarning", "ignore::FutureWarning")
def test_gnss_aided_navigation_1_h_and_pyins() -> None:
    """The issue's check in full: 1 h of the drive aided by the 1 Hz, 1.5 m track: position
    error RMS ≤ σ and maximum ≤ 3σ (3-D, at every fix after the in-motion alignment's
    start), heading within 0.1° from 5 min on; pyins' filter on the same data meets the
    same bounds and agrees in RMS within 10 %. 80-200 s, nearly all of it pyins."""
    d = simulate_drive(3600.0, seed=11)
    noise = paper_noise(load_imu("paper"))
    res = navigate_aided(d.dtheta, d.dv, d.dt, d.track, noise)
    c, a = res.coarse, res.aided
    u = a.updated
    e = np.linalg.norm(_position_error_m(d, a.t[u], a.lat[u], a.lon[u], a.alt[u]), axis=1)
    assert np.sqrt(np.mean(e**2)) <= GNSS_SD_M
    assert e.max() <= 3 * GNSS_SD_M
    h = _heading_error_deg(d, a.t[u], a.C_nr[u])
    assert np.abs(h[a.t[u] >= 300.0]).max() < HEADING_BOUND_DEG
    tr, t = _pyins_aided(d, c.index, c.C_nr, c.lat, c.lon, c.alt, c.v_n, noise)
    e_py = np.linalg.norm(
        _position_error_m(
            d, t, np.radians(tr.lat.to_numpy()), np.radians(tr.lon.to_numpy()), tr.alt.to_numpy()
        ),
        axis=1,
    )
    rms, rms_py = np.sqrt(np.mean(e**2)), np.sqrt(np.mean(e_py**2))
    assert rms_py <= GNSS_SD_M
    assert e_py.max() <= 3 * GNSS_SD_M
    assert rms == pytest.approx(rms_py, rel=0.1)


def test_in_motion_heading_over_seeds() -> None:
    """Six drives (seeds 1-6): the heading error at 5 min is within 0.1° on each, and its
    spread agrees with the filter's own σ (rms within a factor 2 of it)."""
    noise = paper_noise(load_imu("paper"))
    errs, sds = [], []
    for seed in range(1, 7):
        d = simulate_drive(300.0, seed=seed)
        a = navigate_aided(d.dtheta, d.dv, d.dt, d.track, noise).aided
        u = a.updated
        errs.append(_heading_error_deg(d, a.t[u][-1:], a.C_nr[u][-1:])[0])
        sds.append(math.degrees(a.sd[-1, 8]))
    errs_a = np.array(errs)
    assert np.abs(errs_a).max() < HEADING_BOUND_DEG
    rms = float(np.sqrt(np.mean(errs_a**2)))
    assert 0.5 * np.mean(sds) < rms < 2.0 * np.mean(sds)

"""A recorded run navigated by rinscal and by pyins (python-ins) from the same initial state.

What is compared. A strapdown recording (the turntable does not turn, the IMU is fixed to
the body) with the paper IMU's real sensor errors (turn-on bias, thermal drift, noise) is
simulated, written in the recorded-navigation log's columns (SI increments) and turned
into :class:`rinscal.schema.NavSamples` by hand.
:func:`rinscal.nav.recorded.navigate.navigate_recording` aligns on the window [0, 600 s)
and navigates the rest. pyins then navigates the same
recorded increments after the navigation start from rinscal's alignment outcome (attitude
``C_nr``, the site, velocity zero), minus the same gyro and accelerometer bias estimates
× dt, and its horizontal error is taken against the same truth at the same output times
(every second). The issue's requirement: the two horizontal error curves agree within
1 % + 10 m at every second of the hour, where the error grows to kilometres (asserted, so
that the tolerance is a real test), on a static base and on a flat drive (the drive
recorded with its reference track). A control shows the tolerance catches a navigation
that forgets the bias estimates.

Why it is independent. Only the alignment (the initial state and the bias estimates) is
shared; the free navigation, where the error grows, is pyins' own strapdown: its own
Earth and gravity model, NED/FRD frames, coning and sculling (two-sample, from raw
increments with ``compute_increments_from_imu(..., 'increment')`` and the sample before the
navigation start as its "before" sample), its own position update. What it checks on the
rinscal side: that navigate_recording hands its strapdown the alignment's attitude at the
right sample, keeps subtracting the biases it reports, reads the recording's increments
without loss or shift and dates its output as the samples it navigated.

Frames as in test_pyins_crosscheck: ``v_NED = P v_ENU`` and ``v_FRD = P v_RFU`` with the
proper rotation ``P = [[0, 1, 0], [1, 0, 0], [0, 0, −1]]``, so ``C_NED←FRD = P C_nr Pᵀ``.
The vertical channel: rinscal holds the altitude and the vertical velocity to the
reference ("hold"); pyins without altitude keeps the altitude and zeroes the vertical
velocity, the same on a static base and on a flat route.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from rinscal import earth
from rinscal.nav.recorded.blocks import BlockStats
from rinscal.nav.recorded.frame import recording_frame
from rinscal.nav.recorded.navigate import Reference, navigate_recording
from rinscal.nav.recorded.window import Noise, align_config, find_window
from rinscal.nav.rotation import RotationSchedule
from rinscal.schema import DTHETA, DVEL, NavSamples
from rinscal.sim.config import load_imu
from rinscal.sim.scenario import ThermalPlant, align_for, preset, run_scenario
from rinscal.sim.trajectory import StepChannel

pyins = pytest.importorskip("pyins")
from pyins import strapdown as pstrap  # noqa: E402
from pyins import transform as ptrans  # noqa: E402

P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
ALIGN_S = 600.0
RATE = 20.0
IMU_COLS = ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]


def _record(scenario: str, nav_s: float, seed: int = 2):  # type: ignore[no-untyped-def]
    """A recording without rotation: ``ALIGN_S`` of alignment, then ``nav_s`` navigated."""
    imu = load_imu("paper")
    align = align_for(imu, total_s=ALIGN_S)
    if scenario == "vehicle":  # the drive: nav_s after standing still for the alignment
        cfg = preset("vehicle", hours=nav_s / 3600, rate_hz=RATE, align=align)
        flat = dataclasses.replace(cfg.trajectory, grade=StepChannel(0.0))
        cfg = dataclasses.replace(cfg, trajectory=flat, duration_s=ALIGN_S + nav_s)
    else:
        cfg = preset(scenario, hours=(ALIGN_S + nav_s) / 3600, rate_hz=RATE, align=align)
    cfg = dataclasses.replace(cfg, schedule=RotationSchedule.none())
    plant = ThermalPlant.for_scenario(imu, cfg, seed=seed)
    frames: list[pd.DataFrame] = []

    def rec(ch, dth, dv) -> None:  # type: ignore[no-untyped-def]
        frames.append(recording_frame(ch, dth, dv, increments=True, track=scenario == "vehicle"))

    run_scenario(cfg, plant, {"none": None}, recorder=rec)
    return cfg, imu, pd.concat(frames, ignore_index=True)


def _pieces(d: pd.DataFrame, size: int = 7001):  # type: ignore[no-untyped-def]
    t = d["time_s"].to_numpy()
    dt = np.diff(t, prepend=t[0] - 1.0 / RATE)
    th, dv = d[list(DTHETA)].to_numpy(), d[list(DVEL)].to_numpy()
    ref = None
    if "ref_lat_deg" in d:
        ref = np.column_stack(
            [np.deg2rad(d["ref_lat_deg"]), np.deg2rad(d["ref_lon_deg"]), d["ref_h_m"]]
        )
    table = np.deg2rad(d["table_deg"].to_numpy())
    for a in range(0, len(t), size):
        b = slice(a, a + size)
        yield NavSamples(
            t[b], dt[b], th[b], dv[b], a + 1, table[b], ref=None if ref is None else ref[b]
        )


def _navigate(cfg, imu, d):  # type: ignore[no-untyped-def]
    st = BlockStats()
    for s in _pieces(d):
        st.add(s)
    win = find_window(st.finish(), ALIGN_S, start_s=0.0)
    wd, rw = imu.noise.white_density_si(), imu.noise.bias_rw_si()
    noise = Noise(float(wd[0]), float(wd[3]), float(rw[0]), float(rw[3]))
    tr = cfg.trajectory
    ref = Reference(tr.lat0, tr.lon0, tr.alt0)
    return navigate_recording(_pieces(d), ref, win, align_config(noise, win), cfg.dt)


def _pyins_errors(d: pd.DataFrame, res, biases: bool = True) -> pd.DataFrame:  # type: ignore[no-untyped-def]
    """pyins over the recording after the navigation start, from rinscal's alignment;
    east/north/horizontal error against rinscal's truth rows, every second."""
    al = res.alignment["none"]
    dt = 1.0 / RATE
    n_nav = round(res.config.nav_start_s * RATE)  # samples before the navigation start
    t = d["time_s"].to_numpy()[n_nav - 1 :]  # one "before" sample for the coning terms
    gyro = d[list(DTHETA)].to_numpy()[n_nav - 1 :]
    accel = d[list(DVEL)].to_numpy()[n_nav - 1 :]
    if biases:
        gyro = gyro - al.gyro_bias * dt
        accel = accel - al.accel_bias * dt
    imu = pd.DataFrame(np.hstack([gyro @ P.T, accel @ P.T]), index=t, columns=IMU_COLS)
    inc = pstrap.compute_increments_from_imu(imu, "increment")
    rph = ptrans.mat_to_rph(P @ al.C_nr @ P.T)
    # the site (the vehicle stands there until the navigation starts), velocity zero
    site = res.config.trajectory
    pva = pd.Series(
        {
            "lat": np.rad2deg(site.lat0),
            "lon": np.rad2deg(site.lon0),
            "alt": res.truth["alt_m"].iloc[0],
            "VN": 0.0,
            "VE": 0.0,
            "VD": 0.0,
            "roll": rph[0],
            "pitch": rph[1],
            "heading": rph[2],
        }
    )
    traj = pstrap.Integrator(pva, with_altitude=False).integrate(inc)
    tr = res.truth  # the recording's reference at the output times
    out = traj.iloc[1:].loc[tr["time_s"].to_numpy()]  # pyins dates rows by sample times
    lat_t, lon_t, alt_t = (np.deg2rad(tr["lat_deg"]), np.deg2rad(tr["lon_deg"]), tr["alt_m"])
    rn, re = earth.principal_radii(lat_t.to_numpy())
    north = (np.deg2rad(out["lat"].to_numpy()) - lat_t.to_numpy()) * (rn + alt_t.to_numpy())
    east = (
        (np.deg2rad(out["lon"].to_numpy()) - lon_t.to_numpy())
        * (re + alt_t.to_numpy())
        * np.cos(lat_t.to_numpy())
    )
    return pd.DataFrame(
        {
            "time_s": out.index.to_numpy(),
            "east_m": east,
            "north_m": north,
            "horizontal_m": np.hypot(east, north),
        }
    )


def _compare(d: pd.DataFrame, res, nav_s: float, min_err_m: float) -> dict[str, float]:  # type: ignore[no-untyped-def]
    ours = res.errors["none"]
    theirs = _pyins_errors(d, res)
    # every second of the navigated span, at the same times
    assert len(ours) == len(theirs) == round(nav_s)
    np.testing.assert_allclose(theirs["time_s"], ours["time_s"], rtol=0, atol=1e-6)
    assert ours["time_s"].iloc[0] == pytest.approx(res.config.nav_start_s + 1.0)
    h_ours = ours["horizontal_m"].to_numpy()
    h_theirs = theirs["horizontal_m"].to_numpy()
    # a real error to compare: kilometres, so that 1 % + 10 m is tight
    assert h_ours.max() > min_err_m
    diff = np.abs(h_ours - h_theirs)
    tol = 0.01 * h_ours + 10.0
    worst = int(np.argmax(diff / tol))
    assert np.all(diff <= tol), (
        f"at {ours['time_s'].iloc[worst]:.0f} s rinscal {h_ours[worst]:.1f} m, "
        f"pyins {h_theirs[worst]:.1f} m"
    )
    # the components too (not only the norm)
    for c in ("east_m", "north_m"):
        assert np.all(np.abs(ours[c] - theirs[c]) <= tol), c
    # pyins really ran: an error of its own that grows like ours, not a copy of our numbers
    assert h_theirs.max() > min_err_m
    assert h_theirs[-1] > 10 * h_theirs[59]
    assert diff.max() > 0.0
    return {"max_diff_m": float(diff.max()), "max_err_m": float(h_ours.max())}


@pytest.fixture(scope="module")
def static_run():  # type: ignore[no-untyped-def]
    cfg, imu, d = _record("quasi-static", 3600.0)
    return d, _navigate(cfg, imu, d)


@pytest.mark.filterwarnings("ignore:The copy keyword is deprecated")
def test_static_recording_rinscal_and_pyins_agree_within_1pct_plus_10m_over_1h(
    static_run,
) -> None:  # type: ignore[no-untyped-def]
    d, res = static_run
    got = _compare(d, res, 3600.0, min_err_m=2000.0)
    # same algorithm class on a static base: far inside the tolerance (measured: 0.4 mm
    # where the error reaches 13 km)
    assert got["max_diff_m"] < 1.0


@pytest.mark.filterwarnings("ignore:The copy keyword is deprecated")
def test_the_tolerance_sees_the_bias_estimates(static_run) -> None:  # type: ignore[no-untyped-def]
    """Control: pyins without the alignment's bias estimates is far outside 1 % + 10 m, so
    the comparison above does check that rinscal keeps subtracting them."""
    d, res = static_run
    ours = res.errors["none"]["horizontal_m"].to_numpy()
    raw = _pyins_errors(d, res, biases=False)["horizontal_m"].to_numpy()
    assert np.max(np.abs(ours - raw) - (0.01 * ours + 10.0)) > 100.0


@pytest.mark.filterwarnings("ignore:The copy keyword is deprecated")
def test_vehicle_recording_rinscal_and_pyins_agree_within_1pct_plus_10m_over_1h() -> None:
    """A flat drive (pyins without altitude zeroes the vertical velocity), no rotation,
    against the track recorded in the log's reference columns."""
    cfg, imu, d = _record("vehicle", 3600.0)
    res = _navigate(cfg, imu, d)
    assert "ref_lat_deg" in d
    # the vehicle really drove (kilometres from the site)
    lat = np.deg2rad(res.truth["lat_deg"].to_numpy())
    assert np.max(np.abs(lat - lat[0])) * earth.principal_radii(lat[0])[0] > 1000.0
    got = _compare(d, res, 3600.0, min_err_m=2000.0)
    # the same algorithm class, turns at 20 Hz: well inside the tolerance (measured: 0.1 m)
    assert got["max_diff_m"] < 2.0

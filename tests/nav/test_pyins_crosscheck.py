"""Independent cross-check against pyins (python-ins, a test-only dependency).

Same trajectory, same r-frame increments: our ENU integrator and ``pyins.strapdown``
(NED, body x forward / y right / z down) must agree in position to better than 1 cm over
1 h. Conversions: ``v_NED = P v_ENU`` and ``v_FRD = P v_RFU`` with the same proper rotation
``P = [[0, 1, 0], [1, 0, 0], [0, 0, −1]]``; pyins takes raw increments and applies its own
two-sample coning/sculling (``compute_increments_from_imu(..., 'increment')``, which needs
one extra "before" sample).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from rinscal import earth
from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.nav.strapdown import Strapdown
from rinscal.sim.ideal_imu import ImuSynthesizer
from rinscal.sim.trajectory import C_nb_from_euler, StepChannel, vehicle_route

pyins = pytest.importorskip("pyins")
from pyins import strapdown as pstrap  # noqa: E402
from pyins import transform as ptrans  # noqa: E402

P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
RATE = 100
HOURS = 1.0


@pytest.fixture(scope="module")
def run() -> dict[str, np.ndarray]:
    # a flat route (pyins without altitude zeroes the vertical velocity) on the turntable
    route = dataclasses.replace(
        vehicle_route(duration_s=HOURS * 3600 - 60, stationary_s=60), grade=StepChannel(0.0)
    )
    sched = RotationSchedule.four_position()
    syn = ImuSynthesizer(route, sched, RATE)
    kin = route.kinematics(np.zeros(1))
    C_nr = C_nb_from_euler(kin.euler[0]) @ C_br(sched.angle(0.0)[0])
    navs = {
        k: Strapdown(
            route.lat0, route.lon0, route.alt0, kin.v_n[0], C_nr, 1 / RATE, "hold", rotation_term=k
        )
        for k in (False, True)
    }
    dth, dv, truth, outs = [], [], [], {False: [], True: []}
    for ch in syn.chunks(HOURS * 3600, 120.0):
        for k, nav in navs.items():
            outs[k].append(
                nav.run(ch.dtheta, ch.dv, alt_ref=ch.alt, vu_ref=ch.v_n[:, 2], out_every=RATE)
            )
        sel = (ch.k0 + np.arange(1, ch.n + 1)) % RATE == 0
        truth.append(np.column_stack([ch.lat[sel], ch.lon[sel]]))
        dth.append(ch.dtheta)
        dv.append(ch.dv)
    return {
        "dtheta": np.concatenate(dth),
        "dv": np.concatenate(dv),
        "truth": np.concatenate(truth),
        "ours2": np.concatenate(outs[False])[:, :2],
        "ours3": np.concatenate(outs[True])[:, :2],
        "C_nr": C_nr,
        "lla0": np.array([route.lat0, route.lon0, route.alt0]),
        "v0": kin.v_n[0],
    }


def _distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    rn, re = earth.principal_radii(b[:, 0])
    return np.hypot((a[:, 0] - b[:, 0]) * rn, (a[:, 1] - b[:, 1]) * re * np.cos(b[:, 0]))


def _pyins(run: dict[str, np.ndarray]) -> np.ndarray:
    gyro = np.vstack([run["dtheta"][:1], run["dtheta"]]) @ P.T
    accel = np.vstack([run["dv"][:1], run["dv"]]) @ P.T
    t = np.arange(gyro.shape[0]) / RATE
    cols = ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]
    imu = pd.DataFrame(np.hstack([gyro, accel]), index=t, columns=cols)
    inc = pstrap.compute_increments_from_imu(imu, "increment")
    rph = ptrans.mat_to_rph(P @ run["C_nr"] @ P.T)
    lat, lon, alt = run["lla0"]
    v = run["v0"]
    pva = pd.Series(
        {
            "lat": np.rad2deg(lat),
            "lon": np.rad2deg(lon),
            "alt": alt,
            "VN": v[1],
            "VE": v[0],
            "VD": -v[2],
            "roll": rph[0],
            "pitch": rph[1],
            "heading": rph[2],
        }
    )
    integ = pstrap.Integrator(pva, with_altitude=False)
    traj = integ.integrate(inc)
    lat_p = np.deg2rad(traj["lat"].to_numpy()[1:][RATE - 1 :: RATE])
    lon_p = np.deg2rad(traj["lon"].to_numpy()[1:][RATE - 1 :: RATE])
    return np.column_stack([lat_p, lon_p])


@pytest.mark.filterwarnings("ignore:The copy keyword is deprecated")
def test_pyins_and_ours_agree_within_1cm_over_1h(run: dict[str, np.ndarray]) -> None:
    theirs = _pyins(run)
    assert theirs.shape == run["ours2"].shape == (int(HOURS * 3600), 2)
    truth = run["truth"]
    # the route really moves (tens of km) and both integrators follow it
    assert np.max(_distance(truth, np.tile(truth[:1], (truth.shape[0], 1)))) > 10_000
    # same algorithm class (two-sample coning/sculling): < 1 cm apart over the hour
    assert np.max(_distance(theirs, run["ours2"])) < 0.01
    # with the second-order rotation term ours is closer to the exact truth than pyins
    err_ours = np.max(_distance(run["ours3"], truth))
    err_pyins = np.max(_distance(theirs, truth))
    assert err_ours < 0.01
    assert err_ours < err_pyins

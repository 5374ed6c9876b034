"""Independent check (issue 25): data made by pyins' sensor-error model on kinematics from
textbook formulas, and a plain least squares written here from the textbook model
``y = T s + b``, give the same parameters as calibrate_imu."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pyins_sensor = pytest.importorskip("pyins.inertial_sensor")

from rinscal.calibration.imu.workflow import calibrate_imu  # noqa: E402
from rinscal.sensormodel import TriadErrors  # noqa: E402
from tests.calibration._imu_synth import Design, _commands  # noqa: E402

LAT, PSI = np.deg2rad(45.0), np.deg2rad(30.0)
OMEGA = 7.292115e-5  # WGS84 Earth rate [rad/s]
DPH, UG = np.pi / 180 / 3600, 9.80665e-6
SETTLE = 2.0


def _gravity(lat):
    """Somigliana's normal gravity on the ellipsoid (WGS84) [m/s²]."""
    s2 = np.sin(lat) ** 2
    return 9.7803253359 * (1 + 0.00193185265241 * s2) / np.sqrt(1 - 0.00669437999013 * s2)


def _c_nr(o, i):
    """ENU <- IMU on the table: level frame with y at azimuth PSI, then R_y(o), R_z(i)."""
    c0 = np.array([[np.cos(PSI), np.sin(PSI), 0], [-np.sin(PSI), np.cos(PSI), 0], [0, 0, 1.0]])
    co, so, ci, si = np.cos(o), np.sin(o), np.cos(i), np.sin(i)
    ry = np.array([[co, 0, so], [0, 1, 0], [-so, 0, co]])
    rz = np.array([[ci, -si, 0], [si, ci, 0], [0, 0, 1]])
    return c0 @ ry @ rz


def _kinematics(design: Design):
    """Table columns and the true interval-mean rate and specific force of every sample."""
    dt = 1 / design.rate_hz
    w_n = np.array([0, OMEGA * np.cos(LAT), OMEGA * np.sin(LAT)])
    f_n = np.array([0, 0, _gravity(LAT)])
    rows, kin, steps = [], [], []
    for kind, o, i, ro, ri, n in _commands(design):
        first = len(rows)
        for k in range(n):
            if kind == "move":
                oo, ii, r_o, r_i = o - (n - k) * 3.0, i + (n - k) * 2.0, 30.0, 20.0
            else:
                oo, ii, r_o, r_i = o + ro * dt * (k + 1), i + ri * dt * (k + 1), ro, ri
            rows.append((oo, ii, r_o, r_i))
            w_acc, f_acc = np.zeros(3), np.zeros(3)
            for m in range(16):  # the mean over the sample interval, 16 midpoints
                back = dt * (1 - (m + 0.5) / 16)
                a_o, a_i = np.deg2rad(oo - r_o * back), np.deg2rad(ii - r_i * back)
                c_rn = _c_nr(a_o, a_i).T
                table = np.deg2rad([r_o * np.sin(a_i), r_o * np.cos(a_i), r_i])
                w_acc += c_rn @ w_n + table
                f_acc += c_rn @ f_n
            kin.append(np.concatenate([w_acc, f_acc]) / 16)
        if kind == "static":
            steps.append(("static", first + int(SETTLE * design.rate_hz), len(rows)))
        elif kind == "rate":  # the last whole turns
            per_turn = round(360 / (abs(ro + ri) * dt))
            steps.append(("rate", len(rows) - design.turns * per_turn, len(rows)))
    return np.array(rows), np.array(kin), steps


def _plain_lsq(y, s, steps, sensor):
    """y = T s + b on segment means, each weighted by its number of samples (white noise of
    one level): T (3, 3), b (3,)."""
    use = [(a, b) for kind, a, b in steps if sensor == "gyro" or kind == "static"]
    ys = np.array([y[a:b].mean(axis=0) for a, b in use])
    ss = np.array([s[a:b].mean(axis=0) for a, b in use])
    w = np.sqrt([b - a for a, b in use])[:, None]
    x, *_ = np.linalg.lstsq(w * np.column_stack([ss, np.ones(len(use))]), w * ys, rcond=None)
    return x[:3].T, x[3]


def _ours(res, sensor):
    e = res.estimates.set_index("parameter")
    to_si = {"gyro": DPH, "accel": UG}[sensor]
    sf = np.array([e.value[f"{sensor}_sf_{a}"] for a in "xyz"]) * 1e-6
    mis = np.zeros((3, 3))
    for j, a in enumerate("xyz"):
        for k, b in enumerate("xyz"):
            if j != k:
                mis[j, k] = e.value[f"{sensor}_mis_{a}{b}"] * np.pi / 180 / 3600
    bias = np.array([e.value[f"{sensor}_bias_{a}"] for a in "xyz"]) * to_si
    return TriadErrors(sf=sf, mis=mis).matrix(), bias, e


@pytest.mark.parametrize("noisy", [False, True])
def test_pyins_data_and_a_plain_lsq_give_our_parameters(noisy):
    design = Design(dwell_s=20.0, turns=1, settle_s=SETTLE)
    table, kin, steps = _kinematics(design)
    dt = 1 / design.rate_hz
    t = (np.arange(len(table)) + 1.0) * dt
    rng = np.random.default_rng(4)
    t_g = np.eye(3) + rng.normal(0, 1e-4, (3, 3))
    t_a = np.eye(3) + rng.normal(0, 3e-4, (3, 3))
    b_g, b_a = rng.normal(0, 0.05, 3) * DPH, rng.normal(0, 100, 3) * UG
    sd = (0.1 * DPH, 200 * UG) if noisy else (0.0, 0.0)
    imu = pd.DataFrame(kin, index=t, columns=[*pyins_sensor.GYRO_COLS, *pyins_sensor.ACCEL_COLS])
    out = pyins_sensor.apply_imu_parameters(
        imu,
        "rate",
        pyins_sensor.Parameters(transform=t_g, bias=b_g, noise=sd[0] * np.sqrt(dt), rng=1),
        pyins_sensor.Parameters(transform=t_a, bias=b_a, noise=sd[1] * np.sqrt(dt), rng=2),
    ).to_numpy()
    chans = ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]
    log = pd.DataFrame(out / np.array([DPH] * 3 + [UG] * 3), columns=chans)
    log.insert(0, "run", "cal_+20C")
    log.insert(0, "time_s", t)
    for ch in chans:
        log[f"temp_{ch}"] = 20.0
    cols = ["table_outer_deg", "table_inner_deg", "table_outer_rate_dps", "table_inner_rate_dps"]
    log[cols] = table
    meta = {
        "units": dict.fromkeys(chans[:3], "deg/h") | dict.fromkeys(chans[3:], "ug"),
        "latitude_deg": 45.0,
        "heading_deg": 30.0,
        "altitude_m": 0.0,
        "set_points_c": {"cal_+20C": 20.0},
    }
    res = calibrate_imu(log, meta, settle_s=SETTLE, nonlinear=False, max_degree=0)
    for sensor, sl, t_true, b_true in (
        ("gyro", slice(0, 3), t_g, b_g),
        ("accel", slice(3, 6), t_a, b_a),
    ):
        t_lsq, b_lsq = _plain_lsq(out[:, sl], kin[:, sl], steps, sensor)
        t_ours, b_ours, est = _ours(res, sensor)
        if not noisy:  # all three agree to rounding: the same model, the same positions
            assert np.abs(t_ours - t_true).max() < 1e-10
            assert np.abs(t_lsq - t_true).max() < 1e-10
            assert np.abs(b_ours - b_true).max() < 1e-9 * np.abs(b_true).max()
            continue
        # with noise: our weighted fit and the plain one differ by a fraction of the sd;
        # both are within 4 sd of pyins' truth
        unit = {"gyro": DPH, "accel": UG}[sensor]
        sd_b = np.array([est.sd[f"{sensor}_bias_{a}"] for a in "xyz"]) * unit
        sd_t = np.array([est.sd[f"{sensor}_sf_{a}"] for a in "xyz"]) * 1e-6
        assert (np.abs(b_ours - b_lsq) < 0.5 * sd_b).all()
        assert (np.abs(b_ours - b_true) < 4 * sd_b).all()
        assert (np.abs(np.diag(t_ours - t_lsq)) < 0.5 * sd_t).all()
        assert (np.abs(np.diag(t_ours - t_true)) < 4 * sd_t).all()
        off = ~np.eye(3, dtype=bool)
        sd_m = np.array([[est.sd.get(f"{sensor}_mis_{a}{b}", 0) for b in "xyz"] for a in "xyz"])
        sd_m = sd_m * np.pi / 180 / 3600
        assert (np.abs(t_ours - t_lsq)[off] < 0.5 * sd_m[off]).all()
        assert (np.abs(t_ours - t_true)[off] < 4 * sd_m[off]).all()

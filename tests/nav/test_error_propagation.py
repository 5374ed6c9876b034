"""Textbook error propagation of the strapdown INS, and what rotation modulation cancels.

The reference is the linearised ENU error model of a stationary INS (Titterton & Weston
Ch. 12, Britting), with ``C̃_nr = (I − [φ×]) C_nr``, vertical channel held::

    φ̇  = −ω_ie^n × φ + (−δv_N/R_N, δv_E/R_E, δv_E tan L/R_E) + δω_ie^n(δL) − C_nr ε
    δv̇ = (f^n × φ)_EN − (2 ω_ie^n × δv)_EN + (C_nr ∇)_EN,   f^n = (0, 0, g)
    δṗ = δv

whose short-time solutions (Earth-rate coupling neglected, ω_s² = g/R) are the classics
``δp_E = (∇_E/ω_s²)(1 − cos ω_s t)`` for an east accelerometer bias and
``δp_E = R ε_N (t − sin(ω_s t)/ω_s)`` for a north gyro drift.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from scipy.integrate import solve_ivp

from rinscal import earth, units
from rinscal.nav.rotation import RotationSchedule
from rinscal.sim.scenario import ScenarioConfig, constant_errors, run_scenario
from rinscal.sim.trajectory import StaticMotion

DPH = units.DPH_TO_RPS
UG = units.UG_TO_MPS2
SITE = StaticMotion(heading_deg=0.0, lat_deg=32.06, alt_m=10.0)  # r x east, y north


def _run(bias: np.ndarray, hours: float, rate: float, schedule=None, traj=SITE):  # type: ignore[no-untyped-def]
    sched = RotationSchedule.none() if schedule is None else schedule
    cfg = ScenarioConfig("t", traj, sched, hours * 3600.0, rate, align=None, out_dt_s=10.0)
    return run_scenario(cfg, constant_errors(bias)).errors["none"]


def _linear_model(eps_n: np.ndarray, acc_n: np.ndarray, t: np.ndarray) -> np.ndarray:
    """East and north position error of the linear error model (exact, matrix exponential)."""
    lat, alt = SITE.lat0, SITE.alt0
    rn, re = earth.principal_radii(lat)
    rn, re = float(rn) + alt, float(re) + alt
    g = float(earth.gravity(lat, alt))
    on, ou = earth.RATE * math.cos(lat), earth.RATE * math.sin(lat)
    F = np.zeros((7, 7))  # φE φN φU δvE δvN pE pN
    F[0, 1], F[0, 2], F[1, 0], F[2, 0] = ou, -on, -ou, on
    F[0, 4], F[1, 3], F[2, 3] = -1 / rn, 1 / re, math.tan(lat) / re
    F[1, 6], F[2, 6] = -ou / rn, on / rn  # Earth rate seen at the wrong latitude
    F[3, 1], F[4, 0], F[3, 4], F[4, 3] = -g, g, 2 * ou, -2 * ou
    F[5, 3], F[6, 4] = 1.0, 1.0
    u = np.zeros(7)
    u[0:3] = -eps_n
    u[3:5] = acc_n[0:2]
    M = np.zeros((8, 8))
    M[:7, :7] = F
    M[:7, 7] = u
    return np.array([scipy.linalg.expm(M * tt)[5:7, 7] for tt in t])


def _schuler_rate() -> float:
    re = float(earth.principal_radii(SITE.lat0)[1]) + SITE.alt0
    return math.sqrt(float(earth.gravity(SITE.lat0, SITE.alt0)) / re)


def test_east_accel_bias_schuler_oscillation() -> None:
    """Constant east accelerometer bias ∇: δp_E = (∇/ω_s²)(1 − cos ω_s t), period 84.4 min."""
    b = 50 * UG
    e = _run(np.array([0, 0, 0, b, 0, 0.0]), 1.6, 10.0)
    t = e["time_s"].to_numpy()
    ws = _schuler_rate()
    assert abs(2 * math.pi / ws / 60 - 84.4) < 0.3
    # period from the zero crossing of the east velocity error (half a Schuler period)
    v = e["v_e_err"].to_numpy()
    k = np.nonzero(np.sign(v[1:]) != np.sign(v[:-1]))[0][0]
    t0 = t[k] - v[k] * (t[k + 1] - t[k]) / (v[k + 1] - v[k])
    assert abs(2 * t0 / 60 - 84.4) < 0.5
    # amplitude: the textbook curve within 2 % of its peak 2∇/ω_s² over one period
    first = t <= 2 * math.pi / ws
    pred = b / ws**2 * (1 - np.cos(ws * t))
    peak = 2 * b / ws**2
    assert abs(e["east_m"].max() - peak) / peak < 0.02
    assert np.max(np.abs(e["east_m"].to_numpy()[first] - pred[first])) / peak < 0.02


def test_north_gyro_drift_grows_as_textbook() -> None:
    """Constant north gyro drift ε: δp_E = R ε (t − sin(ω_s t)/ω_s) for t ≪ 24 h/2π.

    Over 4 h the Earth-rate coupling (heading error, Foucault) bends the curve; there the
    full linear error model is the reference (within 1 %).
    """
    eps = 0.01 * DPH
    e = _run(np.array([0, eps, 0, 0, 0, 0.0]), 4.0, 10.0)
    t = e["time_s"].to_numpy()
    ws = _schuler_rate()
    R = float(earth.principal_radii(SITE.lat0)[1]) + SITE.alt0
    short = (t >= 1200) & (t <= 5400)
    simple = R * eps * (t - np.sin(ws * t) / ws)
    np.testing.assert_allclose(e["east_m"].to_numpy()[short], simple[short], rtol=0.02)
    sel = slice(None, None, 36)
    lin = _linear_model(np.array([0, eps, 0]), np.zeros(3), t[sel])
    ins = e[["east_m", "north_m"]].to_numpy()[sel]
    scale = np.max(np.hypot(lin[:, 0], lin[:, 1]))
    assert scale > 3000.0
    assert np.max(np.hypot(*(ins - lin).T)) / scale < 0.01


def test_constant_horizontal_biases_are_modulated_z_gyro_is_not() -> None:
    """Four-position modulation cuts the 4 h error ≥10× for horizontal biases (Eqs. 8-9);
    a z-gyro bias, on the rotation axis, is not modulated at all."""
    traj = StaticMotion(heading_deg=45.0)
    four = RotationSchedule.four_position()
    horiz = np.array([0.01 * DPH, -0.008 * DPH, 0.0, 50 * UG, -40 * UG, 0.0])
    still = _run(horiz, 4.0, 20.0, traj=traj)["horizontal_m"].to_numpy()
    rot = _run(horiz, 4.0, 20.0, four, traj=traj)["horizontal_m"].to_numpy()
    assert still[-1] > 1000.0
    assert still[-1] / rot[-1] >= 10.0
    assert still.max() / rot.max() >= 10.0
    z = np.array([0.0, 0.0, 0.01 * DPH, 0.0, 0.0, 0.0])
    still_z = _run(z, 4.0, 20.0, traj=traj)["horizontal_m"].to_numpy()
    rot_z = _run(z, 4.0, 20.0, four, traj=traj)["horizontal_m"].to_numpy()
    assert still_z[-1] > 500.0
    assert 0.9 < rot_z[-1] / still_z[-1] < 1.1


def test_z_gyro_position_error_follows_the_linear_error_model_in_absolute_terms() -> None:
    """Constant vertical gyro bias ε on the rotating RINS (four-position, heading 45°), 4 h.

    The reference is the textbook φ-angle error model (ENU, stationary, vertical channel
    held), written out here with its own WGS84 radii and Somigliana gravity and integrated by
    scipy::

        φ̇ = −ω_ie^n × φ + (−δv_N/R_M, δv_E/R_N, δv_E tan L/R_N)
             + (0, −Ω sin L δL, Ω cos L δL) − (0, 0, ε)
        δv̇_E = −g φ_N + 2 Ω sin L δv_N,   δv̇_N = g φ_E − 2 Ω sin L δv_E
        δL̇ = δv_N/R_M,   δλ̇ = δv_E/(R_N cos L)

    The heading error −ε t tilts the platform through the north Earth rate; the position
    error (1.8 km after 4 h for 0.01 °/h) must match within 0.5 % of its maximum at every
    time — in absolute terms, not only as a rotating/still ratio.
    """
    traj = StaticMotion(heading_deg=45.0, lat_deg=32.06, alt_m=10.0)
    eps = 0.01 * DPH
    e = _run(np.array([0, 0, eps, 0, 0, 0.0]), 4.0, 10.0, RotationSchedule.four_position(), traj)
    lat, h = traj.lat0, traj.alt0
    a, e2, om = 6378137.0, 6.69437999014e-3, 7.292115e-5
    s2 = math.sin(lat) ** 2
    rm = a * (1 - e2) / (1 - e2 * s2) ** 1.5 + h
    rn = a / math.sqrt(1 - e2 * s2) + h
    g = 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - e2 * s2) * (1 - 2 * h / a)
    on, ou = om * math.cos(lat), om * math.sin(lat)

    def rhs(_t: float, x: np.ndarray) -> list[float]:
        pe, pn, pu, ve, vn, dlat, _dlon = x
        dphi = (
            -np.cross([0.0, on, ou], [pe, pn, pu])
            + np.array([-vn / rm, ve / rn, ve * math.tan(lat) / rn])
            + np.array([0.0, -ou * dlat, on * dlat])
            - np.array([0.0, 0.0, eps])
        )
        return [
            *dphi,
            -g * pn + 2 * ou * vn,
            g * pe - 2 * ou * ve,
            vn / rm,
            ve / (rn * math.cos(lat)),
        ]

    t = e["time_s"].to_numpy()
    sol = solve_ivp(
        rhs, (0.0, t[-1]), np.zeros(7), t_eval=t, method="DOP853", rtol=1e-10, atol=1e-14
    )
    east, north = sol.y[6] * rn * math.cos(lat), sol.y[5] * rm
    scale = float(np.max(np.hypot(east, north)))
    assert scale > 1500.0
    miss = np.hypot(e["east_m"].to_numpy() - east, e["north_m"].to_numpy() - north)
    assert np.max(miss) < 0.005 * scale


def test_vertical_channel_free_diverges_damped_holds() -> None:
    """Free vertical channel with a vertical accelerometer bias ∇: δḧ = k δh + ∇ with the
    gravity gradient k = 2g(1 + f + m − 2f sin²L)/a, so δh = (∇/k)(cosh(√k t) − 1)
    (time constant ~ 570 s). The third-order damping loop keeps it bounded."""
    b = 10 * UG
    traj = SITE
    bias = np.array([0, 0, 0, 0, 0, b])
    kw = dict(align=None, out_dt_s=10.0)
    free = ScenarioConfig("v", traj, RotationSchedule.none(), 3600.0, 10.0, vertical="free", **kw)
    e = run_scenario(free, constant_errors(bias)).errors["none"]
    t = e["time_s"].to_numpy()
    s2 = math.sin(traj.lat0) ** 2
    g0 = float(earth.gravity(traj.lat0, 0.0))
    k = 2 * g0 * (1 + earth.F + earth.M_RATIO - 2 * earth.F * s2) / earth.A
    pred = b / k * (np.cosh(math.sqrt(k) * t) - 1)
    assert pred[-1] > 100.0
    np.testing.assert_allclose(e["up_m"].to_numpy(), pred, rtol=0.02, atol=1e-3)
    damped = ScenarioConfig(
        "v", traj, RotationSchedule.none(), 3600.0, 10.0, vertical="damped", **kw
    )
    up = run_scenario(damped, constant_errors(bias)).errors["none"]["up_m"].to_numpy()
    assert np.max(np.abs(up)) < 2.0
    assert abs(up[-1]) < 0.1 * np.max(np.abs(up))  # the loop's integrator absorbs the bias

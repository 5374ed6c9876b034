"""The numba ideal-IMU synthesis equals the straightforward numpy formulation it replaced.

The reference below is the previous implementation, kept only here: the smooth-step
channels and the vehicle kinematics in numpy, the position by chunk-wise quadrature with a
two-pass fixed point on the meridian radius, the body signals by
:func:`rinscal.sim.ideal_imu.body_signals` (numpy), and the turntable by an explicit rotation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from rinscal import _kernels, earth
from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.sim.ideal_imu import ImuSynthesizer, body_signals
from rinscal.sim.trajectory import Kinematics, StepChannel, VehicleMotion, vehicle_route

RTOL = 1e-12  # of each channel's largest magnitude in a chunk (we get < 1e-14)


def _step_ref(ch: StepChannel, t: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Value and first derivative of a smooth-step channel (the former numpy code)."""
    x = np.full(t.shape, float(ch.x0))
    xd = np.zeros(t.shape)
    if not ch.starts:
        return x, xd
    s, d, dl = (np.asarray(a, dtype=float) for a in (ch.starts, ch.durations, ch.deltas))
    before = np.concatenate([[0.0], np.cumsum(dl)])
    k = np.searchsorted(s, t, side="right") - 1
    valid = k >= 0
    kk = np.where(valid, k, 0)
    u = np.where(valid, (t - s[kk]) / d[kk], 0.0)
    active = valid & (u < 1.0)
    ua = np.where(active, u, 0.0)
    tp = 2 * math.pi
    x += np.where(valid, before[kk], 0.0)
    x += np.where(active, dl[kk] * (ua - np.sin(tp * ua) / tp), np.where(valid, dl[kk], 0.0))
    xd += np.where(active, dl[kk] / d[kk] * (1 - np.cos(tp * ua)), 0.0)
    return x, xd


def _kinematics_ref(m: VehicleMotion, t: NDArray[np.float64]) -> Kinematics:
    s, sd = _step_ref(m.speed, t)
    h, hd = _step_ref(m.heading, t)
    p, pd = _step_ref(m.grade, t)
    ch, sh, cp, sp = np.cos(h), np.sin(h), np.cos(p), np.sin(p)
    v = np.stack([s * cp * sh, s * cp * ch, s * sp], axis=-1)
    a = np.stack(
        [
            sd * cp * sh + s * (-sp * pd * sh + cp * ch * hd),
            sd * cp * ch + s * (-sp * pd * ch - cp * sh * hd),
            sd * sp + s * cp * pd,
        ],
        axis=-1,
    )
    z = np.zeros_like(h)
    return Kinematics(v, a, np.stack([h, p, z], -1), np.stack([hd, pd, z], -1))


def _chunk_ref(
    m: VehicleMotion, pos: NDArray[np.float64], edges: NDArray[np.float64], dt: float
) -> tuple[NDArray, ...]:
    """Body signals at the Gauss-Legendre nodes [rad/s, m/s²], position at the edges
    [rad, rad, m] and the quadrature weights [s] of a chunk with sample interval ``dt`` [s]."""
    gx, gw = _kernels.GL_X, _kernels.GL_W
    h = 0.5 * np.diff(edges)
    kin = _kinematics_ref(m, 0.5 * (edges[:-1] + edges[1:])[:, None] + 0.5 * dt * gx[None, :])
    v = kin.v_n
    w = gw[None, :] * h[:, None]
    frac = 0.5 * (1.0 + gx)[None, :]
    d_alt = np.sum(w * v[..., 2], axis=1)
    alt_e = pos[2] + np.concatenate([[0.0], np.cumsum(d_alt)])
    alt_nd = alt_e[:-1, None] + frac * d_alt[:, None]
    lat_nd = np.full(v.shape[:2], pos[0])
    for _ in range(2):
        rn, _re = earth.principal_radii(lat_nd)
        d_lat = np.sum(w * v[..., 1] / (rn + alt_nd), axis=1)
        lat_e = pos[0] + np.concatenate([[0.0], np.cumsum(d_lat)])
        lat_nd = lat_e[:-1, None] + frac * d_lat[:, None]
    _rn, re = earth.principal_radii(lat_nd)
    d_lon = np.sum(w * v[..., 0] / ((re + alt_nd) * np.cos(lat_nd)), axis=1)
    lon_e = pos[1] + np.concatenate([[0.0], np.cumsum(d_lon)])
    w_b, f_b = body_signals(kin, lat_nd, alt_nd)
    return w_b, f_b, lat_e, lon_e, alt_e, w


def _close(new: NDArray, ref: NDArray) -> None:
    """Every column within RTOL of its largest magnitude."""
    scale = np.max(np.abs(ref), axis=0)
    np.testing.assert_allclose(new, ref, rtol=0, atol=RTOL * float(np.max(scale)))
    assert np.all(np.abs(new - ref) <= RTOL * scale + 1e-300)


@pytest.mark.parametrize("table_deg", [None, 30.0], ids=["four-position", "held-at-30deg"])
def test_synthesis_equals_the_numpy_formulation(table_deg: float | None) -> None:
    """dθ, dv and every truth channel to 1e-12 of their largest magnitude (10 min, 20 Hz,
    11 chunks: speed changes, turns, hills; the position carries from chunk to chunk)."""
    route = vehicle_route(duration_s=600.0, stationary_s=20.0, lat_deg=47.3, heading_deg=-20.0)
    if table_deg is None:
        sched = RotationSchedule.four_position(dwell_s=20.0)
    else:
        sched = RotationSchedule.none(table_deg)
    rate = 20.0
    chunks = list(ImuSynthesizer(route, sched, rate).chunks(620.0, chunk_s=60.0))
    assert len(chunks) == 11
    pos = np.array([route.lat0, route.lon0, route.alt0])
    starts, coefs, period, offset, t_start = sched.arrays()
    for ch in chunks:
        edges = (ch.k0 + np.arange(ch.n + 1)) * (1.0 / rate)  # the synthesiser's times
        w_b, f_b, lat_e, lon_e, alt_e, w = _chunk_ref(route, pos, edges, 1.0 / rate)
        pos = np.array([lat_e[-1], lon_e[-1], alt_e[-1]])
        if table_deg is None:  # the turntable by the (unchanged) rotation kernel
            dth = np.empty((ch.n, 3))
            dv = np.empty((ch.n, 3))
            phi = np.empty(ch.n)
            _kernels.rotate_increments(
                edges, w_b, f_b, starts, coefs, period, offset, t_start, False, dth, dv, phi
            )
        else:  # table at rest: dθ = C_rb ∫ω dt, dv = C_rb ∫f dt
            C_rb = C_br(table_deg * math.pi / 180).T
            dth = np.einsum("nm,nmi->ni", w, w_b) @ C_rb.T
            dv = np.einsum("nm,nmi->ni", w, f_b) @ C_rb.T
        _close(ch.dtheta, dth)
        _close(ch.dv, dv)
        _close(ch.lat, lat_e[1:])
        _close(ch.lon, lon_e[1:])
        _close(ch.alt, alt_e[1:])
        kin = _kinematics_ref(route, edges[1:])
        _close(ch.v_n, kin.v_n)
        _close(ch.euler, kin.euler)
    assert np.ptp(np.concatenate([c.euler[:, 0] for c in chunks])) > 1.5  # it turns
    assert np.ptp(np.concatenate([c.alt for c in chunks])) > 5.0  # and climbs


def test_step_channel_at_unsorted_times_equals_the_numpy_formulation() -> None:
    ch = vehicle_route(duration_s=1200.0).speed
    t = np.random.default_rng(0).uniform(-50.0, 2000.0, size=(300, 7))
    t[0, :4] = [ch.starts[0], ch.starts[1], ch.starts[1] + ch.durations[1], -1.0]
    x, xd, _ = ch.evaluate(t)
    x_ref, xd_ref = _step_ref(ch, t)
    assert x.shape == t.shape
    np.testing.assert_allclose(x, x_ref, rtol=1e-14, atol=1e-13)
    np.testing.assert_allclose(xd, xd_ref, rtol=1e-14, atol=1e-13)
    x0, xd0, xdd0 = StepChannel(2.5).evaluate(t[:3])
    assert np.all(x0 == 2.5) and np.all(xd0 == 0.0) and np.all(xdd0 == 0.0)

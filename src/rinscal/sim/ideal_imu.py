"""Exact ideal-IMU synthesis: r-frame angle and velocity increments from a trajectory.

Inverse mechanisation in ENU (Groves Ch. 5): for a body with ENU velocity ``v``, its
derivative ``v̇`` and attitude ``C_nb`` at latitude ``L`` and height ``h``,

    ω_ib^b = ω_nb^b + C_bn (ω_ie^n + ω_en^n)
    f^b    = C_bn (v̇ + (2 ω_ie^n + ω_en^n) × v − g^n)

with ``ω_ie^n = Ω (0, cos L, sin L)``, ``ω_en^n = (−v_N/(R_N+h), v_E/(R_E+h),
v_E tan L/(R_E+h))`` and ``g^n = (0, 0, −g(L, h))`` (normal gravity). The turntable then
gives ``ω_ir^r = C_rb ω_ib^b + φ̇ z`` and ``f^r = C_rb f^b``, and each output sample is the
integral over its interval (an increment [rad], [m/s]), computed by 4-point
Gauss-Legendre quadrature split at the schedule's break points: exact to rounding for the
smooth pieces we use. For a body at rest the outputs are exactly Earth rate and gravity.

Position is integrated from the velocity in the same quadrature (latitude by a two-pass
fixed point on the meridian radius), chunk by chunk, so memory stays bounded.

A moving carrier's position, body signals and turntable rotation are computed by the numba
kernels :func:`rinscal._kernels.moving_body_signals` and
:func:`rinscal._kernels.rotate_increments`; :func:`body_signals` is the same inverse
mechanisation in numpy (vectorised, for checks and small inputs). The two agree to rounding
(``tests/nav/test_synthesis_reference.py``).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rinscal import _kernels, earth
from rinscal.errors import ConfigError
from rinscal.nav.rotation import RotationSchedule
from rinscal.sim.trajectory import (
    C_nb_from_euler,
    Kinematics,
    Trajectory,
    body_rate_from_euler,
)

_GL_X = _kernels.GL_X


@dataclass(frozen=True)
class ImuChunk:
    """Ideal IMU output and truth for samples ``k0+1 .. k0+n`` (sample ``k`` ends at ``k·dt``).

    Attributes
    ----------
    k0 : int
        Number of samples before this chunk.
    t : ndarray, shape (n,) [s]
        End time of each sample interval.
    dtheta : ndarray, shape (n, 3) [rad]
        Ideal r-frame angle increments ∫ω_ir^r dt.
    dv : ndarray, shape (n, 3) [m/s]
        Ideal r-frame velocity increments ∫f^r dt.
    encoder : ndarray, shape (n,) [rad]
        Encoder angle φ at ``t``.
    lat, lon, alt : ndarray, shape (n,) [rad, rad, m]
        True position at ``t``.
    v_n : ndarray, shape (n, 3) [m/s]
        True ENU velocity at ``t``.
    euler : ndarray, shape (n, 3) [rad]
        True body heading, pitch, roll at ``t``.
    """

    k0: int
    t: NDArray[np.float64]
    dtheta: NDArray[np.float64]
    dv: NDArray[np.float64]
    encoder: NDArray[np.float64]
    lat: NDArray[np.float64]
    lon: NDArray[np.float64]
    alt: NDArray[np.float64]
    v_n: NDArray[np.float64]
    euler: NDArray[np.float64]

    @property
    def n(self) -> int:
        return self.t.shape[0]


def transport_rate_n(
    lat: NDArray[np.float64], alt: NDArray[np.float64], v_n: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Transport rate ω_en^n in ENU [rad/s] for position and ENU velocity."""
    rn, re = earth.principal_radii(lat)
    out = np.empty(np.shape(v_n))
    out[..., 0] = -v_n[..., 1] / (rn + alt)
    out[..., 1] = v_n[..., 0] / (re + alt)
    out[..., 2] = v_n[..., 0] * np.tan(lat) / (re + alt)
    return out


def body_signals(
    kin: Kinematics, lat: NDArray[np.float64], alt: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ideal ω_ib^b [rad/s] and f^b [m/s²] of a body motion (inverse mechanisation).

    Parameters
    ----------
    kin : Kinematics
        Body motion at a set of times.
    lat, alt : ndarray [rad, m]
        Position at the same times.

    Returns
    -------
    w_b, f_b : ndarray, shape (..., 3)
    """
    C_nb = C_nb_from_euler(kin.euler)
    w_ie = earth.rate_n(lat)
    w_en = transport_rate_n(lat, alt, kin.v_n)
    w_in = w_ie + w_en
    w_b = body_rate_from_euler(kin.euler, kin.euler_rate) + np.einsum(
        "...ji,...j->...i", C_nb, w_in
    )
    f_n = kin.a_n + np.cross(2 * w_ie + w_en, kin.v_n) - earth.gravity_n(lat, alt)
    f_b = np.einsum("...ji,...j->...i", C_nb, f_n)
    return w_b, f_b


class ImuSynthesizer:
    """Ideal r-frame increments and truth for a trajectory on a turntable, chunk by chunk.

    Parameters
    ----------
    trajectory : Trajectory
        Carrier motion (``StaticMotion``, ``SwingMotion``, ``VehicleMotion`` ...).
    schedule : RotationSchedule
        Turntable encoder angle against time.
    rate_hz : float [Hz]
        Output rate.
    """

    def __init__(self, trajectory: Trajectory, schedule: RotationSchedule, rate_hz: float) -> None:
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise ConfigError(f"rate_hz must be > 0, got {rate_hz}")
        self.trajectory = trajectory
        self.schedule = schedule
        self.rate_hz = float(rate_hz)
        self.dt = 1.0 / self.rate_hz
        self._sched = schedule.arrays()
        self._k = 0
        self._pos = np.array([trajectory.lat0, trajectory.lon0, trajectory.alt0])
        if trajectory.is_static:
            kin = trajectory.kinematics(np.zeros(1))
            lat = np.array([trajectory.lat0])
            alt = np.array([trajectory.alt0])
            w_b, f_b = body_signals(kin, lat, alt)
            self._w_const = np.ascontiguousarray(np.broadcast_to(w_b.reshape(1, 1, 3), (1, 4, 3)))
            self._f_const = np.ascontiguousarray(np.broadcast_to(f_b.reshape(1, 1, 3), (1, 4, 3)))
            self._euler_const = kin.euler[0].copy()

    @property
    def samples_done(self) -> int:
        """Number of samples synthesised so far."""
        return self._k

    def next_chunk(self, n: int) -> ImuChunk:
        """Synthesise the next ``n`` samples."""
        if n <= 0:
            raise ConfigError(f"chunk size must be > 0 samples, got {n}")
        k0 = self._k
        dt = self.dt
        edges = (k0 + np.arange(n + 1)) * dt
        tr = self.trajectory
        if tr.is_static:
            w_b, f_b = self._w_const, self._f_const
            lat = np.full(n, tr.lat0)
            lon = np.full(n, tr.lon0)
            alt = np.full(n, tr.alt0)
            v_n = np.zeros((n, 3))
            euler = np.broadcast_to(self._euler_const, (n, 3)).copy()
        else:
            half = 0.5 * dt
            t_nodes = 0.5 * (edges[:-1] + edges[1:])[:, None] + half * _GL_X[None, :]
            kin_nodes = tr.kinematics(t_nodes)
            kin_edges = tr.kinematics(edges)
            w_b = np.empty((n, 4, 3))
            f_b = np.empty((n, 4, 3))
            lat_e = np.empty(n + 1)
            lon_e = np.empty(n + 1)
            alt_e = np.empty(n + 1)
            lat0, lon0, alt0 = self._pos
            _kernels.moving_body_signals(
                edges,
                *(
                    np.ascontiguousarray(np.broadcast_to(a, (n, 4, 3)), dtype=float)
                    for a in (kin_nodes.v_n, kin_nodes.a_n, kin_nodes.euler, kin_nodes.euler_rate)
                ),
                float(lat0),
                float(lon0),
                float(alt0),
                w_b,
                f_b,
                lat_e,
                lon_e,
                alt_e,
            )
            lat, lon, alt = lat_e[1:], lon_e[1:], alt_e[1:]
            v_n = kin_edges.v_n[1:]
            euler = kin_edges.euler[1:]
            self._pos = np.array([lat_e[-1], lon_e[-1], alt_e[-1]])
        dtheta = np.empty((n, 3))
        dv = np.empty((n, 3))
        phi = np.empty(n)
        starts, coefs, period, offset, t_start = self._sched
        _kernels.rotate_increments(
            edges, w_b, f_b, starts, coefs, period, offset, t_start, tr.is_static, dtheta, dv, phi
        )
        self._k = k0 + n
        return ImuChunk(k0, edges[1:], dtheta, dv, phi, lat, lon, alt, v_n, euler)

    def chunks(
        self, duration_s: float, chunk_s: float = 60.0, split_at: tuple[float, ...] = ()
    ) -> Iterator[ImuChunk]:
        """Iterate over chunks covering ``[0, duration_s]`` (from the current position).

        Parameters
        ----------
        duration_s : float [s]
            End time.
        chunk_s : float [s]
            Nominal chunk length.
        split_at : tuple of float [s]
            Times at which a chunk must end (e.g. the end of the alignment).
        """
        n_total = round(duration_s * self.rate_hz)
        n_chunk = max(1, round(chunk_s * self.rate_hz))
        splits = sorted({round(s * self.rate_hz) for s in split_at if 0 < s < duration_s})
        while self._k < n_total:
            stop = min(self._k + n_chunk, n_total)
            for s in splits:
                if self._k < s < stop:
                    stop = s
                    break
            yield self.next_chunk(stop - self._k)


def static_increments(
    lat: float, heading: float, encoder: float, dt: float, alt: float = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ideal increments of a level IMU at rest (Earth rate and gravity times ``dt``).

    The body y axis points at ``heading`` [rad] and the table holds ``encoder`` [rad].
    """
    C_nb = C_nb_from_euler(np.array([heading, 0.0, 0.0]))
    C_nr = C_nb @ np.array(
        [
            [math.cos(encoder), -math.sin(encoder), 0],
            [math.sin(encoder), math.cos(encoder), 0],
            [0, 0, 1],
        ]
    )
    w = C_nr.T @ earth.rate_n(lat)
    f = C_nr.T @ -earth.gravity_n(lat, alt)
    return w * dt, f * dt


__all__ = ["ImuChunk", "ImuSynthesizer", "body_signals", "static_increments", "transport_rate_n"]

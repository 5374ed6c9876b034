"""Strapdown navigation on r-frame increments, ENU (the public face of the numba kernel).

The integrator follows Savage (1998) in the ENU frame: two-sample (previous-sample) coning
and sculling, the rotation-compensation term ½ Δθ × Δv, exact exponential updates of the
body (r) and navigation frames, Coriolis and transport rate evaluated at the mid-interval
velocity, normal gravity (same formula as :func:`rinscal.earth.gravity`), and a
trapezoidal position update. The vertical channel of a marine or land RINS is either held
to a reference (altitude and vertical velocity, e.g. the truth or an altimeter), damped by
a third-order loop towards a reference altitude, or left free (unstable, for tests).

Attitude is kept as the quaternion of ``C_nr``; the body attitude is ``C_nb = C_nr C_rb(φ)``
with the encoder angle φ.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal import _kernels
from rinscal.errors import ConfigError

VerticalMode = Literal["hold", "damped", "free"]
_VMODES = {
    "hold": _kernels.VERTICAL_HOLD,
    "damped": _kernels.VERTICAL_DAMPED,
    "free": _kernels.VERTICAL_FREE,
}


# --------------------------------------------------------------------------- quaternions
def _dcm_rows(w: Any, x: Any, y: Any, z: Any) -> tuple[tuple[Any, Any, Any], ...]:
    """The rotation matrix's entries, row by row, from a quaternion's components (Python
    floats or arrays alike)."""
    return (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def quat_to_dcm(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix of unit quaternion(s) ``q`` (scalar first), shape (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    if q.shape == (4,):  # one: on Python floats (the same bits, 10x faster)
        return np.array(_dcm_rows(*q.tolist()))
    out = np.empty((*q.shape[:-1], 3, 3))
    for i, row in enumerate(_dcm_rows(q[..., 0], q[..., 1], q[..., 2], q[..., 3])):
        for j, entry in enumerate(row):
            out[..., i, j] = entry
    return out


def dcm_to_quat(C: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion (scalar first, non-negative scalar) of a rotation matrix (3, 3)."""
    C = np.asarray(C, dtype=float)
    tr = np.trace(C)
    cands = np.array([tr, C[0, 0], C[1, 1], C[2, 2]])
    k = int(np.argmax(cands))
    if k == 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = [0.25 * s, (C[2, 1] - C[1, 2]) / s, (C[0, 2] - C[2, 0]) / s, (C[1, 0] - C[0, 1]) / s]
    elif k == 1:
        s = 2.0 * math.sqrt(1.0 + C[0, 0] - C[1, 1] - C[2, 2])
        q = [(C[2, 1] - C[1, 2]) / s, 0.25 * s, (C[0, 1] + C[1, 0]) / s, (C[0, 2] + C[2, 0]) / s]
    elif k == 2:
        s = 2.0 * math.sqrt(1.0 + C[1, 1] - C[0, 0] - C[2, 2])
        q = [(C[0, 2] - C[2, 0]) / s, (C[0, 1] + C[1, 0]) / s, 0.25 * s, (C[1, 2] + C[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + C[2, 2] - C[0, 0] - C[1, 1])
        q = [(C[1, 0] - C[0, 1]) / s, (C[0, 2] + C[2, 0]) / s, (C[1, 2] + C[2, 1]) / s, 0.25 * s]
    qa = np.asarray(q)
    qa /= np.linalg.norm(qa)
    return qa if qa[0] >= 0 else -qa


def rotvec_to_dcm(rv: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix exp([rv×]) of a rotation vector [rad]."""
    rv = np.asarray(rv, dtype=float)
    q = np.array(_kernels.quat_from_rotvec(float(rv[0]), float(rv[1]), float(rv[2])))
    return quat_to_dcm(q)


def skew(v: ArrayLike) -> NDArray[np.float64]:
    """Cross-product matrix [v×]."""
    x, y, z = np.asarray(v, dtype=float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


# --------------------------------------------------------------------------- integrator
class Strapdown:
    """Strapdown INS state and integrator.

    Parameters
    ----------
    lat, lon : float [rad]
        Initial position.
    alt : float [m]
        Initial height above the ellipsoid.
    v_n : array_like, shape (3,) [m/s]
        Initial ENU velocity.
    C_nr : array_like, shape (3, 3)
        Initial attitude of the IMU frame r.
    dt : float [s]
        Sample interval of the increments.
    vertical : {"hold", "damped", "free"}
        Vertical channel: held to a reference, damped towards a reference altitude, or free.
    damping_tau_s : float [s]
        Time constant of the third-order damping loop (``damped`` mode).
    rotation_term : bool
        Include the second-order rotation term (1/6) Δθ × (Δθ × Δv) of the velocity
        increment (default). ``False`` gives the classical two-sample algorithm (as pyins
        does), whose error grows with the square of the sample interval while the IMU spins.
    """

    def __init__(
        self,
        lat: float,
        lon: float,
        alt: float,
        v_n: ArrayLike,
        C_nr: ArrayLike,
        dt: float,
        vertical: VerticalMode = "hold",
        damping_tau_s: float = 100.0,
        rotation_term: bool = True,
    ) -> None:
        if vertical not in _VMODES:
            raise ConfigError(
                f"strapdown: vertical must be one of {sorted(_VMODES)}, got {vertical!r}"
            )
        if not (math.isfinite(dt) and dt > 0):
            raise ConfigError(f"strapdown: dt must be > 0 s, got {dt}")
        if not (math.isfinite(damping_tau_s) and damping_tau_s > 0):
            raise ConfigError(f"strapdown: damping_tau_s must be > 0 s, got {damping_tau_s}")
        self.dt = float(dt)
        self.rotation_term = bool(rotation_term)
        self.vertical = vertical
        self._vmode = _VMODES[vertical]
        tau = float(damping_tau_s)
        self._k_loop = np.array([3.0 / tau, 3.0 / tau**2, 1.0 / tau**3])
        self.state = np.zeros(_kernels.STATE_SIZE)
        self.state[0:3] = (lat, lon, alt)
        self.state[3:6] = np.asarray(v_n, dtype=float)
        self.state[6:10] = dcm_to_quat(C_nr)
        self.k = 0
        self._alt_ref = np.array([float(alt)])
        self._vu_ref = np.array([float(self.state[5])])

    # ------------------------------------------------------------------ accessors
    @property
    def lat(self) -> float:
        return float(self.state[0])

    @property
    def lon(self) -> float:
        return float(self.state[1])

    @property
    def alt(self) -> float:
        return float(self.state[2])

    @property
    def v_n(self) -> NDArray[np.float64]:
        return self.state[3:6].copy()

    @property
    def q_nr(self) -> NDArray[np.float64]:
        return self.state[6:10].copy()

    @property
    def C_nr(self) -> NDArray[np.float64]:
        return quat_to_dcm(self.state[6:10])

    def set_reference(self, alt: float, vu: float = 0.0) -> None:
        """Constant reference altitude [m] and vertical velocity [m/s] for later steps."""
        self._alt_ref = np.array([float(alt)])
        self._vu_ref = np.array([float(vu)])

    # ------------------------------------------------------------------ integration
    def run(
        self,
        dtheta: NDArray[np.float64],
        dv: NDArray[np.float64],
        alt_ref: NDArray[np.float64] | None = None,
        vu_ref: NDArray[np.float64] | None = None,
        out_every: int = 0,
    ) -> NDArray[np.float64]:
        """Integrate increments; return the state every ``out_every``-th step.

        Parameters
        ----------
        dtheta, dv : ndarray, shape (n, 3) [rad], [m/s]
            r-frame increments (already compensated for sensor errors).
        alt_ref, vu_ref : ndarray, shape (n,), optional [m], [m/s]
            Reference altitude and vertical velocity at the end of each step; default:
            the constant reference of :meth:`set_reference` (initially the start altitude).
        out_every : int
            Decimation of the output (0: none). Steps are counted globally over calls.

        Returns
        -------
        ndarray, shape (m, 10)
            Rows ``lat, lon, alt, vE, vN, vU, q0, q1, q2, q3`` after every
            ``out_every``-th step.
        """
        dtheta = np.ascontiguousarray(dtheta, dtype=float)
        dv = np.ascontiguousarray(dv, dtype=float)
        n = dtheta.shape[0]
        if dtheta.shape != (n, 3) or dv.shape != (n, 3):
            raise ConfigError("strapdown: dtheta and dv must both have shape (n, 3)")
        a_ref = self._alt_ref if alt_ref is None else np.ascontiguousarray(alt_ref, dtype=float)
        v_ref = self._vu_ref if vu_ref is None else np.ascontiguousarray(vu_ref, dtype=float)
        if a_ref.shape[0] not in (1, n) or v_ref.shape[0] not in (1, n):
            raise ConfigError("strapdown: alt_ref and vu_ref must have length 1 or n")
        if alt_ref is not None:
            self._alt_ref = a_ref[-1:].copy()
        if vu_ref is not None:
            self._vu_ref = v_ref[-1:].copy()
        m = 0
        if out_every > 0:
            m = (self.k + n) // out_every - self.k // out_every
        out = np.empty((max(m, 1), _kernels.OUT_SIZE))
        got = _kernels.strapdown(
            self.state,
            dtheta,
            dv,
            self.dt,
            a_ref,
            v_ref,
            self._vmode,
            self._k_loop,
            out,
            int(out_every),
            int(self.k),
            self.rotation_term,
        )
        self.k += n
        return out[:got]

    # ------------------------------------------------------------------ corrections
    def correct(self, phi_n: ArrayLike | None = None, dv_n: ArrayLike | None = None) -> None:
        """Apply error estimates (closed-loop feedback).

        Parameters
        ----------
        phi_n : array_like, shape (3,) [rad], optional
            Attitude error φ with ``C̃_nr = (I − [φ×]) C_nr``; the attitude becomes
            ``exp([φ×]) C̃_nr``.
        dv_n : array_like, shape (3,) [m/s], optional
            Velocity error (estimate minus truth), subtracted.
        """
        if phi_n is not None:
            p = np.asarray(phi_n, dtype=float)
            b = _kernels.quat_from_rotvec(float(p[0]), float(p[1]), float(p[2]))
            q = self.state[6:10]
            qn = np.array(_kernels.quat_mul(*b, *q))
            self.state[6:10] = qn / np.linalg.norm(qn)
        if dv_n is not None:
            self.state[3:6] -= np.asarray(dv_n, dtype=float)

    def reset(
        self,
        lat: float | None = None,
        lon: float | None = None,
        alt: float | None = None,
        v_n: ArrayLike | None = None,
    ) -> None:
        """Overwrite position and/or velocity (e.g. at the end of a zero-velocity alignment)."""
        if lat is not None:
            self.state[0] = lat
        if lon is not None:
            self.state[1] = lon
        if alt is not None:
            self.state[2] = alt
        if v_n is not None:
            self.state[3:6] = np.asarray(v_n, dtype=float)
            self.state[18:21] = 0.0


__all__ = ["Strapdown", "VerticalMode", "dcm_to_quat", "quat_to_dcm", "rotvec_to_dcm", "skew"]

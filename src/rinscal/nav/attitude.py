"""Attitude transforms shared by the simulator and navigation: Euler angles to ``C_nb`` and
back, vectorised, and the small-angle error between two attitudes (all angles in rad).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def C_nb_from_euler(euler: ArrayLike) -> NDArray[np.float64]:
    """Vectorised :func:`rinscal.earth.C_nb_from_euler`.

    Parameters
    ----------
    euler : array_like, shape (..., 3) [rad]
        Heading, pitch, roll.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    e = np.asarray(euler, dtype=float)
    ch, sh = np.cos(e[..., 0]), np.sin(e[..., 0])
    cp, sp = np.cos(e[..., 1]), np.sin(e[..., 1])
    cr, sr = np.cos(e[..., 2]), np.sin(e[..., 2])
    out = np.empty((*e.shape[:-1], 3, 3))
    # Rz(-heading) @ Rx(pitch) @ Ry(roll), multiplied out
    out[..., 0, 0] = ch * cr + sh * sp * sr
    out[..., 0, 1] = sh * cp
    out[..., 0, 2] = ch * sr - sh * sp * cr
    out[..., 1, 0] = -sh * cr + ch * sp * sr
    out[..., 1, 1] = ch * cp
    out[..., 1, 2] = -sh * sr - ch * sp * cr
    out[..., 2, 0] = -cp * sr
    out[..., 2, 1] = sp
    out[..., 2, 2] = cp * cr
    return out


def euler_from_C_nb(C: ArrayLike) -> NDArray[np.float64]:
    """Heading, pitch, roll [rad] of ``C_nb`` (inverse of :func:`C_nb_from_euler`)."""
    C = np.asarray(C, dtype=float)
    heading = np.arctan2(C[..., 0, 1], C[..., 1, 1])
    pitch = np.arcsin(np.clip(C[..., 2, 1], -1.0, 1.0))
    roll = np.arctan2(-C[..., 2, 0], C[..., 2, 2])
    return np.stack([heading, pitch, roll], axis=-1)


def attitude_error(C_true: NDArray, C_est: NDArray) -> NDArray[np.float64]:
    """Small-angle φ with C_est = (I − [φ×]) C_true, shape (m, 3) [rad]."""
    M = np.einsum("mij,mkj->mik", C_true, C_est)
    return 0.5 * np.stack(
        [M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0], M[:, 1, 0] - M[:, 0, 1]], axis=1
    )


__all__ = ["C_nb_from_euler", "attitude_error", "euler_from_C_nb"]

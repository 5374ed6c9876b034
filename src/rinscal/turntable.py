"""Geometry of the two-axis turntable in the thermal chamber: the IMU's attitude from the
axis angles, and the reference rate and specific force it feels.

Both the simulator (:mod:`rinscal.sim`) and the IMU calibration
(:mod:`rinscal.calibration.imu`) use it, so it lives on the ground floor.

The table (a U-O type): the **outer** axis is horizontal and points at the azimuth
``heading`` (clockwise from north); the **inner** axis is carried by the outer frame,
perpendicular to it, and is vertical when the outer angle is zero. The IMU is mounted on the
inner table with its z axis along the inner axis and its y axis along the outer axis at
zero angles, so at (0°, 0°) the IMU frame ``r`` is level, z up, y at ``heading`` (the
navigation convention of :func:`rinscal.earth.static_outputs_r`). Then::

    C_nr(o, i) = C_n0 · R_y(o) · R_z(i)

with ``C_n0`` the level frame at ``heading``, ``R_y(o)`` a right-handed rotation by the outer
angle ``o`` about the outer axis (IMU y at zero) and ``R_z(i)`` by the inner angle ``i``
about the inner axis (IMU z). Every IMU axis can point up or down: z up at (0, 0), x up at
(−90°, 0), y up at (90°, 90°).

An angular rate ``ω_o`` of the outer axis is felt by the IMU as ``R_z(i)ᵀ · (0, ω_o, 0)``,
one of the inner axis as ``(0, 0, ω_i)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal import earth, units

__all__ = [
    "C_nr",
    "reference_r",
    "table_rate_r",
]


def _rot_y(a: NDArray[np.float64]) -> NDArray[np.float64]:
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack(
        [np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2
    )


def _rot_z(a: NDArray[np.float64]) -> NDArray[np.float64]:
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack(
        [np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2
    )


def C_nr(outer_deg: ArrayLike, inner_deg: ArrayLike, heading: float) -> NDArray[np.float64]:
    """Attitude of the IMU on the table: ``v_n = C_nr @ v_r``.

    Parameters
    ----------
    outer_deg, inner_deg : array_like, shape (n,) or scalar [deg]
        Axis angles.
    heading : float [rad]
        Azimuth of the outer axis (= IMU y at zero), clockwise from north.

    Returns
    -------
    ndarray, shape (n, 3, 3) or (3, 3)
    """
    o = np.asarray(outer_deg, dtype=float) * units.DEG_TO_RAD
    i = np.asarray(inner_deg, dtype=float) * units.DEG_TO_RAD
    c0 = earth.C_nb_from_euler(heading, 0.0, 0.0)
    return c0 @ _rot_y(o) @ _rot_z(i)


def table_rate_r(
    inner_deg: ArrayLike, outer_rate_dps: ArrayLike, inner_rate_dps: ArrayLike
) -> NDArray[np.float64]:
    """The table's own angular rate felt by the IMU, resolved in ``r``.

    Parameters
    ----------
    inner_deg : array_like, shape (n,) or scalar [deg]
        Inner-axis angle.
    outer_rate_dps, inner_rate_dps : array_like, shape (n,) or scalar [deg/s]
        Axis rates.

    Returns
    -------
    ndarray, shape (n, 3) or (3,) [rad/s]
    """
    i = np.asarray(inner_deg, dtype=float) * units.DEG_TO_RAD
    wo = np.asarray(outer_rate_dps, dtype=float) * units.DPS_TO_RPS
    wi = np.asarray(inner_rate_dps, dtype=float) * units.DPS_TO_RPS
    i, wo, wi = np.broadcast_arrays(i, wo, wi)
    # R_z(i)^T (0, wo, 0) = (wo sin i, wo cos i, 0)
    return np.stack([wo * np.sin(i), wo * np.cos(i), wi], axis=-1)


def reference_r(
    outer_deg: ArrayLike,
    inner_deg: ArrayLike,
    lat: float,
    heading: float,
    alt: float = 0.0,
    outer_rate_dps: ArrayLike = 0.0,
    inner_rate_dps: ArrayLike = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """What an ideal IMU on the table feels: Earth rate plus the table's rate, and gravity.

    Parameters
    ----------
    outer_deg, inner_deg : array_like, shape (n,) or scalar [deg]
        Axis angles.
    lat : float [rad]
        Geodetic latitude.
    heading : float [rad]
        Azimuth of the outer axis, clockwise from north.
    alt : float [m]
        Height above the ellipsoid.
    outer_rate_dps, inner_rate_dps : array_like, shape (n,) or scalar [deg/s]
        Axis rates.

    Returns
    -------
    omega_ir_r : ndarray, shape (n, 3) or (3,) [rad/s]
        Angular rate of ``r`` with respect to inertial space, in ``r``.
    f_r : ndarray, shape (n, 3) or (3,) [m/s²]
        Specific force in ``r`` (the IMU at the table's centre: no lever arm).
    """
    c_rn = np.swapaxes(C_nr(outer_deg, inner_deg, heading), -1, -2)
    omega = c_rn @ earth.rate_n(lat)
    f = c_rn @ (-earth.gravity_n(lat, alt))
    omega = omega + table_rate_r(inner_deg, outer_rate_dps, inner_rate_dps)
    return omega, f

"""WGS84 Earth model: radii, normal gravity and Earth rate, in the ENU navigation frame.

All angles in radians, heights in metres, rates in rad/s, accelerations in m/s².
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: WGS84 semi-major axis [m].
A = 6378137.0
#: WGS84 flattening [-].
F = 1.0 / 298.257223563
#: WGS84 first eccentricity squared [-].
E2 = F * (2.0 - F)
#: WGS84 semi-minor axis [m].
B = A * (1.0 - F)
#: Earth rotation rate relative to the inertial frame (WGS84) [rad/s].
RATE = 7.292115e-5
#: WGS84 geocentric gravitational constant [m³/s²].
GM = 3.986004418e14
#: Normal gravity at the equator (Somigliana) [m/s²].
GE = 9.7803253359
#: Normal gravity at the poles (Somigliana) [m/s²].
GP = 9.8321849378
#: Somigliana's constant k = (b·gp − a·ge)/(a·ge) [-].
K_SOMIGLIANA = (B * GP - A * GE) / (A * GE)
#: m = ω²a²b/GM, used in the height correction of normal gravity [-].
M_RATIO = RATE**2 * A**2 * B / GM


def principal_radii(lat: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Meridian and transverse (prime-vertical) radii of curvature.

    Parameters
    ----------
    lat : array_like [rad]
        Geodetic latitude.

    Returns
    -------
    rn : ndarray [m]
        Meridian radius of curvature (north-south), R_N in Groves.
    re : ndarray [m]
        Transverse radius of curvature (east-west), R_E in Groves.
    """
    s2 = np.sin(np.asarray(lat, dtype=float)) ** 2
    x = 1.0 - E2 * s2
    return A * (1.0 - E2) / x**1.5, A / np.sqrt(x)


def gravity(lat: ArrayLike, alt: ArrayLike = 0.0) -> NDArray[np.float64]:
    """Magnitude of normal gravity (Somigliana with the WGS84 height correction).

    Parameters
    ----------
    lat : array_like [rad]
        Geodetic latitude.
    alt : array_like [m]
        Height above the ellipsoid.

    Returns
    -------
    ndarray [m/s²]
        Magnitude of gravity (gravitation plus centrifugal), pointing down.
    """
    s2 = np.sin(np.asarray(lat, dtype=float)) ** 2
    alt = np.asarray(alt, dtype=float)
    g0 = GE * (1.0 + K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    return g0 * (1.0 - 2.0 / A * (1.0 + F + M_RATIO - 2.0 * F * s2) * alt + 3.0 * alt**2 / A**2)


def gravity_n(lat: ArrayLike, alt: ArrayLike = 0.0) -> NDArray[np.float64]:
    """Gravity vector in the ENU navigation frame.

    Parameters
    ----------
    lat : array_like [rad]
        Geodetic latitude.
    alt : array_like [m]
        Height above the ellipsoid.

    Returns
    -------
    ndarray, shape (..., 3) [m/s²]
        ``(0, 0, -g)``.
    """
    g = gravity(lat, alt)
    out = np.zeros((*g.shape, 3))
    out[..., 2] = -g
    return out


def rate_n(lat: ArrayLike) -> NDArray[np.float64]:
    """Earth rate resolved in the ENU navigation frame, ω_ie^n.

    Parameters
    ----------
    lat : array_like [rad]
        Geodetic latitude.

    Returns
    -------
    ndarray, shape (..., 3) [rad/s]
        ``(0, Ω cos φ, Ω sin φ)``.
    """
    lat = np.asarray(lat, dtype=float)
    out = np.zeros((*lat.shape, 3))
    out[..., 1] = RATE * np.cos(lat)
    out[..., 2] = RATE * np.sin(lat)
    return out


def static_outputs_r(lat: float, heading: float, alt: float = 0.0) -> tuple[NDArray, NDArray]:
    """Ideal gyro and accelerometer outputs of a level IMU at rest on the Earth.

    The IMU frame ``r`` is level (z up) with its y axis pointing at ``heading``, measured
    clockwise from north (so heading 0 means x east, y north).

    Parameters
    ----------
    lat : float [rad]
        Geodetic latitude.
    heading : float [rad]
        Azimuth of the IMU y axis, clockwise from north.
    alt : float [m]
        Height above the ellipsoid.

    Returns
    -------
    omega_ir_r : ndarray, shape (3,) [rad/s]
        Angular rate of ``r`` relative to inertial space, resolved in ``r`` (Earth rate).
    f_r : ndarray, shape (3,) [m/s²]
        Specific force resolved in ``r`` (``+g`` on z).
    """
    C_rn = C_nb_from_euler(heading, 0.0, 0.0).T
    return C_rn @ rate_n(lat), C_rn @ (-gravity_n(lat, alt))


def C_nb_from_euler(heading: float, pitch: float, roll: float) -> NDArray[np.float64]:
    """Rotation matrix from body (x right, y forward, z up) to ENU navigation frame.

    Rotation order heading (about −z, clockwise from north), then pitch (about x, nose up
    positive), then roll (about y, right wing down positive), as usual for ENU/RFU.

    Parameters
    ----------
    heading, pitch, roll : float [rad]
        Euler angles.

    Returns
    -------
    ndarray, shape (3, 3)
        ``C_nb`` such that ``v_n = C_nb @ v_b``.
    """
    ch, sh = np.cos(heading), np.sin(heading)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cr, sr = np.cos(roll), np.sin(roll)
    # yaw psi = -heading about z (ENU convention: counter-clockwise positive)
    Rz = np.array([[ch, sh, 0.0], [-sh, ch, 0.0], [0.0, 0.0, 1.0]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    Ry = np.array([[cr, 0.0, sr], [0.0, 1.0, 0.0], [-sr, 0.0, cr]])
    return Rz @ Rx @ Ry


def enu_difference(
    lat: ArrayLike,
    lon: ArrayLike,
    alt: ArrayLike,
    lat0: ArrayLike,
    lon0: ArrayLike,
    alt0: ArrayLike,
) -> NDArray[np.float64]:
    """Small position difference ``(lat, lon, alt) − (lat0, lon0, alt0)`` in metres, ENU.

    Parameters
    ----------
    lat, lon, lat0, lon0 : array_like [rad]
    alt, alt0 : array_like [m]

    Returns
    -------
    ndarray, shape (..., 3) [m]
        East, north, up (first order in the difference: exact to ~1e-6 relative for the
        few hundred metres a filter ever sees).
    """
    lat0 = np.asarray(lat0, dtype=float)
    alt0 = np.asarray(alt0, dtype=float)
    rn, re = principal_radii(lat0)
    dlat = np.asarray(lat, dtype=float) - lat0
    dlon = np.asarray(lon, dtype=float) - np.asarray(lon0, dtype=float)
    return np.stack(
        [
            dlon * (re + alt0) * np.cos(lat0),
            dlat * (rn + alt0),
            np.asarray(alt, dtype=float) - alt0,
        ],
        axis=-1,
    )

"""The one linear least-squares solve of the calibration code: numpy only.

Every regression of :mod:`rinscal.calibration` ends here: the thermal models' blocked QR
(:func:`rinscal.calibration.thermal.fitting.solve_r` solves its small triangular system with
it), the field's cubics (PX4's and ArduPilot's ``np.polyfit``, :func:`polynomial_fit`), the
IMU's weighted regressions and laws (:mod:`rinscal.calibration.imu`), the temperature rate of
a ramp, the line under an edge step (:mod:`rinscal.calibration.evaluate`) and the Allan noise
fit (:mod:`rinscal.calibration.allan`).

It is LAPACK's SVD least squares (``numpy.linalg.lstsq``, ``gelsd``): minimum-norm where the
design is rank-deficient, singular values below machine precision × max(rows, columns) of
the largest treated as zero. Callers that must refuse a rank-deficient design check it
themselves (:mod:`rinscal.calibration.thermal.guards`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["least_squares", "polynomial_fit"]


def least_squares(
    a: ArrayLike,
    y: ArrayLike,
    sd: ArrayLike | None = None,
    *,
    equilibrate: bool = False,
) -> NDArray[np.float64]:
    """Coefficients ``β`` minimising ``‖(A β − y) / sd‖``.

    Parameters
    ----------
    a : array_like, shape (n, k) [unit of each column]
        Design.
    y : array_like, shape (n,) or (n, m) [unit of y]
        Observations (each column of a 2-D ``y`` fitted apart, on the same design).
    sd : array_like, shape (n,), optional [unit of y]
        Standard deviation of each observation: rows weighted by ``1 / sd`` (default: alike).
    equilibrate : bool
        Scale each column of the (weighted) design to unit norm before solving, and the
        coefficients back after (what ``np.polyfit`` does; the same ``β`` in exact arithmetic,
        a better conditioned solve for a Vandermonde design).

    Returns
    -------
    ndarray, shape (k,) or (k, m) [unit of y / unit of each column]
    """
    a = np.asarray(a, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if sd is not None:
        w = np.asarray(sd, dtype=np.float64)
        a = a / w[:, None]
        y = y / (w if y.ndim == 1 else w[:, None])
    if not equilibrate:
        return np.asarray(np.linalg.lstsq(a, y, rcond=None)[0], dtype=np.float64)
    scale = np.sqrt((a * a).sum(axis=0))
    coef = np.linalg.lstsq(a / scale, y, rcond=None)[0]
    return np.asarray((coef.T / scale).T, dtype=np.float64)


def polynomial_fit(x: ArrayLike, y: ArrayLike, degree: int) -> NDArray[np.float64]:
    """Least-squares polynomial in ``x``, highest power first: ``np.polyfit(x, y, degree)``.

    The same numbers as ``np.polyfit`` (a Vandermonde design, its columns equilibrated, the
    same SVD solve and cut-off) without its warning of a poorly conditioned fit.

    Parameters
    ----------
    x : array_like, shape (n,) [unit of x]
        Abscissae, at least ``degree + 1`` of them.
    y : array_like, shape (n,) or (n, m) [unit of y]
        Ordinates.
    degree : int
        Degree of the polynomial.

    Returns
    -------
    ndarray, shape (degree + 1,) or (degree + 1, m) [unit of y / unit of x^k]
    """
    x = np.asarray(x, dtype=np.float64)
    return least_squares(np.vander(x, degree + 1), y, equilibrate=True)

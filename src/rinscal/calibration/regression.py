"""The one linear least-squares solve of the calibration code.

Every regression of :mod:`rinscal.calibration` ends here: the thermal models' blocked QR
(:func:`rinscal.calibration.thermal.fitting.solve_r` solves its small triangular system with
it), the field's cubics (PX4's and ArduPilot's ``np.polyfit``, :func:`polynomial_fit`), the
IMU's weighted regressions and laws (:mod:`rinscal.calibration.imu`), the temperature rate of
a ramp, the line under an edge step (:mod:`rinscal.calibration.evaluate`) and the Allan noise
fit (:mod:`rinscal.calibration.allan`).

It is LAPACK's SVD least squares (``gelsd``, what ``numpy.linalg.lstsq`` calls, with its
cut-off): minimum-norm where the design is rank-deficient, singular values below machine
precision × max(rows, columns) of the largest treated as zero. Callers that must refuse a
rank-deficient design check it themselves (:mod:`rinscal.calibration.thermal.guards`).
The routine is called through :mod:`scipy.linalg.lapack` on a column-major copy of the
design: the same numbers as ``numpy.linalg.lstsq`` (the same routine and cut-off), but
other threads run while it solves (``numpy.linalg`` holds the GIL: numpy issue 7179), which
matters where channels are fitted on threads (``fit --method auto`` solves the field's
cubics on hundreds of thousands of rows), and no second copy of a tall design is made.
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
        return _gelsd(np.array(a, order="F"), y)
    scale = np.sqrt((a * a).sum(axis=0))
    coef = _gelsd(np.divide(a, scale, out=np.empty(a.shape, order="F")), y)
    return np.asarray((coef.T / scale).T, dtype=np.float64)


def _gelsd(a: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """``numpy.linalg.lstsq(a, y, rcond=None)[0]``: LAPACK's ``gelsd`` with the same cut-off.

    ``a`` is a column-major design the solve may overwrite; ``y`` is 1-D or 2-D.
    """
    # deferred: scipy.linalg loads in ~0.1 s where nothing else needs it
    from scipy.linalg import lapack

    if a.ndim != 2 or y.ndim not in (1, 2) or y.shape[0] != a.shape[0]:
        raise np.linalg.LinAlgError(f"incompatible dimensions {a.shape} and {y.shape}")
    m, n = a.shape
    k = 1 if y.ndim == 1 else y.shape[1]
    if m == 0 or n == 0 or k == 0:  # numpy's answer; LAPACK refuses these
        return np.zeros((n, *y.shape[1:]))
    b = np.zeros((max(m, n), k), order="F")  # room for the solution when m < n
    b[:m] = y.reshape(m, k)
    cut = np.finfo(np.float64).eps * max(m, n)
    work, iwork, _ = lapack.dgelsd_lwork(m, n, k, cut)
    x, _, _, info = lapack.dgelsd(a, b, work, iwork, cut, overwrite_a=True, overwrite_b=True)
    if info > 0:
        raise np.linalg.LinAlgError("SVD did not converge in Linear Least Squares")
    return x[:n, 0] if y.ndim == 1 else x[:n]


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

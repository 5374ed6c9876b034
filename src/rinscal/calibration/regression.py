"""The one linear least-squares solve of the calibration code.

Every regression of :mod:`rinscal.calibration` ends here: the thermal models' blocked QR
(:func:`rinscal.calibration.thermal.fitting.solve_r` solves its small triangular system with
it), the field's cubics (PX4's and ArduPilot's ``np.polyfit``, :func:`polynomial_fit`), the
IMU's weighted regressions and laws (:mod:`rinscal.calibration.imu`), the temperature rate of
a ramp, the line under an edge step (:mod:`rinscal.calibration.evaluate`) and the Allan noise
fit (:mod:`rinscal.calibration.allan`).

It is LAPACK's SVD least squares (``gelsd``, as ``numpy.linalg.lstsq`` calls it, the same
numbers): minimum-norm where the design is rank-deficient, singular values below machine
precision × max(rows, columns) of the largest treated as zero. scipy's LAPACK is called
directly (:mod:`rinscal.calibration._lapack`, the GIL released: numpy's ``lstsq`` holds it,
so the channels' threads of ``auto`` took turns on the field's cubics). Callers that must
refuse a rank-deficient design check it themselves (:mod:`rinscal.calibration.thermal.guards`).

numpy only, but for :func:`polynomial_fit` of many samples in a process that has numba
loaded already: its design then comes from one compiled pass (:mod:`rinscal.calibration.
_vander`), the same numbers.
"""

from __future__ import annotations

import ctypes
import sys

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal.calibration._lapack import lapack_function

__all__ = ["least_squares", "polynomial_fit"]

#: Samples from which :func:`polynomial_fit` forms its design in one pass
#: (:mod:`rinscal.calibration._vander`) where the process has numba loaded.
_KERNEL_ROWS = 10_000


def _lstsq(a: np.ndarray, y: np.ndarray, overwrite: bool = False) -> np.ndarray:
    """``np.linalg.lstsq(a, y, rcond=None)[0]``: ``dgelsd`` with the workspace it asks for
    and numpy's cut-off (machine precision × max(rows, columns)). ``overwrite``: ``a`` may be
    destroyed where it is a column-major float64 array (no copy)."""
    m, n = a.shape
    nrhs = 1 if y.ndim == 1 else y.shape[1]
    if not (m and n and nrhs):
        return np.asarray(np.linalg.lstsq(a, y, rcond=None)[0], dtype=np.float64)
    if overwrite and a.dtype == np.float64 and a.flags.f_contiguous:
        af = a
    else:
        af = np.array(a, dtype=np.float64, order="F")
    b = np.zeros((max(m, n), nrhs), order="F")
    b[:m] = y.reshape(m, nrhs)
    sv = np.empty(min(m, n))
    rcond = ctypes.c_double(np.finfo(np.float64).eps * max(m, n))
    rank, info = ctypes.c_int(0), ctypes.c_int(0)
    dims = ctypes.c_int(m), ctypes.c_int(n), ctypes.c_int(nrhs), ctypes.c_int(max(m, n))

    def call(work: np.ndarray, iwork: np.ndarray, lwork: int) -> None:
        # dgelsd(m, n, nrhs, a, lda, b, ldb, s, rcond, rank, work, lwork, iwork, info)
        lapack_function("dgelsd", "iiipipipdipipi")(
            dims[0], dims[1], dims[2], af.ctypes.data, dims[0], b.ctypes.data, dims[3],
            sv.ctypes.data, rcond, rank, work.ctypes.data, ctypes.c_int(lwork),
            iwork.ctypes.data, info,
        )  # fmt: skip
        if info.value < 0:
            raise np.linalg.LinAlgError(f"dgelsd: argument {-info.value} is illegal")
        if info.value > 0:
            raise np.linalg.LinAlgError("SVD did not converge in Linear Least Squares")

    work, iwork = np.empty(1), np.zeros(1, dtype=np.intc)
    call(work, iwork, -1)  # the workspace LAPACK asks for
    lwork = max(1, int(work[0]))
    call(np.empty(lwork), np.empty(max(1, int(iwork[0])), dtype=np.intc), lwork)
    return b[:n, 0].copy() if y.ndim == 1 else np.array(b[:n])


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
        return _lstsq(a, y)
    scale = np.sqrt((a * a).sum(axis=0))
    # divided straight into the column-major copy LAPACK factors (and destroys)
    coef = _lstsq(np.divide(a, scale, out=np.empty(a.shape, order="F")), y, overwrite=True)
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
    if x.ndim == 1 and x.size >= _KERNEL_ROWS and "numba" in sys.modules:
        # deferred: the one-pass design where numba is loaded already (``auto``'s field
        # candidates); a process without it does not load it for this
        from rinscal.calibration._vander import equilibrated_vander

        a, scale = equilibrated_vander(x, degree)
        coef = _lstsq(a, np.asarray(y, dtype=np.float64), overwrite=True)
        return np.asarray((coef.T / scale).T, dtype=np.float64)
    return least_squares(np.vander(x, degree + 1), y, equilibrate=True)

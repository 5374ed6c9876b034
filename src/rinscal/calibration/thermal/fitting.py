"""Fitting of the polynomial thermal models: numpy only.

The numerics behind :mod:`rinscal.calibration.thermal.estimators` (whose scikit-learn classes
call these functions) and what :class:`rinscal.calibration.thermal.model.ThermalFitter` calls
directly, so that fitting ``poly-t``, ``sectional``, ``regression``, ``px4`` or ``ardupilot``
never imports scikit-learn (about 1 s of a command's start-up); only ``neural`` does.

Polynomial inputs are mapped onto ``[−1, 1]`` (centre and half-range, as
``astropy.modeling`` does), and the least-squares problem is solved by a blocked QR
factorisation of ``[A | y]`` (TSQR; never the normal equations), so memory stays bounded for
millions of samples. Feature matrices have columns ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C];
outputs are in the log's units.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from rinscal.calibration._lapack import lapack_function
from rinscal.calibration.regression import least_squares
from rinscal.calibration.thermal.guards import COND_ERROR, check_design, design_condition

__all__ = [
    "fit_poly_t",
    "fit_regression",
    "fit_sectional",
    "lstsq_qr",
    "one_blas_thread",
    "qr_r",
    "sectional_edges",
    "solve_r",
    "tsqr",
]

#: Rows a ``neural`` fit trains on at most by default (every k-th of the training blocks).
NEURAL_MAX_SAMPLES = 50_000

#: Rows of each block of a blocked QR: the block of ``[A | y]`` (1.5 MB at 12 columns)
#: stays in cache while it is expanded and factored.
_BLOCK = 1 << 14


class PowerBasis:
    """The basis ``[1, z_0 .. z_0^p, z_1 .. z_1^q, ...]`` with ``z_v = (x_v − c_v)/s_v``.

    ``basis(x)`` is the (rows, n_terms) column-major design of the inputs ``x`` (rows, k);
    ``basis(x, out)`` writes it into ``out`` (a column-major (rows, n_terms) array, e.g.
    the first columns of a block of ``[A | y]``: no copy).
    """

    def __init__(
        self, center: Sequence[float], scale: Sequence[float], orders: Sequence[int]
    ) -> None:
        self.center = [float(c) for c in center]
        self.scale = [float(v) for v in scale]
        self.orders = [int(o) for o in orders]
        self.n_terms = 1 + sum(self.orders)

    def __call__(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        a = np.empty((x.shape[0], self.n_terms), order="F") if out is None else out
        a[:, 0] = 1.0
        col = 1
        for v, order in enumerate(self.orders):
            if order == 0:
                continue
            z = a[:, col]  # column by column: contiguous
            np.subtract(x[:, v], self.center[v], out=z)
            z /= self.scale[v]
            for _ in range(1, order):
                np.multiply(a[:, col], z, out=a[:, col + 1])
                col += 1
            col += 1
        return a


def one_blas_thread() -> Any:
    """A context in which BLAS runs on one thread (``threadpoolctl``), for fitting.

    The factorisations here are of tall blocks a few columns wide, where BLAS threads only
    wait on each other: tens of times slower on a loaded or pinned machine. A fit's
    parallelism is its channels' threads (:mod:`rinscal.parallel`).
    """
    # deferred: threadpoolctl is needed only while fitting
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def qr_r(a: np.ndarray, overwrite: bool = False) -> np.ndarray:
    """Triangular factor of a QR factorisation: ``np.linalg.qr(a, mode="r")``, the same
    numbers (LAPACK's ``dgeqrf`` with the workspace it asks for, as numpy calls it).

    scipy's LAPACK, called directly (:mod:`rinscal.calibration._lapack`, the GIL
    released): numpy's bundled one took 2.3 times as long for the blocks of :func:`tsqr`
    (16 384 × 12: 1.6 ms against 0.7 ms, one thread), and numpy copies the matrix in and
    out around the call.

    Parameters
    ----------
    a : ndarray, shape (m, n)
        Matrix (float64).
    overwrite : bool
        Factor ``a`` in place where it is a column-major float64 array (its contents are
        then lost).

    Returns
    -------
    ndarray, shape (min(m, n), n)
    """
    m, n = a.shape
    if not overwrite or not (a.dtype == np.float64 and a.flags.f_contiguous):
        a = np.array(a, dtype=np.float64, order="F")
    if m == 0 or n == 0:
        return np.zeros((min(m, n), n))
    tau = np.empty(min(m, n))
    info = ctypes.c_int(0)
    rows, cols = ctypes.c_int(m), ctypes.c_int(n)

    def call(work: np.ndarray, lwork: int) -> None:
        # dgeqrf(m, n, a, lda, tau, work, lwork, info)
        lapack_function("dgeqrf", "iipippii")(
            rows, cols, a.ctypes.data, rows, tau.ctypes.data, work.ctypes.data,
            ctypes.c_int(lwork), info,
        )  # fmt: skip
        if info.value:
            raise np.linalg.LinAlgError(f"dgeqrf: argument {-info.value} is illegal")

    query = np.empty(1)
    call(query, -1)  # the workspace LAPACK asks for
    size = max(1, int(query[0]))
    call(np.empty(size), size)
    return np.triu(a[: min(m, n)])


def tsqr(
    basis: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    y: np.ndarray,
    n_terms: int,
    block: int = _BLOCK,
) -> np.ndarray:
    """Triangular factor ``R`` of ``[A | y]`` by blocked (TSQR) QR, ``A = basis(x)``.

    ``A`` is never formed whole: each block of rows of ``x`` is expanded by ``basis`` and
    reduced to its ``R`` factor, and the stacked factors are reduced again. ``RᵀR =
    [A | y]ᵀ[A | y]``, so ``R`` (or any subset of its columns, reduced again) carries
    everything a least-squares fit of ``y`` on columns of ``A`` needs.

    Parameters
    ----------
    basis : callable
        ``basis(x_block) -> ndarray, shape (rows, n_terms)``; a :class:`PowerBasis` writes
        each block into one buffer, reused.
    x : ndarray, shape (n, k)
        Inputs.
    y : ndarray, shape (n,)
        Targets.
    n_terms : int
        Columns of ``A``.
    block : int
        Rows per block.

    Returns
    -------
    ndarray, shape (min(n, n_terms + 1), n_terms + 1)
    """
    n = x.shape[0]
    rs = []
    # column-major, as LAPACK factors it: each column written and read contiguously; a
    # Householder QR of a tall block is memory-bound, so blocks that stay in cache are
    # several times faster than one long factorisation
    buf = np.empty((min(block, n), n_terms + 1), order="F")
    for s in range(0, n, block):
        m = min(block, n - s)
        aug = buf if m == buf.shape[0] else np.empty((m, n_terms + 1), order="F")
        if isinstance(basis, PowerBasis):
            basis(x[s : s + m], out=aug[:, :n_terms])
        else:
            aug[:, :n_terms] = basis(x[s : s + m])
        aug[:, n_terms] = y[s : s + m]
        rs.append(qr_r(aug, overwrite=True))  # the buffer is refilled: factored in place
    return rs[0] if len(rs) == 1 else qr_r(np.vstack(rs), overwrite=True)


def solve_r(r: np.ndarray, n_terms: int) -> tuple[np.ndarray, float]:
    """Least-squares solution and residual sum of squares from the ``R`` of ``[A | y]``.

    Parameters
    ----------
    r : ndarray, shape (k, n_terms + 1)
        Triangular factor (see :func:`tsqr`).
    n_terms : int
        Columns of ``A``.

    Returns
    -------
    beta : ndarray, shape (n_terms,)
        Solution (minimum-norm when rank deficient).
    rss : float
        Residual sum of squares.
    """
    k = min(n_terms, r.shape[0])
    rk = np.zeros((n_terms, n_terms))
    rk[:k] = r[:k, :n_terms]
    qty = np.zeros(n_terms)
    qty[:k] = r[:k, n_terms]
    beta = least_squares(rk, qty)
    rss = float(r[n_terms, n_terms] ** 2) if r.shape[0] > n_terms else 0.0
    return beta, rss


def lstsq_qr(
    basis: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    y: np.ndarray,
    n_terms: int,
    block: int = _BLOCK,
) -> tuple[np.ndarray, float]:
    """Least squares ``min ‖A β − y‖`` by blocked QR of ``[A | y]`` (never normal equations).

    :func:`tsqr` then :func:`solve_r`; the small triangular system is solved by
    :func:`rinscal.calibration.regression.least_squares` (minimum-norm when rank deficient).

    Parameters
    ----------
    basis : callable
        ``basis(x_block) -> ndarray, shape (rows, n_terms)``.
    x : ndarray, shape (n, k)
        Inputs.
    y : ndarray, shape (n,)
        Targets.
    n_terms : int
        Columns of ``A``.
    block : int
        Rows per block.

    Returns
    -------
    beta : ndarray, shape (n_terms,)
        Solution.
    rss : float
        Residual sum of squares.
    """
    return solve_r(tsqr(basis, x, y, n_terms, block), n_terms)


def _checked_lstsq(
    basis: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    y: np.ndarray,
    orders: Sequence[int],
    what: str,
    warn_collinear: bool = True,
) -> np.ndarray:
    """:func:`lstsq_qr` that refuses a rank-deficient design (:func:`check_design`)."""
    n_terms = 1 + int(sum(orders))
    r = tsqr(basis, x, y, n_terms)
    if x.shape[0] > n_terms:  # fewer rows are caught by the callers' own checks
        check_design(r[:, :n_terms], x, orders, what, warn_collinear)
    return solve_r(r, n_terms)[0]


def fit_factors(factors: Sequence[np.ndarray], sel: Sequence[int]) -> np.ndarray | None:
    """Least squares on stacked column subsets of triangular factors of ``[A | y]``.

    Parameters
    ----------
    factors : sequence of ndarray
        Factors ``R`` (:func:`tsqr`) of the row sets fitted together.
    sel : sequence of int
        Columns: those of ``A`` to fit on, then the ``y`` column last.

    Returns
    -------
    ndarray or None
        ``[β; −1]`` (so that ``R[:, sel] @ it`` is the residual's factor), or None when the
        design is rank-deficient (equilibrated condition above ``COND_ERROR``).
    """
    return _coef_from_r(np.linalg.qr(np.vstack([r[:, sel] for r in factors]), mode="r"))


def fit_factors_leaving_out(factors: Sequence[np.ndarray], sel: Sequence[int]) -> list:
    """:func:`fit_factors` without each factor in turn (the same numbers): item ``k`` fits
    every factor but ``factors[k]``. One batched QR instead of one QR per item."""
    n = len(factors)
    cols = [r[:, sel] for r in factors]
    stacks = np.stack([np.vstack([cols[j] for j in range(n) if j != k]) for k in range(n)])
    return [_coef_from_r(rt) for rt in np.linalg.qr(stacks, mode="r")]


def _coef_from_r(rt: np.ndarray) -> np.ndarray | None:
    """``[β; −1]`` from the factor of ``[A | y]``, or None when ``A`` is rank-deficient."""
    m = rt.shape[1] - 1
    if m > 1 and design_condition(rt[:, :m]) > COND_ERROR:
        return None
    return np.append(solve_r(rt, m)[0], -1.0)


def factor_ss_about_mean(r: np.ndarray, coef: np.ndarray, n: int) -> float:
    """Residual sum of squares about its mean, of rows whose ``[A | y]`` factor is ``r``.

    ``r`` holds the selected columns, the design's first column being ones, so its first
    row is the column sums over √n; ``coef`` is ``[β; −1]`` (:func:`fit_factors`), ``n``
    the number of rows.
    """
    total = float(np.sum((r @ coef) ** 2))
    mean = float(r[0] @ coef) * float(r[0, 0]) / max(n, 1)
    return max(total - n * mean**2, 0.0)


def center_scale(x: np.ndarray) -> tuple[float, float]:
    """Centre and half-range of ``x``, mapping it onto ``[−1, 1]`` (half-range 1 if 0)."""
    lo, hi = float(np.min(x)), float(np.max(x))
    c = 0.5 * (lo + hi)
    s = 0.5 * (hi - lo)
    if not s > 1e-12 * max(1.0, abs(c)):
        s = 1.0
    return c, s


def power_basis(
    center: Sequence[float], scale: Sequence[float], orders: Sequence[int]
) -> PowerBasis:
    """Basis ``[1, z_0 .. z_0^p, z_1 .. z_1^q, ...]`` with ``z_v = (x_v − c_v)/s_v``
    (:class:`PowerBasis`)."""
    return PowerBasis(center, scale, orders)


def _split_coef(beta: np.ndarray, orders: Sequence[int]) -> tuple[float, list[list[float]]]:
    coef, col = [], 1
    for order in orders:
        coef.append([float(c) for c in beta[col : col + order]])
        col += order
    return float(beta[0]), coef


def _fit_power(
    x: np.ndarray, y: np.ndarray, orders: Sequence[int], what: str = "regression"
) -> dict[str, Any]:
    """Fit ``intercept + Σ_v Σ_k coef[v][k] z_v^(k+1)``; return the regression parameters.

    Raises :class:`~rinscal.calibration.thermal.guards.DesignError` on a rank-deficient design.
    """
    cs = [center_scale(x[:, v]) for v in range(len(orders))]
    center = [c for c, _ in cs]
    scale = [s for _, s in cs]
    label = f"{what} {tuple(int(o) for o in orders)}"
    beta = _checked_lstsq(
        power_basis(center, scale, orders), x, y, orders, label, not what.startswith("sectional")
    )
    intercept, coef = _split_coef(beta, orders)
    return {
        "orders": [int(o) for o in orders],
        "center": center,
        "scale": scale,
        "intercept": intercept,
        "coef": coef,
    }


def fit_poly_t(
    X: np.ndarray, y: np.ndarray, degree: int = 3, t_ref: float | None = None
) -> dict[str, Any]:
    """``poly-t``: QR least squares on ``(T − t_ref)/s``, ``s`` the largest ``|T − t_ref|``.

    Parameters
    ----------
    X : ndarray, shape (n, k)
        Features; only ``T`` [°C] is used.
    y : ndarray, shape (n,)
        Raw output [log units].
    degree : int
        0..7.
    t_ref : float, optional [°C]
        Reference (default the middle of the range).

    Returns
    -------
    dict
        ``poly-t`` parameters (see :mod:`rinscal.calibration.inference`).
    """
    deg = int(degree)
    if deg < 0 or deg > 7:
        raise ValueError(f"degree must be 0..7, got {degree!r}")
    t = X[:, 0]
    ref = 0.5 * (t.min() + t.max()) if t_ref is None else float(t_ref)
    s = float(np.max(np.abs(t - ref)))
    s = s if s > 0 else 1.0
    beta = _checked_lstsq(power_basis([ref], [s], [deg]), X, y, [deg], f"degree-{deg} poly-t")
    coef = beta / s ** np.arange(deg + 1)
    return {"method": "poly-t", "t_ref": float(ref), "coef": coef.tolist()}


def fit_regression(
    X: np.ndarray, y: np.ndarray, t_order: int = 3, rate_order: int = 3, grad_order: int = 3
) -> dict[str, Any]:
    """``regression`` (method 2, Eq. 11): orders ``p, q, s`` in ``T, Ṫ, ΔT``, no cross terms.

    Parameters
    ----------
    X : ndarray, shape (n, k)
        ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C] (the first ``min(k, 3)`` are used).
    y : ndarray, shape (n,)
        Raw output [log units].
    t_order, rate_order, grad_order : int
        0..8.

    Returns
    -------
    dict
        ``regression`` parameters.
    """
    orders = [int(t_order), int(rate_order), int(grad_order)]
    if any(o < 0 or o > 8 for o in orders):
        raise ValueError(f"orders must be 0..8, got {orders}")
    orders = orders[: min(3, X.shape[1])]
    return {"method": "regression", **_fit_power(X, y, orders)}


def sectional_edges(
    t: np.ndarray,
    edges: Sequence[float] | None = None,
    set_points: Sequence[float] | None = None,
    n_segments: int = 7,
) -> np.ndarray:
    """Segment edges of a sectional model [°C]: given, set-point midpoints, or quantiles.

    Parameters
    ----------
    t : ndarray [°C]
        Training temperatures.
    edges : sequence of float, optional [°C]
        Given edges (each must lie inside the data's range).
    set_points : sequence of float, optional [°C]
        Chamber set points: edges at their midpoints.
    n_segments : int
        Otherwise: this many segments at quantiles of ``t``.

    Returns
    -------
    ndarray [°C]
        Strictly increasing edges.
    """
    if edges is not None:
        e = np.asarray(edges, dtype=np.float64).ravel()
        lo, hi = float(t.min()), float(t.max())
        outside = [float(v) for v in e if not lo < v < hi]
        if outside:
            raise ValueError(
                f"segment edge(s) {', '.join(f'{v:g}' for v in outside)} °C lie outside "
                f"the training temperatures ({lo:.4g} … {hi:.4g} °C): a segment there "
                "holds no data; give edges inside the data's range"
            )
    elif set_points is not None and len(set_points) >= 2:
        sp = np.unique(np.asarray(set_points, dtype=np.float64))
        e = 0.5 * (sp[1:] + sp[:-1])
    else:
        k = int(n_segments)
        if k < 1:
            raise ValueError(f"n_segments must be at least 1, got {n_segments!r}")
        q = np.unique(np.quantile(t, np.arange(1, k) / k, method="lower"))
        # keep only edges that leave a training sample in every segment
        kept: list[float] = []
        prev = -np.inf
        for edge in q[q < t.max()]:
            if np.any((t > prev) & (t <= edge)):
                kept.append(float(edge))
                prev = edge
        e = np.asarray(kept)
    if not np.all(np.isfinite(e)) or np.any(np.diff(e) <= 0):
        raise ValueError(f"segment edges must be finite and strictly increasing, got {e}")
    return e


def fit_sectional(
    X: np.ndarray, y: np.ndarray, edges: np.ndarray, t_order: int = 3, rate_order: int = 3
) -> dict[str, Any]:
    """``sectional`` (method 1, Eq. 15): one polynomial in ``T``, ``Ṫ`` per segment.

    Parameters
    ----------
    X : ndarray, shape (n, k), k ≥ 2
        ``T`` [°C] and ``Ṫ`` [°C/min].
    y : ndarray, shape (n,)
        Raw output [log units].
    edges : ndarray [°C]
        Segment edges (:func:`sectional_edges`).
    t_order, rate_order : int
        0..8.

    Returns
    -------
    dict
        ``sectional`` parameters.

    Raises
    ------
    ValueError
        If a segment holds no training sample.
    """
    orders = [int(t_order), int(rate_order)]
    if any(o < 0 or o > 8 for o in orders):
        raise ValueError(f"orders must be 0..8, got {orders}")
    edges = np.asarray(edges, dtype=np.float64)
    seg = np.searchsorted(edges, X[:, 0], side="left")
    centers, scales, intercepts, coefs = [], [], [], []
    bounds = [-np.inf, *edges.tolist(), np.inf]
    for k in range(edges.size + 1):
        sel = seg == k
        if not sel.any():
            raise ValueError(
                f"temperature segment {k + 1} ({bounds[k]} < T <= {bounds[k + 1]} °C) holds "
                "no training sample; give segment edges that the data cover"
            )
        p = _fit_power(X[sel][:, :2], y[sel], orders, f"sectional segment {k + 1}")
        centers.append(p["center"])
        scales.append(p["scale"])
        intercepts.append(p["intercept"])
        coefs.append(p["coef"])
    return {
        "method": "sectional",
        "orders": orders,
        "edges": edges.tolist(),
        "center": centers,
        "scale": scales,
        "intercept": intercepts,
        "coef": coefs,
    }


def rms_about_run_mean(resid: np.ndarray, codes: np.ndarray, n_runs: int = 0) -> float:
    """RMS of a residual about each run's own mean (Eq. 16: turn-on offsets removed).

    Parameters
    ----------
    resid : ndarray, shape (n,)
        Residual, in the channel's unit.
    codes : ndarray of int, shape (n,)
        Run code of each sample (0 .. n_runs − 1).
    n_runs : int
        Number of runs (codes may leave some out).

    Returns
    -------
    float
        ``sqrt(mean((r − mean_run(r))²))``, in the channel's unit.
    """
    sums = np.bincount(codes, weights=resid, minlength=n_runs)
    cnts = np.bincount(codes, minlength=n_runs)
    about = resid - (sums / np.maximum(cnts, 1))[codes]
    return float(np.sqrt(np.mean(about**2)))

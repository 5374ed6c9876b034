"""The four thermal models as scikit-learn estimators of one sensor channel.

Every estimator takes a feature matrix ``X`` whose columns are, in order, the inner
temperature ``T`` [°C], its rate ``Ṫ`` [°C/min] and the gradient ``ΔT`` [°C] (see
:mod:`rinscal.calibration.thermal.features`), and the raw output ``y`` of one channel in the log's
units. Columns after those a method uses are ignored, so one matrix serves every method.
``predict`` returns the modelled output ``f(T, Ṫ, ΔT)``; compensation is ``N' = N − f``
(Eq. 10). ``__init__`` only stores hyper-parameters; ``fit`` returns ``self``; fitted
attributes end in ``_``; ``params_`` holds the plain parameters that
:func:`rinscal.calibration.inference.predict_params` evaluates with numpy alone (and that
the model file stores), and ``predict`` calls exactly that function.

Methods
-------
:class:`PolyT` (``poly-t``)
    The field's baseline (PX4 ``process_sensor_caldata.py``, ArduPilot ``tempcal_IMU.py``):
    one polynomial in ``T`` alone, cubic by default, about a reference temperature.
:class:`Sectional` (``sectional``, method 1, Eq. 15, Table 4)
    One polynomial in ``T`` and ``Ṫ`` per temperature segment. Our reading of Table 4: an
    accelerometer segment has 7 coefficients, ``A0`` and ``T, T², T³`` (``A_T1..A_T3``) and
    ``Ṫ, Ṫ², Ṫ³`` (``A_T4..A_T6``), i.e. orders (3, 3); a gyro segment has 3, ``G0``, ``T``
    and ``Ṫ``, orders (1, 1). The magnitudes support it: ``A_T4..A_T6`` (tens to hundreds)
    match the rate coefficients of Table 6, not higher powers of ``T``.
:class:`Regression` (``regression``, method 2, Eqs. 10-11, Table 6)
    Polynomials of orders ``p, q, s`` in ``T, Ṫ, ΔT`` with one constant and no cross terms.
:class:`Neural` (``neural``, method 3, Eqs. 12-14, Tables 7-8)
    One hidden layer of ``n`` sigmoid neurons and a linear output.

Numerics: polynomial inputs are mapped onto ``[−1, 1]`` (centre and half-range, as
``astropy.modeling`` does), and the least-squares problem is solved by a blocked QR
factorisation of ``[A | y]`` (TSQR; never the normal equations), so memory stays bounded
for millions of samples. Coefficients are also reportable in the paper's raw form
(:meth:`Regression.raw_coefficients`).

Why one module: about 770 lines, one idea: the scikit-learn face of the paper's methods
(and of the field's two baselines), each class a thin estimator over the numpy fits; they
share one base and the conventions scikit-learn checks, so they stay together.
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils.validation import check_is_fitted, column_or_1d, validate_data
from threadpoolctl import threadpool_limits

from rinscal.calibration.inference import predict_params, raw_polynomial
from rinscal.calibration.thermal.baselines import ARDUPILOT_WINDOW_S, ardupilot_fit, px4_fit
from rinscal.calibration.thermal.fitting import (
    NEURAL_MAX_SAMPLES,
    fit_poly_t,
    fit_regression,
    fit_sectional,
    lstsq_qr,
    sectional_edges,
    solve_r,
    tsqr,
)

__all__ = [
    "ALL_ESTIMATORS",
    "BASELINES",
    "ESTIMATORS",
    "ArduPilotFit",
    "Neural",
    "PX4Fit",
    "PolyT",
    "Regression",
    "Sectional",
    "block_split",
    "lstsq_qr",
    "solve_r",
    "tsqr",
]


class _ThermalEstimator(RegressorMixin, BaseEstimator):
    """Common ``predict`` and export of the thermal estimators."""

    #: Method name in model files.
    method: str = ""
    _min_features = 1

    def _validate_fit(self, X: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
        X, y = validate_data(
            self, X, y, y_numeric=True, ensure_min_features=self._min_features, dtype=np.float64
        )
        return X, np.asarray(y, dtype=np.float64)

    def predict(self, X: Any) -> np.ndarray:
        """Modelled output ``f(T, Ṫ, ΔT)``.

        Parameters
        ----------
        X : array_like, shape (n, k)
            Features ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C].

        Returns
        -------
        ndarray, shape (n,) [output units]
        """
        check_is_fitted(self, "params_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return predict_params(self.params_, X)

    def export_params(self) -> dict[str, Any]:
        """Plain JSON-able parameters (see :mod:`rinscal.calibration.inference`)."""
        check_is_fitted(self, "params_")
        return copy.deepcopy(self.params_)


class PolyT(_ThermalEstimator):
    """Polynomial in the inner temperature alone: the PX4/ArduPilot baseline.

    ``f = Σ_{k=0..degree} coef_[k] (T − t_ref_)^k``.

    Parameters
    ----------
    degree : int
        Polynomial degree (3, as in PX4 and ArduPilot).
    t_ref : float, optional [°C]
        Reference temperature; None: the middle of the training range.

    Attributes
    ----------
    t_ref_ : float [°C]
        Reference temperature used.
    coef_ : ndarray, shape (degree + 1,) [output units / °C^k]
        Coefficients of ``(T − t_ref_)^k``.
    params_ : dict
        Plain parameters.
    """

    method = "poly-t"

    def __init__(self, degree: int = 3, t_ref: float | None = None) -> None:
        self.degree = degree
        self.t_ref = t_ref

    def fit(self, X: Any, y: Any) -> PolyT:
        """Fit by QR least squares on ``(T − t_ref)/s``, ``s`` the largest ``|T − t_ref|``.

        Parameters
        ----------
        X : array_like, shape (n, k)
            Features; only the first column ``T`` [°C] is used.
        y : array_like, shape (n,)
            Raw output.

        Returns
        -------
        PolyT
        """
        X, y = self._validate_fit(X, y)
        self.params_ = fit_poly_t(X, y, self.degree, self.t_ref)
        self.t_ref_ = float(self.params_["t_ref"])
        self.coef_ = np.asarray(self.params_["coef"])
        return self

    def raw_coefficients(self) -> np.ndarray:
        """Coefficients of ``T^0 .. T^degree`` (not about ``t_ref_``)."""
        check_is_fitted(self, "params_")
        return np.asarray(raw_polynomial(self.params_)["coef"])


class Regression(_ThermalEstimator):
    """Multiple regression, Eqs. 10-11: polynomials in ``T``, ``Ṫ`` and ``ΔT``.

    ``f = a0 + Σ_{k=1..p} a_Tk T^k + Σ_{k=1..q} a_Ṫk Ṫ^k + Σ_{k=1..s} a_ΔTk ΔT^k``, fitted
    on inputs mapped onto ``[−1, 1]``. With two feature columns (no outer temperature)
    the ``ΔT`` terms drop out; with one, only ``T`` remains.

    Parameters
    ----------
    t_order, rate_order, grad_order : int
        ``p``, ``q``, ``s`` (paper: 3, 3, 3 for accelerometers and 1, 1, 1 for gyros).

    Attributes
    ----------
    orders_ : tuple of int
        Orders used, one per input column used.
    intercept_ : float
        Constant of the centred form.
    params_ : dict
        Plain parameters (centred, scaled form).
    """

    method = "regression"

    def __init__(self, t_order: int = 3, rate_order: int = 3, grad_order: int = 3) -> None:
        self.t_order = t_order
        self.rate_order = rate_order
        self.grad_order = grad_order

    def fit(self, X: Any, y: Any) -> Regression:
        """Fit by blocked QR least squares.

        Parameters
        ----------
        X : array_like, shape (n, k)
            ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C] (the first ``min(k, 3)`` are used).
        y : array_like, shape (n,)
            Raw output.

        Returns
        -------
        Regression
        """
        X, y = self._validate_fit(X, y)
        self.params_ = fit_regression(X, y, self.t_order, self.rate_order, self.grad_order)
        self.orders_ = tuple(self.params_["orders"])
        self.intercept_ = self.params_["intercept"]
        return self

    def raw_coefficients(self) -> dict[str, Any]:
        """The paper's Table 6 form: ``{"a0": a0, "coef": [[a_T1..a_Tp], [a_Ṫ1..], [a_ΔT1..]]}``."""
        check_is_fitted(self, "params_")
        return raw_polynomial(self.params_)


class Sectional(_ThermalEstimator):
    """Sectional model, method 1 (Eq. 15, Table 4): a polynomial in ``T`` and ``Ṫ`` per segment.

    Segment ``k`` holds ``edges[k−1] < T ≤ edges[k]`` (the first ``T ≤ edges[0]``, the last
    ``T > edges[-1]``), as in Eq. 15.

    Parameters
    ----------
    edges : sequence of float, optional [°C]
        Segment edges, strictly increasing.
    set_points : sequence of float, optional [°C]
        Soak set points; when ``edges`` is None the edges are the midpoints between
        consecutive set points (Table 3 → 3.5, 10.5, ..., 38.5 °C).
    n_segments : int
        When neither is given: this many segments holding equal numbers of training samples.
    t_order, rate_order : int
        Orders in ``T`` and ``Ṫ`` (3, 3 for accelerometers: 7 coefficients per segment; 1, 1
        for gyros: 3 coefficients).

    Attributes
    ----------
    edges_ : ndarray [°C]
        Edges used.
    params_ : dict
        Plain parameters.
    """

    method = "sectional"
    _min_features = 2

    def __init__(
        self,
        edges: Sequence[float] | None = None,
        set_points: Sequence[float] | None = None,
        n_segments: int = 7,
        t_order: int = 3,
        rate_order: int = 3,
    ) -> None:
        self.edges = edges
        self.set_points = set_points
        self.n_segments = n_segments
        self.t_order = t_order
        self.rate_order = rate_order

    def _edges(self, t: np.ndarray) -> np.ndarray:
        return sectional_edges(t, self.edges, self.set_points, self.n_segments)

    def fit(self, X: Any, y: Any) -> Sectional:
        """Fit one polynomial per segment by QR least squares.

        Parameters
        ----------
        X : array_like, shape (n, k), k ≥ 2
            ``T`` [°C] and ``Ṫ`` [°C/min] (further columns ignored).
        y : array_like, shape (n,)
            Raw output.

        Returns
        -------
        Sectional

        Raises
        ------
        ValueError
            If a segment holds no training sample.
        """
        X, y = self._validate_fit(X, y)
        self.params_ = fit_sectional(
            X, y, self._edges(X[:, 0]), int(self.t_order), int(self.rate_order)
        )
        self.edges_ = np.asarray(self.params_["edges"])
        return self

    def raw_coefficients(self) -> dict[str, Any]:
        """Table 4 form: per segment ``{"a0": A0, "coef": [[A_T1..], [A_Ṫ1..]]}``."""
        check_is_fitted(self, "params_")
        return raw_polynomial(self.params_)


def block_split(
    n: int,
    groups: np.ndarray | None,
    fraction: float = 0.3,
    n_blocks: int = 10,
) -> np.ndarray:
    """Validation mask by contiguous blocks of each run, never by random rows.

    Each run's rows (in order) are cut into ``n_blocks`` contiguous blocks; the blocks at
    evenly spread positions ``⌊(i + ½)·n_blocks/n_val⌋``, ``n_val = round(fraction ·
    n_blocks)``, go to validation (e.g. blocks 1, 5 and 8 of 10 for 30 %).

    Parameters
    ----------
    n : int
        Number of rows.
    groups : ndarray, shape (n,), optional
        Run label of each row; None: one run.
    fraction : float
        Validation share.
    n_blocks : int
        Blocks per run.

    Returns
    -------
    ndarray of bool, shape (n,)
        True for validation rows.
    """
    val = np.zeros(n, dtype=bool)
    n_val = round(fraction * n_blocks)
    if n_val <= 0:
        return val
    pick = {int((i + 0.5) * n_blocks / n_val) for i in range(n_val)}
    if groups is None:
        runs = [np.arange(n)]
    else:
        g = np.asarray(groups)
        _, inv = np.unique(g, return_inverse=True)
        order = np.argsort(inv, kind="stable")
        bounds = np.searchsorted(inv[order], np.arange(inv.max() + 2))
        runs = [order[bounds[k] : bounds[k + 1]] for k in range(inv.max() + 1)]
    for rows in runs:
        for b, part in enumerate(np.array_split(rows, n_blocks)):
            if b in pick:
                val[part] = True
    return val


class Neural(_ThermalEstimator):
    """BP network, method 3 (Eqs. 12-14): one sigmoid hidden layer, linear output.

    Inputs are standardised, the output too; weights are trained by L-BFGS
    (:class:`sklearn.neural_network.MLPRegressor`, ``activation="logistic"``). The data are
    split 70/30 by contiguous blocks of each run (:func:`block_split`; ``groups`` gives the
    runs); the network is trained on the 70 %, ``n_init`` times from seeds
    ``random_state, random_state + 1, ...``, and the start with the lowest RMS on the 30 %
    is kept. Deterministic for a given ``random_state``. Inference is plain numpy.

    Parameters
    ----------
    hidden : int
        Hidden neurons ``n`` (6 for accelerometers, 2 for gyros in the paper).
    alpha : float
        L2 penalty on the weights (on standardised data).
    max_iter : int
        L-BFGS iterations per start.
    tol : float
        L-BFGS tolerance.
    n_init : int
        Random starts.
    validation_fraction : float
        Share of each run's blocks held out (0.3).
    n_blocks : int
        Contiguous blocks per run.
    max_samples : int or None
        Training on more rows than this uses every ``k``-th row of the training blocks
        (``k = ⌈n/max_samples⌉``), in order; thermal features are smooth, so little is lost.
        The validation rows are decimated the same way.
    refine : bool
        Polish each start by Levenberg-Marquardt (``scipy.optimize.least_squares``, analytic
        Jacobian; MATLAB's ``trainlm`` is the classic BP trainer) on the same objective
        (half mean squared error plus ``alpha/2 · ‖weights‖² / n``). L-BFGS in
        ``MLPRegressor`` stops on a relative loss change of about 2e-9; the polish takes the
        fit to the solver's precision.
    refine_max_nfev : int
        Most function evaluations of the polish.
    random_state : int
        Seed of the first start.

    Attributes
    ----------
    params_ : dict
        Plain parameters.
    train_rms_, validation_rms_ : float [output units]
        RMS of the residual on the training and validation rows.
    n_iter_ : int
        L-BFGS iterations of the start kept plus function evaluations of its polish.
    converged_ : bool
        Whether L-BFGS or the polish stopped before its iteration limit.
    """

    method = "neural"

    def __init__(
        self,
        hidden: int = 6,
        alpha: float = 1e-6,
        max_iter: int = 1000,
        tol: float = 1e-10,
        n_init: int = 3,
        validation_fraction: float = 0.3,
        n_blocks: int = 10,
        max_samples: int | None = NEURAL_MAX_SAMPLES,
        refine: bool = True,
        refine_max_nfev: int = 200,
        random_state: int = 0,
    ) -> None:
        self.hidden = hidden
        self.alpha = alpha
        self.max_iter = max_iter
        self.tol = tol
        self.n_init = n_init
        self.validation_fraction = validation_fraction
        self.n_blocks = n_blocks
        self.max_samples = max_samples
        self.refine = refine
        self.refine_max_nfev = refine_max_nfev
        self.random_state = random_state

    def fit(self, X: Any, y: Any, groups: Any = None) -> Neural:
        """Train on 70 % of each run (contiguous blocks), select the start on the other 30 %.

        Parameters
        ----------
        X : array_like, shape (n, k)
            ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C] (the first ``min(k, 3)`` are used).
        y : array_like, shape (n,)
            Raw output.
        groups : array_like, shape (n,), optional
            Run of each row.

        Returns
        -------
        Neural
        """
        X, y = self._validate_fit(X, y)
        # the matrices are tiny (rows x a few neurons): one BLAS thread is fastest, and
        # threads spinning on a busy machine made training 25 times slower
        with threadpool_limits(limits=1, user_api="blas"):
            return self._fit(X, y, groups)

    def _fit(self, X: np.ndarray, y: np.ndarray, groups: Any) -> Neural:
        # deferred: sklearn.neural_network adds ~50 ms to this module's import; only a
        # network fit needs it
        from sklearn.neural_network import MLPRegressor

        n_hidden = int(self.hidden)
        if n_hidden < 1:
            raise ValueError(f"hidden must be at least 1, got {self.hidden!r}")
        d = min(3, X.shape[1])
        X = X[:, :d]
        g = None if groups is None else np.asarray(groups)
        if g is not None and g.shape[0] != X.shape[0]:
            raise ValueError(f"groups has {g.shape[0]} rows, X has {X.shape[0]}")
        val = block_split(X.shape[0], g, self.validation_fraction, int(self.n_blocks))
        tr = np.flatnonzero(~val)
        va = np.flatnonzero(val)
        if tr.size == 0:
            tr, va = va, tr
        if self.max_samples is not None:
            ms = int(self.max_samples)
            if tr.size > ms:
                tr = tr[:: -(-tr.size // ms)]
            if va.size > ms:
                va = va[:: -(-va.size // ms)]
        xm = X[tr].mean(axis=0)
        xs = X[tr].std(axis=0)
        xs = np.where(xs > 1e-12 * np.maximum(1.0, np.abs(xm)), xs, 1.0)
        ym = float(y[tr].mean())
        ys = float(y[tr].std())
        ys = ys if ys > 1e-12 * max(1.0, abs(ym)) else 1.0
        ztr = (X[tr] - xm) / xs
        ytr = (y[tr] - ym) / ys
        best: tuple[float, Any] | None = None
        for i in range(max(1, int(self.n_init))):
            net = MLPRegressor(
                hidden_layer_sizes=(n_hidden,),
                activation="logistic",
                solver="lbfgs",
                alpha=float(self.alpha),
                max_iter=int(self.max_iter),
                max_fun=max(15000, 2 * int(self.max_iter)),
                tol=float(self.tol),
                random_state=int(self.random_state) + i,
            )
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                net.fit(ztr, ytr)
            theta = _pack(
                net.coefs_[0].T, net.intercepts_[0], net.coefs_[1][:, 0], net.intercepts_[1][0]
            )
            params = _params(theta, n_hidden, d, xm, xs, ym, ys)
            rows = va if va.size else tr
            resid = predict_params(params, X[rows]) - y[rows]
            score = float(np.sqrt(np.mean(resid**2)))
            if best is None or score < best[0]:
                best = (score, theta, int(net.n_iter_))
        assert best is not None
        theta, n_iter = best[1], best[2]
        self.converged_ = n_iter < int(self.max_iter)
        if self.refine:
            theta, nfev = _levenberg_marquardt(
                theta, ztr, ytr, n_hidden, float(self.alpha), int(self.refine_max_nfev)
            )
            n_iter += nfev
            self.converged_ = self.converged_ or nfev < int(self.refine_max_nfev)
        self.params_ = _params(theta, n_hidden, d, xm, xs, ym, ys)
        self.n_iter_ = n_iter
        self.train_rms_ = float(
            np.sqrt(np.mean((predict_params(self.params_, X[tr]) - y[tr]) ** 2))
        )
        self.validation_rms_ = (
            float(np.sqrt(np.mean((predict_params(self.params_, X[va]) - y[va]) ** 2)))
            if va.size
            else float("nan")
        )
        return self


def _pack(w: np.ndarray, b: np.ndarray, v: np.ndarray, b_out: float) -> np.ndarray:
    return np.concatenate([np.asarray(w).ravel(), b, v, [b_out]])


def _unpack(theta: np.ndarray, n: int, d: int) -> tuple[np.ndarray, ...]:
    w = theta[: n * d].reshape(n, d)
    b = theta[n * d : n * d + n]
    v = theta[n * d + n : n * d + 2 * n]
    return w, b, v, theta[-1]


def _params(
    theta: np.ndarray, n: int, d: int, xm: np.ndarray, xs: np.ndarray, ym: float, ys: float
) -> dict[str, Any]:
    w, b, v, b_out = _unpack(theta, n, d)
    return {
        "method": "neural",
        "x_mean": [float(c) for c in xm],
        "x_scale": [float(c) for c in xs],
        "W": w.tolist(),
        "b": b.tolist(),
        "v": v.tolist(),
        "b_out": float(b_out),
        "y_mean": float(ym),
        "y_scale": float(ys),
    }


def _levenberg_marquardt(
    theta: np.ndarray, z: np.ndarray, y: np.ndarray, n: int, alpha: float, max_nfev: int
) -> tuple[np.ndarray, int]:
    """Minimise ``½ Σ (f(z_i) − y_i)² + ½ α ‖W, v‖²`` from ``theta`` (standardised data)."""
    d = z.shape[1]
    m = z.shape[0]
    n_w = n * d + n  # W and v carry the penalty, as in MLPRegressor (not the biases)
    sq = np.sqrt(alpha) if alpha > 0 else 0.0

    def hidden(th: np.ndarray) -> tuple[np.ndarray, ...]:
        w, b, v, b_out = _unpack(th, n, d)
        h = 1.0 / (1.0 + np.exp(-np.clip(z @ w.T + b, -500.0, 500.0)))
        return w, b, v, b_out, h

    def fun(th: np.ndarray) -> np.ndarray:
        w, _, v, b_out, h = hidden(th)
        r = h @ v + b_out - y
        if sq:
            return np.concatenate([r, sq * w.ravel(), sq * v])
        return r

    def jac(th: np.ndarray) -> np.ndarray:
        _, _, v, _, h = hidden(th)
        g = h * (1.0 - h) * v  # (m, n): ∂f/∂b_j
        rows = m + (n_w if sq else 0)
        jm = np.zeros((rows, th.size))
        jm[:m, : n * d] = (g[:, :, None] * z[:, None, :]).reshape(m, n * d)
        jm[:m, n * d : n * d + n] = g
        jm[:m, n * d + n : n * d + 2 * n] = h
        jm[:m, -1] = 1.0
        if sq:
            idx = np.arange(n * d)
            jm[m + idx, idx] = sq
            idx_v = np.arange(n)
            jm[m + n * d + idx_v, n * d + n + idx_v] = sq
        return jm

    method = "lm" if fun(theta).size >= theta.size else "trf"
    res = least_squares(
        fun,
        theta,
        jac=jac,
        method=method,
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
        max_nfev=max_nfev,
    )
    # keep the polish only if it did not make things worse
    if np.sum(res.fun**2) <= np.sum(fun(theta) ** 2):
        return res.x, int(res.nfev)
    return theta, int(res.nfev)


#: Estimator class of each method name.
ESTIMATORS: dict[str, type[_ThermalEstimator]] = {
    "poly-t": PolyT,
    "sectional": Sectional,
    "regression": Regression,
    "neural": Neural,
}


# ----------------------------------------------------------------- the field's own fits


def _fit_inputs(est: _ThermalEstimator, X: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
    """``X`` validated (finite, sets ``n_features_in_``); ``y`` 1-D float, NaN allowed."""
    if y is None:
        raise ValueError(f"{type(est).__name__} requires y to be passed, but the target y is None")
    X = validate_data(est, X, dtype=np.float64, ensure_min_features=1, ensure_min_samples=2)
    y = column_or_1d(np.asarray(y, dtype=np.float64), warn=True)
    if y.shape != (X.shape[0],):
        raise ValueError(f"y must have {X.shape[0]} entries, got shape {y.shape}")
    return X, y


class PX4Fit(_ThermalEstimator):
    """PX4's thermal fit (``Tools/process_sensor_caldata.py``) as an estimator.

    31-sample running median per run, accelerometers minus their median, 2000 equal
    temperature bins, ``np.polyfit`` cubic about the middle of the temperature range; see
    :func:`px4_fit` and the module docstring.
    ``f = Σ_k coef_[k] (clip(T, t_min_, t_max_) − t_ref_)^k``.

    Parameters
    ----------
    sensor : {"gyro", "accel"}
        Sensor type of the channel.
    resample : bool
        Fit the bin means (default, as the script) or every sample (``--no_resample``).

    Attributes
    ----------
    t_ref_, t_min_, t_max_ : float [°C]
        ``TC_*_TREF``, ``TC_*_TMIN``, ``TC_*_TMAX``.
    coef_ : ndarray, shape (4,) [output units / °C^k]
        ``TC_*_X0 .. X3``.
    params_ : dict
        Plain ``px4`` parameters.
    """

    method = "px4"

    def __init__(self, sensor: str = "gyro", resample: bool = True) -> None:
        self.sensor = sensor
        self.resample = resample

    def fit(self, X: Any, y: Any, groups: Any = None, t: Any = None) -> PX4Fit:
        """Fit one channel.

        Parameters
        ----------
        X : array_like, shape (n, k)
            Features; only the first column ``T`` [°C] is used.
        y : array_like, shape (n,) [output units]
            Raw output; NaN rows are dropped before filtering.
        groups : array_like, shape (n,), optional
            Run code of each row (runs contiguous, rows in time order); None: one run.
        t : array_like, shape (n,), optional [s]
            Time since power-on; not used by PX4 (accepted for a uniform call).

        Returns
        -------
        PX4Fit
        """
        X, y = _fit_inputs(self, X, y)
        p = px4_fit(X[:, 0], y, groups, sensor=self.sensor, resample=bool(self.resample))
        self.t_ref_, self.t_min_, self.t_max_ = p["t_ref"], p["t_min"], p["t_max"]
        self.coef_ = np.asarray(p["coef"])
        self.params_ = p
        return self


class ArduPilotFit(_ThermalEstimator):
    """ArduPilot's thermal fit (``Tools/scripts/tempcal_IMU.py``) as an estimator.

    2 s moving average per run, ``np.polyfit`` cubic in ``T − 35 °C`` whose constant
    ArduPilot drops, range clamped to the smoothed temperatures as the firmware does; see
    :func:`ardupilot_fit` and the module docstring.
    ``f = Σ_k coef_[k] (clip(T, t_min_, t_max_) − 35)^k``, ``coef_[0]`` the training level.

    Parameters
    ----------
    sensor : {"gyro", "accel"}
        Sensor type of the channel (changes only the dropped constant of the fit).
    window_s : int
        Moving-average width [s] (2, as the script).
    sample_s : float, optional
        Sample interval [s] of evenly sampled runs: with it, ``fit`` without ``t`` takes
        each run's time as its row number × ``sample_s`` (the scikit-learn call
        ``fit(X, y)``); without it ``t`` is required.

    Attributes
    ----------
    t_ref_ : float [°C]
        35.
    t_min_, t_max_ : float [°C]
        ``INS_TCALn_TMIN``, ``INS_TCALn_TMAX``.
    coef_ : ndarray, shape (4,) [output units / °C^k]
        Training level, then ``INS_TCALn_*1..3`` × 1e-6.
    params_ : dict
        Plain ``ardupilot`` parameters.
    """

    method = "ardupilot"

    def __init__(
        self,
        sensor: str = "gyro",
        window_s: int = ARDUPILOT_WINDOW_S,
        sample_s: float | None = None,
    ) -> None:
        self.sensor = sensor
        self.window_s = window_s
        self.sample_s = sample_s

    def fit(self, X: Any, y: Any, groups: Any = None, t: Any = None) -> ArduPilotFit:
        """Fit one channel.

        Parameters
        ----------
        X : array_like, shape (n, k)
            Features; only the first column ``T`` [°C] is used.
        y : array_like, shape (n,) [output units]
            Raw output; NaN rows are dropped before smoothing.
        groups : array_like, shape (n,), optional
            Run code of each row (runs contiguous, rows in time order); None: one run.
        t : array_like, shape (n,) [s]
            Time since each run's power-on (sets the 2 s window); required unless
            ``sample_s`` is set.

        Returns
        -------
        ArduPilotFit

        Raises
        ------
        ValueError
            If ``t`` is None and ``sample_s`` is not set, among others.
        """
        if t is None and self.sample_s is None:
            raise ValueError(
                "ArduPilotFit.fit needs t, the time [s] since each run's power-on: "
                "ArduPilot smooths over 2 s before fitting (or sample_s, for evenly sampled runs)"
            )
        X, y = _fit_inputs(self, X, y)
        if t is None:
            t = _even_time(len(y), groups, float(self.sample_s))  # type: ignore[arg-type]
        p = ardupilot_fit(X[:, 0], y, t, groups, sensor=self.sensor, window_s=self.window_s)
        self.t_ref_, self.t_min_, self.t_max_ = p["t_ref"], p["t_min"], p["t_max"]
        self.coef_ = np.asarray(p["coef"])
        self.params_ = p
        return self


def _even_time(n: int, groups: Any, sample_s: float) -> np.ndarray:
    """Time since each run's start [s] of ``n`` evenly sampled rows, ``sample_s`` [s] apart;
    runs are the contiguous stretches of equal ``groups`` (None: one run)."""
    idx = np.arange(n)
    if groups is None:
        return idx * sample_s
    codes = np.asarray(groups)
    starts = np.r_[0, np.flatnonzero(codes[1:] != codes[:-1]) + 1]
    return (idx - starts[np.searchsorted(starts, idx, side="right") - 1]) * sample_s


#: Estimator class of each of the field's methods.
BASELINES: dict[str, type[_ThermalEstimator]] = {"px4": PX4Fit, "ardupilot": ArduPilotFit}

#: Estimator class of every method (the paper's, the baseline, the field's own fits).
ALL_ESTIMATORS: dict[str, type[_ThermalEstimator]] = {**ESTIMATORS, **BASELINES}

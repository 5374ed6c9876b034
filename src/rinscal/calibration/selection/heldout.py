"""Choosing the polynomial orders or the hidden-layer size on runs the model never saw.

Tables 5 and 7 of the paper give the calibration RMS on the training data only, which can
only fall as the model grows. Here, per channel and setting (orders ``p = q = s = k`` for
``regression``, ``k = 1..4``; ``n = 1..8`` hidden neurons for ``neural``), we report

* ``rms_train``: RMS (Eq. 16) of the residual of a fit on all runs, over those runs, and
* ``rms_heldout``: leave-one-run-out: for each run, fit on the others, predict it; the RMS
  over all the held-out predictions.

Both are taken **about each run's mean residual** (a turn-on offset per power-on is not
thermal and not predictable), over inlier samples. The recommended setting is the smallest
whose held-out RMS is within ``tolerance`` (2 % by default) of the best held-out RMS: the
rule of :mod:`rinscal.calibration.selection.rule`, where the defaults are explained.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from rinscal import _check
from rinscal.calibration.modelfile import FittedModel
from rinscal.calibration.selection.rule import (
    DEFAULT_TOLERANCES,
    SETTINGS_TOLERANCE,
    simplest_within,
)
from rinscal.calibration.thermal.features import (
    DerivativeConfig,
    Features,
    OutlierConfig,
    build_features,
)
from rinscal.calibration.thermal.fitting import (
    factor_ss_about_mean,
    fit_factors,
    rms_about_run_mean,
)
from rinscal.calibration.thermal.model import ThermalFitter
from rinscal.calibration.thermal.runs import RunFits
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS

__all__ = [
    "DEFAULT_SETTINGS",
    "AutoSelectionResult",
    "SelectionResult",
    "select_model",
    "select_regression_runs",
]

#: Settings tried by default: orders 1-4 (regression), 1-8 neurons (neural).
DEFAULT_SETTINGS: dict[str, tuple[int, ...]] = {
    "regression": (1, 2, 3, 4),
    "neural": (1, 2, 3, 4, 5, 6, 7, 8),
}


@dataclass(frozen=True)
class SelectionResult:
    """Outcome of a model selection.

    Attributes
    ----------
    method : str
        ``regression`` or ``neural``.
    table : DataFrame
        ``channel, setting, rms_train, rms_heldout`` (log units), one row per channel and
        setting.
    recommended : dict of str to int
        Smallest setting within the tolerance of the best held-out RMS, per channel.
    best : dict of str to int
        Setting with the lowest held-out RMS, per channel.
    tolerance : float [dimensionless]
        Tolerance used: relative excess of the held-out RMS over the best's
        (:mod:`rinscal.calibration.selection.rule`).
    runs : tuple of str
        Runs (each held out once).
    """

    method: str
    table: pd.DataFrame
    recommended: dict[str, int]
    best: dict[str, int]
    tolerance: float
    runs: tuple[str, ...]
    units: dict[str, str | None] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        return {
            "method": self.method,
            "setting": "orders p=q=s" if self.method == "regression" else "hidden neurons",
            "rms": "Eq. 16 about each run's mean residual, log units",
            "tolerance": self.tolerance,
            "runs": list(self.runs),
            "units": self.units,
            "recommended": self.recommended,
            "best": self.best,
            "table": self.table.to_dict(orient="records"),
        }


#: What the RMS figures of an ``auto`` selection are (the ``rms`` entry of its JSON form).
AUTO_RMS_NOTE = (
    "heldout_rms, fold_rms and train_rms: RMS of 60 s means of the residual "
    "about each scored part's mean, log units; held-out: the part's fold left out of "
    "the fit; train: the fit on all the data, over the same rows; null: not fitted"
)


@dataclass(frozen=True)
class AutoSelectionResult:
    """Outcome of ``select(log, "auto")``: every candidate's held-out RMS, per channel.

    Attributes
    ----------
    model : FittedModel
        Each channel's chosen model, fitted on all the data (what ``fit --method auto``
        writes).
    channels : dict of str to dict
        Per channel: ``unit`` (the log's unit of the channel, or None) and the selection
        entry of the model file (``scheme``, ``folds``, ``tolerance`` [dimensionless],
        ``chosen``, ``fallback`` and ``table``: per candidate ``heldout_rms``, ``fold_rms``
        and ``train_rms`` in the channel's unit, :data:`AUTO_RMS_NOTE`).
    tolerance : float [dimensionless]
        Relative excess of the held-out RMS over the best's within which a simpler model
        is taken, on top of the paired test (:mod:`rinscal.calibration.selection.rule`).
    """

    model: FittedModel
    channels: dict[str, dict[str, Any]]
    tolerance: float

    @property
    def chosen(self) -> dict[str, str]:
        """The chosen candidate's name, per channel."""
        return {c: str(v["chosen"]) for c, v in self.channels.items()}

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (``rinscal select --json`` prints it, after the log's name)."""
        return {"rms": AUTO_RMS_NOTE, "channels": self.channels}


def _select_auto(
    log: pd.DataFrame,
    meta: Mapping[str, Any] | None,
    tolerance: float,
    channels: Sequence[str],
    derivative: DerivativeConfig,
    outliers: OutlierConfig,
    use_gradient: bool | None,
    random_state: int,
    candidates: Sequence[str] | None,
    source: str | None,
) -> AutoSelectionResult:
    """Every candidate of ``fit --method auto`` scored on held-out folds, the choice made."""
    fitter = ThermalFitter(
        "auto",
        channels=channels,
        derivative=derivative,
        outliers=outliers,
        use_gradient=use_gradient,
        random_state=random_state,
        tolerance=tolerance,
        **({"candidates": tuple(candidates)} if candidates is not None else {}),
    )
    mf = fitter.fit(log, meta, source=source).to_file()
    table = {c: {"unit": mf.models[c].unit, **(mf.models[c].selection or {})} for c in mf.channels}
    return AutoSelectionResult(mf, table, float(tolerance))


def _fit_predict(
    est: Any,
    method: str,
    channel: str,
    x: np.ndarray,
    y: np.ndarray,
    codes: np.ndarray,
    train: np.ndarray,
    test: np.ndarray,
) -> np.ndarray:
    """Fit ``est`` on the ``train`` rows, return its residual on the ``test`` rows."""
    try:
        if method == "neural":
            est.fit(x[train], y[train], groups=codes[train])
        else:
            est.fit(x[train], y[train])
    except ValueError as exc:
        raise ConfigError(f"{channel}: {method} fit failed: {exc}") from None
    return est.predict(x[test]) - y[test]


def _regression_scores(
    channel: str, fits: RunFits, settings: Sequence[int]
) -> list[tuple[float, float]]:
    """Training and leave-one-run-out RMS of ``regression`` orders ``k = k = k``, from factors.

    ``fits`` holds each run's triangular factor ``R_k`` of ``[A | y]`` for the largest orders
    (:class:`~rinscal.calibration.thermal.runs.RunFits`), taken here into the scaling of all
    runs. A fit of any orders on any runs is then a QR of the stacked column subsets of their
    factors, and a run's residual sum of squares about its own mean follows from its factor:
    ``‖R_k [β; −1]‖² − n_k m_k²``, ``m_k`` from the first row of ``R_k`` (the design's first
    column is ones). Equal to refitting from the data (the power basis spans the same
    polynomials whatever its centring and scaling), without touching the data again.
    """
    d, kmax = len(fits.powers), max(settings)
    n_terms = 1 + d * kmax
    factors = fits.global_factors(fits.powers, fits.scaling())
    present = list(range(len(factors)))

    def fit(sel: list[int], runs: list[int], order: int) -> np.ndarray:
        coef = fit_factors([factors[j] for j in runs], sel)
        if coef is None:
            raise ConfigError(
                f"{channel}: regression fit failed: orders {order},{order},{order} leave the "
                "design rank-deficient on these runs (too few distinct temperatures or rates)"
            )
        return coef

    def ss_about_mean(k: int, sel: list[int], beta: np.ndarray) -> float:
        return factor_ss_about_mean(factors[k][:, sel], beta, int(fits.counts[k]))

    n = fits.n
    out = []
    for order in settings:
        sel = [0, *(1 + v * kmax + i for v in range(d) for i in range(order)), n_terms]
        beta = fit(sel, present, order)
        ss_tr = sum(ss_about_mean(k, sel, beta) for k in present)
        ss_ho = 0.0
        for k in present:
            others = [j for j in present if j != k]
            if not others:
                raise ConfigError(f"{channel}: too few samples outside run {k}")
            ss_ho += ss_about_mean(k, sel, fit(sel, others, order))
        out.append((float(np.sqrt(ss_tr / n)), float(np.sqrt(ss_ho / n))))
    return out


def _add_runs(fits: RunFits, feats: Features, j: int, code0: int) -> None:
    """Each run's usable rows of channel ``j`` of ``feats`` into ``fits`` (codes from code0)."""
    x = feats.matrix(j)
    ok = feats.usable(j, x)
    for k in range(len(feats.runs)):
        rows = ok & (feats.run_codes == k)
        if rows.any():
            fits.add(code0 + k, x[rows], feats.output[rows, j], feats.time_s[rows])


def _settings(method: str, settings: Sequence[int] | None, tolerance: float) -> tuple[int, ...]:
    if method not in DEFAULT_SETTINGS:
        raise ConfigError(f"selection supports auto, regression and neural, not {method!r}")
    out = tuple(int(s) for s in (settings or DEFAULT_SETTINGS[method]))
    if not out or any(s < 1 for s in out):
        raise ConfigError(f"settings must be positive integers, got {out}")
    if not (np.isfinite(tolerance) and tolerance >= 0):
        raise ConfigError(f"tolerance must be >= 0, got {tolerance!r}")
    return out


def _two_runs(runs: Sequence[str]) -> None:
    if len(runs) < 2:
        raise ConfigError(
            f"leave-one-run-out needs at least 2 runs; the log has {len(runs)} ({tuple(runs)})"
        )


def _result(
    method: str,
    settings: Sequence[int],
    tolerance: float,
    runs: Sequence[str],
    scores: Mapping[str, list[tuple[float, float]]],
) -> SelectionResult:
    """The table and the recommended (smallest within tolerance) and best settings."""
    rows, recommended, best = [], {}, {}
    for c, sc in scores.items():
        for s, (rms_tr, rms_ho) in zip(settings, sc, strict=True):
            rows.append({"channel": c, "setting": s, "rms_train": rms_tr, "rms_heldout": rms_ho})
        h = np.asarray([ho for _, ho in sc])
        best[c] = settings[int(np.argmin(h))]
        recommended[c] = settings[simplest_within(h, tolerance, settings)]
    return SelectionResult(
        method=method,
        table=pd.DataFrame(rows, columns=["channel", "setting", "rms_train", "rms_heldout"]),
        recommended=recommended,
        best=best,
        tolerance=float(tolerance),
        runs=tuple(runs),
    )


def select_regression_runs(
    runs: Iterable[pd.DataFrame],
    settings: Sequence[int] | None = None,
    tolerance: float = SETTINGS_TOLERANCE,
    channels: Sequence[str] = CHANNELS,
    derivative: DerivativeConfig | None = None,
    outliers: OutlierConfig | None = None,
    use_gradient: bool | None = None,
    on_fit: Callable[[str, int], None] | None = None,
) -> SelectionResult:
    """:func:`select_model` of ``regression`` for a log given a run at a time.

    Each run's features are built a channel at a time and reduced at once to the run's
    factors (:class:`~rinscal.calibration.thermal.runs.RunFits`); nothing else of the run is kept.
    The result equals :func:`select_model`'s on the whole log.

    Parameters
    ----------
    runs : iterable of DataFrame
        The log's runs, each whole and validated (e.g. from
        :func:`rinscal.io.streaming.iter_log_source`).
    settings, tolerance, channels, derivative, outliers, use_gradient, on_fit
        As for :func:`select_model`.
    """
    settings = _settings("regression", settings, tolerance)
    derivative = derivative or DerivativeConfig()
    outliers = outliers or OutlierConfig()
    fits: dict[str, RunFits] = {}
    names: list[str] = []
    for log in runs:
        added: tuple[str, ...] = ()
        for c in channels:  # a channel at a time: memory of one channel's features
            feats = build_features(log, derivative, outliers, (c,), use_gradient=use_gradient)
            acc = fits.setdefault(
                c, RunFits("regression", [max(settings)] * feats.n_features, keep_rows=False)
            )
            _add_runs(acc, feats, 0, len(names))
            added = feats.runs
        names.extend(added)
    _two_runs(names)
    return _result("regression", settings, tolerance, names, _scores(fits, settings, on_fit))


def _scores(
    fits: Mapping[str, RunFits],
    settings: Sequence[int],
    on_fit: Callable[[str, int], None] | None,
) -> dict[str, list[tuple[float, float]]]:
    out = {}
    for c, f in fits.items():
        out[c] = _regression_scores(c, f, settings)
        for s in settings if on_fit is not None else ():
            on_fit(c, s)  # type: ignore[misc]
    return out


def _fit_counter(
    on_fit: Callable[[str, int], None] | None,
    progress: Callable[[float, float], None] | None,
    total: int,
) -> Callable[[str, int], None] | None:
    """One ``on_fit(channel, setting)`` hook that also reports ``progress(done, total)``
    [fits]; ``None`` when neither is given."""
    if on_fit is None and progress is None:
        return None
    done = 0

    def step(channel: str, setting: int) -> None:
        nonlocal done
        done += 1
        if on_fit is not None:
            on_fit(channel, setting)
        if progress is not None:
            progress(float(done), float(total))

    return step


def select_model(
    log: pd.DataFrame,
    method: str,
    settings: Sequence[int] | None = None,
    tolerance: float | None = None,
    channels: Sequence[str] = CHANNELS,
    derivative: DerivativeConfig | None = None,
    outliers: OutlierConfig | None = None,
    use_gradient: bool | None = None,
    random_state: int | None = None,
    estimator_params: Mapping[str, Any] | None = None,
    features: Features | None = None,
    on_fit: Callable[[str, int], None] | None = None,
    *,
    meta: Mapping[str, Any] | None = None,
    candidates: Sequence[str] | None = None,
    source: str | None = None,
    seed: int | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> SelectionResult | AutoSelectionResult:
    """Held-out RMS per channel: of every ``auto`` candidate, or per setting (Tables 5, 7).

    ``auto`` is ``rinscal select --method auto`` (its default): every candidate of
    ``fit --method auto`` scored on held-out folds and each channel's choice made, as the
    command prints it. ``regression`` and ``neural``: training and leave-one-run-out RMS per
    channel and setting, and the recommended setting.

    Parameters
    ----------
    log : DataFrame
        Validated calibration log (at least two runs for ``regression`` and ``neural``).
    method : {"auto", "regression", "neural"}
        What to select.
    settings : sequence of int, optional
        ``regression``/``neural``: orders ``k`` (``p = q = s = k``) or neuron counts to try.
    tolerance : float, optional [dimensionless]
        Relative excess over the best held-out RMS within which the simpler model or the
        smaller setting is taken (:mod:`rinscal.calibration.selection.rule`). Default by
        method (:data:`~rinscal.calibration.selection.rule.DEFAULT_TOLERANCES`): 0 for
        ``auto`` (on top of its paired test), 0.02 for ``regression`` and ``neural``.
    channels : sequence of str
        Channels.
    derivative, outliers, use_gradient, estimator_params
        As for :class:`~rinscal.calibration.thermal.model.ThermalFitter`
        (``estimator_params``: not for ``auto``).
    random_state : int, optional
        Old name of ``seed`` (kept for one release, with a ``DeprecationWarning``).
    features : Features, optional
        ``regression``/``neural``: precomputed features of ``log``.
    on_fit : callable, optional
        Deprecated (the next release removes it; use ``progress``): called
        ``on_fit(channel, setting)`` after each setting of each channel.
    meta : mapping, optional
        ``auto``: the log's metadata (units, static reference), as for :func:`rinscal.fit`.
    candidates : sequence of str, optional
        ``auto``: the candidate families (default all but ``neural``).
    source : str, optional
        ``auto``: the log's name, recorded in the fitted model.
    seed : int
        Seed of the estimators' random starts (``neural``); default 0.
    progress : callable, optional
        ``regression``/``neural``: ``progress(done, total)`` [fits] after each setting of
        each channel.

    Returns
    -------
    SelectionResult or AutoSelectionResult
        ``AutoSelectionResult`` for ``auto``.
    """
    if features is None:
        log = _check.log_table("log", log)
    _check.text("method", method)
    _check.numbers_of("settings", settings, optional=True, nonempty=False, integer=True)
    _check.number("tolerance", tolerance, min=0.0, optional=True)
    random_state = _check.renamed("seed", seed, "random_state", random_state, default=0)
    _check.number("seed", random_state, min=0, integer=True)
    _check.strings("channels", channels)
    _check.mapping("estimator_params", estimator_params, optional=True)
    _check.flag("use_gradient", use_gradient, optional=True)
    _check.callback("on_fit", _check.deprecated("on_fit", on_fit, "progress="))
    _check.callback("progress", progress)
    _check.mapping("meta", meta, optional=True)
    _check.strings("candidates", candidates, optional=True)
    if tolerance is None:
        tolerance = DEFAULT_TOLERANCES.get(method, SETTINGS_TOLERANCE)
    derivative = derivative or DerivativeConfig()
    outliers = outliers or OutlierConfig()
    if method == "auto":
        given = {"settings": settings, "estimator_params": estimator_params, "features": features}
        extra = [k for k, v in given.items() if v is not None]
        if extra:
            raise ConfigError(
                f"{', '.join(extra)} apply to method regression or neural; auto tries every "
                "candidate family: choose them with candidates"
            )
        return _select_auto(
            log, meta, tolerance, channels, derivative, outliers, use_gradient,
            random_state, candidates, source,
        )  # fmt: skip
    if candidates is not None:
        raise ConfigError("candidates apply to method auto only")
    settings = _settings(method, settings, tolerance)
    on_fit = _fit_counter(on_fit, progress, len(channels) * len(settings))
    feats = features or build_features(
        log, derivative, outliers, channels, use_gradient=use_gradient
    )
    n_runs = len(feats.runs)
    _two_runs(feats.runs)
    if method == "regression" and not estimator_params:  # one pass: per-run factors
        fits = {}
        for c in channels:
            j = feats.channels.index(c)
            fits[c] = RunFits("regression", [max(settings)] * feats.n_features, keep_rows=False)
            _add_runs(fits[c], feats, j, 0)
        return _result(method, settings, tolerance, feats.runs, _scores(fits, settings, on_fit))
    scores: dict[str, list[tuple[float, float]]] = {}
    for c in channels:
        j = feats.channels.index(c)
        x = feats.matrix(j)
        ok = feats.usable(j, x)
        y = feats.output[:, j]
        codes = feats.run_codes
        scores[c] = []
        for s in settings:
            tm = ThermalFitter(
                method,
                orders=(s, s, s) if method == "regression" else None,
                hidden=s if method == "neural" else None,
                channels=(c,),
                derivative=derivative,
                outliers=outliers,
                random_state=random_state,
                estimator_params=estimator_params,
            )
            data = (x, y, codes)
            rms_tr = rms_about_run_mean(
                _fit_predict(tm.estimator_for(c), method, c, *data, ok, ok), codes[ok], n_runs
            )
            resid = np.empty(int(ok.sum()))
            pos = np.flatnonzero(ok)
            for k in range(n_runs):
                test = ok & (codes == k)
                if not test.any():
                    continue
                train = ok & (codes != k)
                if train.sum() < 2:
                    raise ConfigError(f"{c}: too few samples outside run {feats.runs[k]!r}")
                resid[np.searchsorted(pos, np.flatnonzero(test))] = _fit_predict(
                    tm.estimator_for(c), method, c, *data, train, test
                )
            scores[c].append((rms_tr, rms_about_run_mean(resid, codes[ok], n_runs)))
            if on_fit is not None:
                on_fit(c, s)
    return _result(method, settings, tolerance, feats.runs, scores)

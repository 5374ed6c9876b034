"""``fit --method auto``: each channel's model chosen by held-out error.

Per channel, every candidate is fitted on all folds but one and scored on the fold left out;
the score is the RMS of the held-out residual averaged over 60 s blocks (:data:`BLOCK_S`: the
slow part a thermal model is for; white noise averages out), about each fold's own mean (a
turn-on offset is not thermal), pooled over the folds. The training RMS of the table is the
same figure for the fit on every fold, over the same rows and blocks, so the two compare.
Among the candidates within noise of the best (those a one-sided paired t-test on the folds'
log error ratios cannot tell from it, :func:`choose`) the choice is no compensation, else the
field's own cubic (ArduPilot's, then PX4's), else the fewest thermal parameters: within
noise, the simpler wins. "No compensation" is a candidate, so on the held-out data the
choice is never clearly worse than doing nothing.

Why one module: about 700 lines, one idea: the held-out choice of one channel's model, its
folds' rows taken once for every candidate (the field's tools and the polynomials scored on
the same rows, so that their scores compare), the table and the rule that reads it; split,
the shared rows and their thinning would have to cross module boundaries as private state.

Folds (:func:`rinscal.calibration.selection.folds.holdout_folds`)
    Leave-one-run-out when the log has three runs or more. Otherwise each run is cut into its
    heating and cooling legs (turning points of the temperature, with a hysteresis of
    max(1 °C, 10 % of the run's span)) and each leg is left out in turn; its contiguous blocks
    (at least :data:`~rinscal.calibration.selection.folds.MIN_FOLDS` in all) are scored
    apart, so that the held-out error has a spread (a standard error needs several values)
    while a leg, a thermal regime of its own, is never half in the training data. A single
    leg is cut into blocks left out one by one.
    Never random rows: neighbouring samples of a slow thermal signal are not independent.

Candidates (:func:`rinscal.calibration.selection.candidates.candidates`)
    ``none`` (a constant: no thermal compensation), ``ardupilot`` and ``px4`` (the field's
    own fits, :mod:`rinscal.calibration.thermal.baselines`; on held-out folds each tool's
    filter runs once per run and its fit on at most :data:`SCREEN_ROWS` filtered samples;
    the chosen one is refitted on every filtered sample kept: all of them up to
    :data:`SCREEN_SAMPLES` rows), ``poly-t`` of degree 1-4, ``regression`` with ``p`` = 1..4,
    ``q`` = 0..3, ``s`` = 0..3 (``s`` only with ``ΔT``; ``q = s = 0`` is ``poly-t``), and on request
    ``neural`` with 2, 4 and 6 hidden neurons (screened with
    ``max_samples`` 5000 and one start, refitted with the defaults if chosen; not in the
    default set: its held-out fits cost minutes on a 7-run log).

Above :data:`SCREEN_SAMPLES` inlier samples the held-out scores use every k-th sample (a
chosen polynomial model is fitted on all of them).

``fit`` reads a log a run at a time and never holds it whole
(:class:`rinscal.calibration.thermal.runs.RowSample`, :func:`select_thinned`): of each channel it
keeps every k-th usable row of the log, ``k`` the smallest power of two that keeps at most
:data:`SCREEN_SAMPLES` (the rows of :func:`select_channel` when its ``k`` is a power of two,
as on the 7.56 M-sample soak log: ``k`` = 8), each with the value of PX4's median and
ArduPilot's moving average at that row (computed on the whole run), and of each run its
legs' temperature ranges (:class:`rinscal.calibration.selection.folds.RunSpan`). The
polynomial candidates are then refitted on every row from per-run QR factors, the field's
fits on the kept filtered rows. Memory is bounded by one run and the kept rows, not by the log.

The polynomial candidates share one pass over the held-out data: per fold the triangular
factor of
the largest design (:func:`rinscal.calibration.thermal.estimators.tsqr`); any candidate on any
training folds is then a QR of the stacked column subsets, and its held-out residual sum of
squares and mean follow from the held-out fold's factor (``‖R_k [β; −1]‖²``; the first row
of ``R_k`` holds the column sums, since the design's first column is ones). A candidate
whose training design is rank-deficient on some fold, or whose inputs are collinear on the
whole log (:func:`rinscal.calibration.thermal.guards.collinear_inputs`), scores ``None`` and is not
chosen.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from rinscal.calibration.inference import predict_params
from rinscal.calibration.selection.candidates import (
    MAX_ORDERS,
    Candidate,
    fit_candidate,
)
from rinscal.calibration.selection.folds import Folds, RunSpan, fold_plan, holdout_plan
from rinscal.calibration.selection.rule import AUTO_TOLERANCE, within_tolerance
from rinscal.calibration.thermal.baselines import (
    ardupilot_fit_smoothed,
    ardupilot_smoothed,
    px4_filtered,
    px4_fit_filtered,
)
from rinscal.calibration.thermal.fitting import (
    center_scale,
    factor_ss_about_mean,
    fit_factors_leaving_out,
    power_basis,
    solve_r,
    tsqr,
)
from rinscal.calibration.thermal.guards import (
    DesignError,
    collinear_inputs,
)

__all__ = [
    "BLOCK_S",
    "CONFIDENCE",
    "DEFAULT_TOLERANCE",
    "SCREEN_ROWS",
    "SCREEN_SAMPLES",
    "Selection",
    "choose",
    "select_channel",
    "select_thinned",
]

#: Default tolerance of the choice [dimensionless]: relative excess of the held-out RMS over
#: the best's, on top of the paired test (:func:`choose`;
#: :mod:`rinscal.calibration.selection.rule`).
DEFAULT_TOLERANCE = AUTO_TOLERANCE
#: One-sided confidence of the paired test by which a candidate is worse than the best
#: (:func:`choose`).
CONFIDENCE = 0.9
#: Filtered samples (every k-th) the PX4 and ArduPilot fits of a held-out fold use at most
#: (a cubic in T: thousands of smooth samples a degree). 200 000 until issue 39: the same
#: choices, chosen and fallback, on the simulated soaks and the real log compared in
#: docs/calibration.md ("The field's held-out fits"), at a sixth of the cost.
SCREEN_ROWS = 25_000
#: Averaging block of the held-out residual [s]: the score is the RMS of 60 s means of the
#: residual, the part of the error a thermal model is for; white noise averages out
#: (by √(rate × 60 s)) and no longer hides thermal differences at high sample rates.
BLOCK_S = 60.0
#: Samples (every k-th) the held-out scores of a channel use at most; the chosen model is
#: fitted on all of them. At 100 Hz over 7 × 3 h this keeps one sample in eight (12.5 Hz),
#: far above the bandwidth of a thermal drift.
SCREEN_SAMPLES = 1_000_000


def _baseline_screens(
    temp: np.ndarray,
    y: np.ndarray,
    run_codes: np.ndarray,
    t: np.ndarray,
    folds: np.ndarray,
    cands: Sequence[Candidate],
) -> Callable[[str, int | None], dict[str, Any]]:
    """Held-out fits of the PX4 and ArduPilot candidates, each tool's filter run once.

    Each tool's filter (PX4's 31-sample median, ArduPilot's 2 s moving average) runs once
    per run over the whole log; the rest of its fit (range, median, bins, cubic) is redone
    on the training folds' filtered samples, every k-th of them so that at most
    :data:`SCREEN_ROWS` are used (the fits average thousands of smooth samples per degree).
    A filter window that straddles a fold boundary sees a few seconds of the held-out fold.
    Returns ``fit(method, k)``: the parameters with fold ``k`` held out, or with ``k`` None
    the tool's own fit on every row (equal to :func:`rinscal.calibration.thermal.baselines.px4_fit`
    and ``ardupilot_fit`` on the same data, the filter not run again).
    """
    methods = _tool_methods(cands)
    pre: dict[str, tuple[np.ndarray, ...]] = {}
    if "px4" in methods:
        pre["px4"] = (*px4_filtered(temp, y, run_codes), folds)
    if "ardupilot" in methods:
        t_s, y_s, t_kept, y_kept, rows = ardupilot_smoothed(temp, y, t, run_codes)
        pre["ardupilot"] = (t_s, y_s, folds[rows], t_kept, y_kept)
    return _tool_fits(pre, methods)


def _tool_methods(cands: Sequence[Candidate]) -> dict[str, Candidate]:
    """The candidates that are the field's fits, by method."""
    return {c.method: c for c in cands if c.method in ("px4", "ardupilot")}


def _tool_fits(
    pre: dict[str, tuple[np.ndarray, ...]], methods: dict[str, Candidate]
) -> Callable[[str, int | None], dict[str, Any]]:
    """``fit(method, k)`` of :func:`_baseline_screens` from the tools' filtered samples.

    ``pre["px4"]``: temperatures, median-filtered outputs and their folds;
    ``pre["ardupilot"]``: smoothed temperatures and outputs, their folds, and the raw
    temperatures and outputs for the constant term.
    """

    def thin(codes: np.ndarray, k: int) -> np.ndarray:
        """Every step-th row, those of fold ``k`` left out: at most about SCREEN_ROWS."""
        n_train = codes.size - int(np.count_nonzero(codes == k))
        rows = np.arange(0, codes.size, max(1, math.ceil(n_train / SCREEN_ROWS)))
        return rows[codes[rows] != k]

    def fit(method: str, k: int | None) -> dict[str, Any]:
        """The held-out fit without fold ``k``; ``k`` None: the tool's exact fit on all rows."""
        sensor = methods[method].params.get("sensor", "gyro")
        if method == "px4":
            tf, yf, codes = pre["px4"]
            if k is None:
                return px4_fit_filtered(tf, yf, sensor=sensor)
            i = thin(codes, k)
            return px4_fit_filtered(tf[i], yf[i], sensor=sensor)
        t_s, y_s, f_s, t_kept, y_kept = pre["ardupilot"]
        if k is None:
            return ardupilot_fit_smoothed(t_s, y_s, t_kept, y_kept, sensor=sensor)
        i = thin(f_s, k)
        # the constant term (from the raw rows) does not change a held-out RMS about the mean
        return ardupilot_fit_smoothed(t_s[i], y_s[i], t_s[i[:1]], y_s[i[:1]], sensor=sensor)

    return fit


def _averaging_blocks(
    folds: np.ndarray, run_codes: np.ndarray, t: np.ndarray, scored: np.ndarray
) -> np.ndarray:
    """Number the scored rows' averaging blocks (:data:`BLOCK_S` of one run and fold); −1 else."""
    out = np.full(folds.size, -1, dtype=np.int64)
    idx = np.flatnonzero(scored)
    if not idx.size:
        return out
    # a new block where the fold, the run or the BLOCK_S interval changes
    change = np.zeros(idx.size, dtype=np.int64)
    for key in (folds[idx], run_codes[idx], np.floor(t[idx] / BLOCK_S)):
        change[1:] |= key[1:] != key[:-1]
    out[idx] = np.cumsum(change)
    return out


def _block_means(resid: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Means of a residual over its blocks (``ids`` increasing)."""
    if not resid.size:
        return resid
    ids = ids - ids[0]
    cnt = np.bincount(ids)
    return np.bincount(ids, weights=resid)[cnt > 0] / cnt[cnt > 0]


def _ss_about_mean(resid: np.ndarray) -> float:
    return float(np.sum((resid - resid.mean()) ** 2)) if resid.size else 0.0


def _polynomial_scores(
    x: np.ndarray,
    y: np.ndarray,
    folds: np.ndarray,
    n_folds: int,
    cands: Sequence[Candidate],
    blocks: np.ndarray,
    units: np.ndarray | None = None,
    unit_fold: np.ndarray | None = None,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Held-out and training SS of block means about the unit's mean, per scoring unit.

    ``blocks`` numbers the scored rows' averaging blocks (−1: not scored); ``units`` and
    ``unit_fold`` (default: the folds themselves) are the scoring units and their folds. The
    held-out SS of a unit is that of the fit without its fold, the training SS that of the
    fit on every fold, over the same scored rows and blocks.
    """
    if units is None or unit_fold is None:
        units, unit_fold = folds, np.arange(n_folds)
    n_units = int(unit_fold.size)
    d = x.shape[1]
    max_orders = list(MAX_ORDERS[:d])
    cs = [center_scale(x[:, v]) for v in range(d)]
    basis = power_basis([c for c, _ in cs], [s for _, s in cs], max_orders)
    n_terms = 1 + sum(max_orders)

    def factor(sel: np.ndarray) -> np.ndarray:
        pad = np.zeros((n_terms + 1, n_terms + 1))
        idx = np.flatnonzero(sel)
        if idx.size:
            # a fold's rows are one block where it is a run left out (views, no copies)
            one = idx[-1] - idx[0] + 1 == idx.size
            rows = slice(int(idx[0]), int(idx[-1]) + 1) if one else idx
            r = tsqr(basis, x[rows], y[rows], n_terms)
            pad[: r.shape[0]] = r
        return pad

    def block_factor(sel: np.ndarray) -> tuple[np.ndarray, int]:
        """``R`` of the block means of ``[A | y]`` over the selected rows, and the blocks."""
        idx = np.flatnonzero(sel)
        pad = np.zeros((n_terms + 1, n_terms + 1))
        if not idx.size:
            return pad, 0
        ids = blocks[idx] - blocks[idx[0]]  # increasing along the rows
        nb = int(ids[-1]) + 1
        sums = np.zeros((nb, n_terms + 1))
        for s in range(0, idx.size, 1 << 16):
            rows = idx[s : s + (1 << 16)]
            a = basis(x[rows])
            for j in range(n_terms):
                sums[:, j] += np.bincount(ids[s : s + (1 << 16)], weights=a[:, j], minlength=nb)
            sums[:, n_terms] += np.bincount(ids[s : s + (1 << 16)], weights=y[rows], minlength=nb)
        cnt = np.bincount(ids, minlength=nb)
        means = sums[cnt > 0] / cnt[cnt > 0, None]
        r = np.linalg.qr(means, mode="r")
        pad[: r.shape[0]] = r
        return pad, int(means.shape[0])

    rs = [factor(folds == k) for k in range(n_folds)]
    rs_scored, counts = [], []
    for u in range(n_units):
        r, nb = block_factor((units == u) & (blocks >= 0))
        rs_scored.append(r)
        counts.append(nb)
    start = np.cumsum([1, *max_orders[:-1]])
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    # a candidate is refused when two of its inputs are collinear: each pair checked once
    used = {c.name: [v for v, o in enumerate(c.orders[:d]) if o > 0] for c in cands if c.orders}
    pairs = {p for u in used.values() for p in itertools.combinations(u, 2)}
    collinear = {p: bool(collinear_inputs(x, [int(v in p) for v in range(d)])) for p in pairs}
    for cand in cands:
        assert cand.orders is not None
        if any(collinear[p] for p in itertools.combinations(used[cand.name], 2)):
            out[cand.name] = (np.full(n_units, np.nan), np.full(n_units, np.nan))
            continue
        cols = [0]
        for v, o in enumerate(cand.orders[:d]):
            cols.extend(range(int(start[v]), int(start[v]) + o))
        sel = [*cols, n_terms]
        m = len(cols)
        ss = np.empty(n_units)
        betas = fit_factors_leaving_out(rs, sel)
        for k in range(n_folds):
            beta = betas[k]
            mine = np.flatnonzero(unit_fold == k)
            if beta is None:
                ss[mine] = np.nan
                continue
            for u in mine:
                ss[u] = factor_ss_about_mean(rs_scored[u][:, sel], beta, int(counts[u]))
        full = np.linalg.qr(np.vstack([r[:, sel] for r in rs]), mode="r")
        coef = np.append(solve_r(full, m)[0], -1.0)
        train = np.array(
            [
                factor_ss_about_mean(rs_scored[u][:, sel], coef, int(counts[u]))
                for u in range(n_units)
            ]
        )
        out[cand.name] = (ss, train)
    return out


@dataclass(frozen=True)
class Selection:
    """The held-out choice of one channel.

    Attributes
    ----------
    chosen : Candidate
        The model to fit on all the data.
    fallback : Candidate
        The T-only candidate used outside the joint domain (policy ``fallback``).
    folds : Folds
        The folds.
    tolerance : float [dimensionless]
        Tolerance of the choice: relative excess of the held-out RMS over the best's
        (:mod:`rinscal.calibration.selection.rule`; files written before it hold a relative
        excess of the mean square error, 0 by default in both).
    table : list of dict
        One row per candidate: ``name``, ``method``, ``n_params``, ``heldout_rms`` (None if
        the candidate could not be fitted on some fold), ``fold_rms`` (per scoring unit;
        None where it was not fitted or nothing of the unit was scored), and ``train_rms``
        (the fit on all the data; None for a network, not refitted while screening), in
        the log's units. Both RMS are of the same figure (:data:`BLOCK_S`): 60 s means of
        the residual about each scoring unit's mean, over the scored rows, pooled; held-out
        with the unit's fold left out of the fit, training with every fold in it.
    fitted : dict of str to dict
        Parameters on all the data of the candidates that the selection could fit without
        another pass (the field's fits, their filters already run: every one that scored);
        :func:`fit_candidate` for the others.
    """

    chosen: Candidate
    fallback: Candidate
    folds: Folds
    tolerance: float
    table: list[dict[str, Any]]
    fitted: dict[str, dict[str, Any]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (the model file's ``selection`` entry)."""
        return {
            "scheme": self.folds.scheme,
            "folds": list(self.folds.unit_names),
            "tolerance": float(self.tolerance),
            "chosen": self.chosen.name,
            "fallback": self.fallback.name,
            "table": self.table,
        }


def choose(
    cands: Sequence[Candidate],
    fold_mse: np.ndarray,
    tolerance: float = DEFAULT_TOLERANCE,
    confidence: float = CONFIDENCE,
) -> Candidate:
    """The preferred candidate among those held-out error cannot tell from the best.

    Parameters
    ----------
    cands : sequence of Candidate
        In preference order.
    fold_mse : ndarray, shape (len(cands), units)
        Held-out mean square error of each scoring unit; NaN where a candidate could not be
        fitted (it is then never chosen).
    tolerance : float [dimensionless]
        Relative excess of a candidate's held-out RMS (the root of its mean MSE over the
        units) over the best's that still counts as near
        (:func:`rinscal.calibration.selection.rule.within_tolerance`).
    confidence : float
        One-sided confidence of the paired test (see below).

    Returns
    -------
    Candidate
        Let ``b`` be the candidate of the lowest mean held-out MSE. Candidate ``i`` is within
        noise of it unless a one-sided paired t-test on the units' log ratios
        ``ln(MSE_i / MSE_b)`` says it is worse at ``confidence``: mean over standard error
        above the Student t quantile of ``units − 1`` degrees of freedom (1.44 for 7 runs at
        90 %). Paired, because every candidate is scored on the same units, and a hot run's
        error is larger for all of them; on log ratios, because units' errors differ by orders
        of magnitude and a model removes a share of each. Also within noise: a root mean
        square at most ``tolerance`` times ``b``'s above it. Among those: no compensation,
        then ArduPilot's fit, then PX4's (the field's cubic; ArduPilot's is the least-squares
        one, PX4's weighs every temperature bin alike), then the fewest thermal parameters
        (:func:`_rank`), then the lowest error.
    """
    mse = np.asarray(fold_mse, dtype=np.float64)
    ok = np.all(np.isfinite(mse), axis=1)
    if not ok.any():
        raise ValueError("no candidate could be fitted on the held-out folds")
    mean = np.where(ok, mse.mean(axis=1) if mse.size else np.inf, np.inf)
    b = int(np.argmin(mean))
    k = mse.shape[1]
    near = within_tolerance(np.sqrt(mean), tolerance)
    if k > 1:
        # deferred: scipy.special loads in ~0.2 s and only several folds need the Student t
        # quantile (taken from scipy.special: scipy.stats imports more slowly still)
        from scipy.special import stdtrit

        floor = 1e-12 * max(float(mean[b]), np.finfo(np.float64).tiny)
        logs = np.log(np.maximum(mse[ok], floor))
        diff = logs - np.log(np.maximum(mse[b], floor))
        avg = diff.mean(axis=1)
        se = diff.std(axis=1, ddof=1) / math.sqrt(k)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(se > 0, avg / se, np.where(avg > 0, np.inf, 0.0))
        near[np.flatnonzero(ok)] |= z <= float(stdtrit(k - 1, confidence))
    near &= ok
    pick = [(_rank(cands[i]), float(mean[i]), int(i)) for i in np.flatnonzero(near)]
    return cands[min(pick)[2]]


def _rank(cand: Candidate) -> tuple[int, int]:
    """Preference within noise: nothing, ArduPilot's fit, PX4's, then the fewest parameters.

    The field's cubic (ArduPilot's or PX4's) is what a user already has and what the flight
    software can load (``rinscal export``): another model must beat it by more than noise.
    """
    tier = {"none": 0, "ardupilot": 1, "px4": 2}.get(cand.family, 3)
    return tier, cand.n_params


def select_channel(
    x: np.ndarray,
    y: np.ndarray,
    run_codes: np.ndarray,
    runs: Sequence[str],
    t: np.ndarray,
    cands: Sequence[Candidate],
    tolerance: float = DEFAULT_TOLERANCE,
    random_state: int = 0,
) -> Selection:
    """Score every candidate on held-out folds and choose one.

    Parameters
    ----------
    x : ndarray, shape (n, d)
        Training inputs ``T`` [°C], ``Ṫ`` [°C/min] (, ``ΔT`` [°C]), inlier rows only.
    y : ndarray, shape (n,)
        The channel's output [log units].
    run_codes : ndarray of int, shape (n,)
        Run of each row.
    runs : sequence of str
        Run names.
    t : ndarray, shape (n,) [s]
        Time since each run's power-on.
    cands : sequence of Candidate
        From :func:`candidates`.
    tolerance : float [dimensionless]
        Of :func:`choose`: relative excess of the held-out RMS over the best's.
    random_state : int
        Seed of neural candidates.

    Returns
    -------
    Selection
    """
    if not 0 <= tolerance < 1:
        raise ValueError(f"tolerance must be in [0, 1), got {tolerance!r}")
    return _select(x, y, run_codes, runs, t, cands, tolerance, random_state)


def _select(
    x: np.ndarray,
    y: np.ndarray,
    run_codes: np.ndarray,
    runs: Sequence[str],
    t: np.ndarray,
    cands: Sequence[Candidate],
    tolerance: float,
    random_state: int,
) -> Selection:
    folds, plan = holdout_plan(run_codes, runs, x[:, 0])
    scored = plan.scored(folds.codes, x[:, 0])
    # the PX4/ArduPilot filters run on every sample; the held-out scores use every k-th
    baseline_fold = _baseline_screens(x[:, 0], y, run_codes, t, folds.codes, cands)
    step = max(1, math.ceil(x.shape[0] / SCREEN_SAMPLES))
    if step > 1:
        x, y, run_codes, t = x[::step], y[::step], run_codes[::step], t[::step]
        scored = scored[::step]
        folds = replace(folds, codes=folds.codes[::step], units=folds.units[::step])
    return _choose_scored(
        x, y, run_codes, t, folds, scored, baseline_fold, cands, tolerance, random_state
    )


def select_thinned(
    x: np.ndarray,
    y: np.ndarray,
    run_codes: np.ndarray,
    rows: np.ndarray,
    t: np.ndarray,
    spans: Sequence[RunSpan],
    runs: Sequence[str],
    tools: dict[str, tuple[np.ndarray, ...]],
    cands: Sequence[Candidate],
    tolerance: float = DEFAULT_TOLERANCE,
    random_state: int = 0,
) -> Selection:
    """:func:`select_channel` from every k-th row of a log and what each whole run left.

    What a log read a run at a time keeps of each channel (:class:`rinscal.calibration.
    _runs.RowSample`): the rows a held-out score uses (every ``k``-th usable row of the log,
    as :func:`select_channel` thins above :data:`SCREEN_SAMPLES` rows), each with the value
    of the field's filters at that row, computed on the whole run; and each run's
    :class:`RunSpan`. The choice is :func:`select_channel`'s on the whole log wherever both
    keep the same rows (up to :data:`SCREEN_SAMPLES` rows, and where ``k`` is a power of
    two); otherwise the field's held-out fits see other filtered samples of the same runs.

    Parameters
    ----------
    x, y, run_codes, t : ndarray
        The kept rows (as for :func:`select_channel`), runs in increasing code.
    rows : ndarray of int
        Position of each kept row among its run's usable rows.
    spans : sequence of RunSpan
        Each run with rows, in increasing code (cut into legs when fewer than 3).
    runs : sequence of str
        Run names, by code.
    tools : dict
        ``"px4"``: the 31-sample running median of the output at each kept row;
        ``"ardupilot"``: ``(T, y)`` of the 2 s moving average centred on each kept row
        (NaN where no complete window is).
    cands, tolerance, random_state
        As for :func:`select_channel`.

    Returns
    -------
    Selection
    """
    if not 0 <= tolerance < 1:
        raise ValueError(f"tolerance must be in [0, 1), got {tolerance!r}")
    plan = fold_plan(spans, runs)
    at = np.searchsorted(run_codes, [sp.code for sp in spans] + [np.iinfo(np.int64).max])
    where = [slice(int(a), int(b)) for a, b in itertools.pairwise(at)]
    folds = plan.folds([(sl, rows[sl]) for sl in where], run_codes.size)
    codes = folds.codes
    scored = plan.scored(codes, x[:, 0])
    pre: dict[str, tuple[np.ndarray, ...]] = {}
    if "px4" in tools:
        pre["px4"] = (x[:, 0], tools["px4"], codes)
    if "ardupilot" in tools:
        t_s, y_s = tools["ardupilot"]
        has = np.isfinite(t_s)
        pre["ardupilot"] = (t_s[has], y_s[has], codes[has], x[:, 0], y)
    fit = _tool_fits(pre, _tool_methods(cands))
    return _choose_scored(x, y, run_codes, t, folds, scored, fit, cands, tolerance, random_state)


def _choose_scored(
    x: np.ndarray,
    y: np.ndarray,
    run_codes: np.ndarray,
    t: np.ndarray,
    folds: Folds,
    scored: np.ndarray,
    baseline_fold: Callable[[str, int | None], dict[str, Any]],
    cands: Sequence[Candidate],
    tolerance: float,
    random_state: int,
) -> Selection:
    """Score every candidate on the rows given (already thinned) and choose one."""
    # deferred: only scoring needs threadpoolctl; importing this module stays numpy-only
    from threadpoolctl import threadpool_limits

    # thousands of tiny factorisations: BLAS threads only add overhead (and spin when the
    # process is pinned to one core)
    with threadpool_limits(limits=1, user_api="blas"):
        codes, units = folds.codes, folds.units
        nf = len(folds.names)
        nu = len(folds.unit_names)
        blocks = _averaging_blocks(units, run_codes, t, scored)
        # averaging blocks of each unit: a block is one stretch of rows of one unit, numbered
        # in row order, so each block's first row counts it
        idx = np.flatnonzero(blocks >= 0)
        first = idx[np.concatenate([[True], np.diff(blocks[idx]) != 0])] if idx.size else idx
        of = units[first]
        counts = np.bincount(of[(of >= 0) & (of < nu)], minlength=nu).astype(int)
        poly = [c for c in cands if c.orders is not None]
        fast = (
            _polynomial_scores(x, y, codes, nf, poly, blocks, units, folds.unit_fold)
            if poly
            else {}
        )
        n_total = int(counts.sum())
        # each unit's scored rows, taken once for every candidate scored by its predictions
        # (the field's fits, a network) on the held-out folds and on all the data
        parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        if any(c.name not in fast for c in cands):
            for u in range(nu):
                i = np.flatnonzero((units == u) & scored)
                parts.append((x[i], y[i], blocks[i]))

        def unit_ss(params: dict[str, Any], u: int) -> float:
            """SS of unit ``u``'s block means of the residual of ``params``, about their mean."""
            xu, yu, bu = parts[u]
            return _ss_about_mean(_block_means(yu - predict_params(params, xu), bu))

        table, mse_rows = [], []
        fitted: dict[str, dict[str, Any]] = {}
        for cand in cands:
            train_ss = np.full(nu, np.nan)  # neural: not fitted on every fold while screening
            if cand.name in fast:
                ss, train_ss = fast[cand.name]
            else:
                if cand.method in ("px4", "ardupilot"):  # the tool's own fit on all the data
                    try:
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            fitted[cand.name] = baseline_fold(cand.method, None)
                    except (ValueError, DesignError):
                        pass
                    else:
                        train_ss = np.array([unit_ss(fitted[cand.name], u) for u in range(nu)])
                ss = np.empty(nu)
                for k in range(nf):
                    mine = np.flatnonzero(folds.unit_fold == k)
                    try:
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            if cand.method in ("px4", "ardupilot"):
                                params = baseline_fold(cand.method, k)
                            else:
                                tr = codes != k
                                params = fit_candidate(
                                    cand, x[tr], y[tr], run_codes[tr], t[tr], random_state, True
                                )
                    except (ValueError, DesignError):
                        ss[mine] = np.nan
                        continue
                    for u in mine:
                        ss[u] = unit_ss(params, u)
            ss[counts == 0] = 0.0
            train_ss[counts == 0] = 0.0
            fold_rms = np.sqrt(ss / np.maximum(counts, 1))
            score = float(math.sqrt(np.sum(ss) / n_total)) if np.all(np.isfinite(ss)) else None
            train_rms = (
                float(math.sqrt(np.sum(train_ss) / n_total))
                if n_total and np.all(np.isfinite(train_ss))
                else None
            )
            mse_rows.append((ss / np.maximum(counts, 1))[counts > 0])
            table.append(
                {
                    "name": cand.name,
                    "method": "none" if cand.family == "none" else cand.method,
                    "n_params": int(cand.n_params),
                    "heldout_rms": score,
                    # None: not fitted, or nothing of the part scored (outside the T range)
                    "fold_rms": [
                        None if not (np.isfinite(v) and n) else float(v)
                        for v, n in zip(fold_rms, counts, strict=True)
                    ],
                    "train_rms": train_rms,
                }
            )
        mse = np.vstack(mse_rows)
        chosen = choose(cands, mse, tolerance)
        t_only = [i for i, c in enumerate(cands) if c.t_only]
        fallback = choose([cands[i] for i in t_only], mse[t_only], tolerance)
        # the field's fits on all the data (their training RMS above): the chosen and the
        # fallback, and for the firmware exports every one that scored (a channel whose
        # choice PX4 and ArduPilot cannot hold exports its best cubic)
        for c in (chosen, fallback):
            if c.method in ("px4", "ardupilot") and c.name not in fitted:
                fitted[c.name] = baseline_fold(c.method, None)  # as before: its error tells
        scored_names = {r["name"] for r in table if r["heldout_rms"] is not None}
        fitted = {
            k: v
            for k, v in fitted.items()
            if k in scored_names or k in (chosen.name, fallback.name)
        }
        return Selection(chosen, fallback, folds, float(tolerance), table, fitted)

"""Held-out folds of a calibration log: runs, or the heating and cooling legs of a run.

Leave-one-run-out when the log has :data:`MIN_RUNS` runs or more; otherwise each run is cut
into its legs (turning points of the temperature) and the legs into contiguous blocks, at
least :data:`MIN_FOLDS` folds in all (see :mod:`rinscal.calibration.selection.auto`). Never
random rows: neighbouring samples of a slow thermal signal are not independent.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "MIN_FOLDS",
    "MIN_RUNS",
    "FoldPlan",
    "Folds",
    "RunSpan",
    "fold_plan",
    "holdout_folds",
    "holdout_plan",
    "run_span",
]

#: Without three runs, legs are cut into contiguous blocks until there are this many folds
#: (a standard error of held-out error needs several).
MIN_FOLDS = 8
#: Leave-one-run-out from this many runs with rows on (fewer: legs, or blocks).
MIN_RUNS = 3


@dataclass(frozen=True)
class Folds:
    """Held-out folds of a training set.

    Attributes
    ----------
    codes : ndarray of int, shape (n,)
        Fold of each row: what a held-out fit leaves out.
    names : tuple of str
        Fold names (a run, ``<run>/heat``, ``<run>/cool2``, ``<run>/3``...).
    scheme : str
        ``leave-one-run-out``, ``legs`` or ``blocks``.
    units : ndarray of int, shape (n,)
        Scoring unit of each row: a fold, or a contiguous block of one (a leg's blocks are
        scored apart so that the error has a spread, but left out together).
    unit_names : tuple of str
        Unit names.
    unit_fold : ndarray of int
        Fold of each unit.
    """

    codes: np.ndarray
    names: tuple[str, ...]
    scheme: str
    units: np.ndarray
    unit_names: tuple[str, ...]
    unit_fold: np.ndarray


def _legs(temp: np.ndarray, min_frac: float = 0.05) -> list[tuple[int, int, str]]:
    """Heating and cooling legs of one run: (start, stop, "heat" | "cool")."""
    n = temp.size
    step = max(1, n // 20000)
    tz = temp[::step]
    span = float(np.ptp(tz)) if tz.size else 0.0
    h = max(1.0, 0.1 * span)
    turns = [0]
    direction = 0  # 0: not yet moved by h, 1: heating, -1: cooling
    first = float(tz[0]) if tz.size else 0.0
    ext_i, ext_v = 0, first
    for i in range(1, tz.size):
        v = float(tz[i])
        if direction == 0:
            if abs(v - first) >= h:
                direction, ext_i, ext_v = (1 if v > first else -1), i, v
        elif direction * (v - ext_v) > 0:  # further along the current leg
            ext_i, ext_v = i, v
        elif abs(v - ext_v) >= h:  # turned back by more than the hysteresis
            turns.append(ext_i)
            direction, ext_i, ext_v = -direction, i, v
    bounds = [t * step for t in turns] + [n]
    legs: list[tuple[int, int, str]] = []
    for a, b in itertools.pairwise(bounds):
        if b <= a:
            continue
        kind = "heat" if temp[b - 1] >= temp[a] else "cool"
        if legs and (b - a) < min_frac * n:
            pa, _, pk = legs[-1]
            legs[-1] = (pa, b, pk)
        else:
            legs.append((a, b, kind))
    return legs


@dataclass(frozen=True)
class RunSpan:
    """What the folds need of one run's usable rows: their number, legs and temperatures.

    Attributes
    ----------
    code : int
        Run code.
    n : int
        Rows.
    legs : tuple of (int, int, str)
        Heating and cooling legs ``(start, stop, "heat" | "cool")`` (:func:`_legs`), or the
        whole run as one ``(0, n, "")`` when it is not cut (leave-one-run-out needs no legs).
    cuts : ndarray of int
        Every boundary a scoring unit can have (a leg's, and those of the leg cut into
        1 .. :data:`MIN_FOLDS` equal blocks), 0 and ``n`` included, increasing.
    lo, hi : ndarray [°C]
        Lowest and highest temperature of the rows between consecutive cuts.
    """

    code: int
    n: int
    legs: tuple[tuple[int, int, str], ...]
    cuts: np.ndarray
    lo: np.ndarray
    hi: np.ndarray


def run_span(
    code: int, temp: np.ndarray, cut: bool, whole: tuple[float, float] | None = None
) -> RunSpan:
    """The :class:`RunSpan` of one run's usable rows.

    Parameters
    ----------
    code : int
        Run code.
    temp : ndarray, shape (n,) [°C]
        The run's temperature, rows in time order.
    cut : bool
        Cut the run into its legs (needed when the log has fewer than :data:`MIN_RUNS` runs).
    whole : (float, float), optional [°C]
        ``temp.min()`` and ``temp.max()`` where the caller has them: a run not cut is one
        segment, whose range is then not searched for again.
    """
    n = int(temp.size)
    legs = tuple(_legs(temp)) if cut and n else ((0, n, ""),)
    cuts = {0, n}
    for a, b, _ in legs:
        for per in range(1, MIN_FOLDS + 1) if cut else (1,):
            cuts.update((a + np.cumsum([0, *_split_sizes(b - a, per)])).tolist())
    c = np.array(sorted(cuts), dtype=np.int64)
    if n and whole is not None and c.size == 2:
        lo, hi = np.array([whole[0]], dtype=np.float64), np.array([whole[1]], dtype=np.float64)
    elif n:
        lo, hi = np.minimum.reduceat(temp, c[:-1]), np.maximum.reduceat(temp, c[:-1])
    else:
        lo = hi = np.zeros(0)
    return RunSpan(int(code), n, legs, c, lo, hi)


def _split_sizes(n: int, parts: int) -> list[int]:
    """Sizes of ``numpy.array_split`` of ``n`` rows into ``parts``: the larger ones first."""
    q, r = divmod(int(n), int(parts))
    return [q + 1] * r + [q] * (parts - r)


@dataclass(frozen=True)
class FoldPlan:
    """Folds and scoring units of a log, as segments of each run's rows.

    Attributes
    ----------
    names, scheme, unit_names, unit_fold
        As in :class:`Folds`.
    segments : tuple of (ndarray, ndarray)
        Per run (in the order of its span): the start row of each unit segment, and its unit.
    lo, hi : ndarray [°C]
        Temperature range of each fold's rows.
    """

    names: tuple[str, ...]
    scheme: str
    unit_names: tuple[str, ...]
    unit_fold: np.ndarray
    segments: tuple[tuple[np.ndarray, np.ndarray], ...]
    lo: np.ndarray
    hi: np.ndarray

    def label(self, i: int, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Fold and unit of rows ``rows`` (positions within run ``i``)."""
        starts, units = self.segments[i]
        u = units[np.searchsorted(starts, rows, side="right") - 1]
        return self.unit_fold[u], u

    def folds(self, parts: Sequence[tuple[Any, np.ndarray]], n: int) -> Folds:
        """The :class:`Folds` of ``n`` rows: ``parts[i]`` says where run ``i``'s rows are
        (an index or a slice) and their positions within the run."""
        codes = np.empty(n, dtype=np.int64)
        units = np.empty(n, dtype=np.int64)
        for i, (where, rows) in enumerate(parts):
            codes[where], units[where] = self.label(i, rows)
        return Folds(codes, self.names, self.scheme, units, self.unit_names, self.unit_fold)

    def scored(self, folds: np.ndarray, temp: np.ndarray) -> np.ndarray:
        """Rows within the temperatures of the folds trained on when theirs is held out.

        Outside that range compensation clamps, and extrapolating in T is not what the
        choice is about.
        """
        nf = len(self.names)
        lo_o, hi_o = np.empty(nf), np.empty(nf)
        for k in range(nf):
            others = np.arange(nf) != k
            lo_o[k] = self.lo[others].min() if others.any() else np.inf
            hi_o[k] = self.hi[others].max() if others.any() else -np.inf
        return (temp >= lo_o[folds]) & (temp <= hi_o[folds])


def fold_plan(spans: Sequence[RunSpan], runs: Sequence[str], min_runs: int = MIN_RUNS) -> FoldPlan:
    """Folds for the held-out choice (see the module docstring) from the runs' spans.

    Parameters
    ----------
    spans : sequence of RunSpan
        The runs with rows, in increasing code (each cut into legs when fewer than
        ``min_runs``).
    runs : sequence of str
        Run names, by code.
    min_runs : int
        Leave-one-run-out from this many runs on.

    Returns
    -------
    FoldPlan
    """

    def segment_range(sp: RunSpan, a: int, b: int) -> tuple[float, float]:
        sel = (sp.cuts[:-1] >= a) & (sp.cuts[:-1] < b)
        if not sel.any():
            return np.inf, -np.inf
        return float(sp.lo[sel].min()), float(sp.hi[sel].max())

    if len(spans) >= min_runs:
        names = tuple(runs[sp.code] for sp in spans)
        idx = np.arange(len(spans))
        ranges = [segment_range(sp, 0, sp.n) for sp in spans]
        segs = tuple((np.zeros(1, dtype=np.int64), idx[i : i + 1]) for i in range(len(spans)))
        lo, hi = (np.array(v) for v in zip(*ranges, strict=True))
        return FoldPlan(names, "leave-one-run-out", names, idx, segs, lo, hi)
    pieces = [
        (i, a, b, f"{runs[sp.code]}/{kind}") for i, sp in enumerate(spans) for a, b, kind in sp.legs
    ]
    # unique names: a run's second cooling leg is cool2
    seen: dict[str, int] = {}
    for *_, name in pieces:
        seen[name] = seen.get(name, 0) + 1
    count = dict.fromkeys(seen, 0)
    named = []
    for i, a, b, name in pieces:
        count[name] += 1
        named.append((i, a, b, name if seen[name] == 1 else f"{name}{count[name]}"))
    per = math.ceil(MIN_FOLDS / len(named))
    starts: list[list[int]] = [[] for _ in spans]
    unit_of: list[list[int]] = [[] for _ in spans]
    unit_names: list[str] = []
    leg_of: list[int] = []
    ranges = []
    for j, (i, a, b, name) in enumerate(named):
        bounds = a + np.cumsum([0, *_split_sizes(b - a, per)])
        for u, (ua, ub) in enumerate(itertools.pairwise(bounds.tolist())):
            starts[i].append(ua)
            unit_of[i].append(len(unit_names))
            unit_names.append(f"{name}/{u + 1}" if per > 1 else name)
            leg_of.append(j)
            ranges.append(segment_range(spans[i], ua, ub))
    segs = tuple(
        (np.asarray(s, dtype=np.int64), np.asarray(u, dtype=np.int64))
        for s, u in zip(starts, unit_of, strict=True)
    )
    u_lo, u_hi = (np.array(v) for v in zip(*ranges, strict=True))
    if len(named) >= 2:  # leave one leg out, score its blocks apart
        fold = np.asarray(leg_of)
        lo = np.array([u_lo[fold == k].min() for k in range(len(named))])
        hi = np.array([u_hi[fold == k].max() for k in range(len(named))])
        return FoldPlan(
            tuple(name for *_, name in named), "legs", tuple(unit_names), fold, segs, lo, hi
        )
    # one leg: its blocks are the folds
    idx = np.arange(len(unit_names))
    return FoldPlan(tuple(unit_names), "blocks", tuple(unit_names), idx, segs, u_lo, u_hi)


def holdout_folds(
    run_codes: np.ndarray, runs: Sequence[str], temp: np.ndarray, min_runs: int = MIN_RUNS
) -> Folds:
    """Folds for the held-out choice (see the module docstring).

    Parameters
    ----------
    run_codes : ndarray of int, shape (n,)
        Run of each row (each run one contiguous block, rows in time order).
    runs : sequence of str
        Run names.
    temp : ndarray, shape (n,) [°C]
        Temperature (legs are cut at its turning points).
    min_runs : int
        Leave-one-run-out from this many runs on.

    Returns
    -------
    Folds
    """
    return holdout_plan(run_codes, runs, temp, min_runs)[0]


def holdout_plan(
    run_codes: np.ndarray, runs: Sequence[str], temp: np.ndarray, min_runs: int = MIN_RUNS
) -> tuple[Folds, FoldPlan]:
    """:func:`holdout_folds` and its plan (fold temperature ranges)."""
    present = np.unique(run_codes)
    rows = [np.flatnonzero(run_codes == k) for k in present]
    cut = present.size < min_runs
    spans = [run_span(int(k), temp[r], cut) for k, r in zip(present, rows, strict=True)]
    plan = fold_plan(spans, runs, min_runs)
    return plan.folds([(r, np.arange(r.size)) for r in rows], run_codes.size), plan

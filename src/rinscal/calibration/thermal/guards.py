"""Guards on training data: refuse a meaningless model, warn about a weak one.

A thermal model fitted on bad data can be off by orders of magnitude without a word (a
regression fitted on 1 °C-quantised temperatures, where ``ΔT`` takes three values and its
square is a combination of the intercept and ``ΔT``, came out off by 10¹³ µg). These checks
run before and during every fit:

:func:`check_temperatures`
    Every temperature column within a plausible range (default −60 … +150 °C; an error naming
    the column and the first offending row) and of a resolution of 0.1 °C or finer (a warning:
    quantised readings make ``Ṫ`` and ``ΔT`` staircases, see PX4 issue #13551).
:func:`check_temperature_span`
    The temperature span of the training data: an error below :data:`MIN_TEMP_SPAN_C`
    (a model of temperature fitted over a few tenths of a degree only extrapolates), a
    warning below :data:`WEAK_TEMP_SPAN_C` (PX4's least allowed ``SYS_CAL_TDEL``; its default
    asks a 24 °C rise).
:func:`check_design`
    The least-squares design of a polynomial model, from its triangular factor ``R``: an
    error when it is rank-deficient (condition number of the column-equilibrated ``R`` above
    :data:`COND_ERROR`), a warning when it is ill-conditioned (above :data:`COND_WARN`); the
    message says why, from :func:`diagnose_inputs` (an input constant, taking fewer distinct
    values than its polynomial order needs, or two inputs collinear, as ``T`` and ``Ṫ`` on a
    single exponential warm-up).

Thresholds: on the simulated soak protocol and on the real MEMS log the condition numbers of
every default design are 5 … 300; noise in the data is amplified by up to the condition
number, so 10⁵ is weak and 10¹⁰ meaningless.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

__all__ = [
    "COND_ERROR",
    "COND_WARN",
    "INPUT_LABELS",
    "PLAUSIBLE_TEMP_C",
    "RESOLUTION_LIMIT_C",
    "DesignError",
    "TrainingDataWarning",
    "check_design",
    "check_temperature_span",
    "check_temperatures",
    "collinear_inputs",
    "design_condition",
    "diagnose_inputs",
    "temperature_resolution",
    "warn_resolution",
]

#: Names of the feature columns, in order.
INPUT_LABELS: tuple[str, str, str] = ("T", "Ṫ", "ΔT")
#: Default plausible temperature range of a reading [°C].
PLAUSIBLE_TEMP_C: tuple[float, float] = (-60.0, 150.0)
#: Temperature resolution coarser than this is warned about [°C].
RESOLUTION_LIMIT_C = 0.1
#: Temperature span of the training data below which a fit is refused [°C].
MIN_TEMP_SPAN_C = 5.0
#: Span below which it is warned about [°C]: PX4's least ``SYS_CAL_TDEL`` (default 24 °C).
WEAK_TEMP_SPAN_C = 10.0
#: Condition number of the equilibrated design above which a fit is refused.
COND_ERROR = 1e10
#: Condition number above which a fit is warned about.
COND_WARN = 1e5
#: ``|r|`` above which two inputs are called collinear: a warning.
COLLINEAR_R = 0.999
#: ``|r|`` above which they are refused (a single exponential warm-up gives |r| > 0.99999).
COLLINEAR_ERROR_R = 0.99999


class TrainingDataWarning(UserWarning):
    """The training data allow a model, but a weak one (the message says why and what to do)."""


class DesignError(ValueError):
    """The training data cannot determine the model (rank-deficient design)."""


def design_condition(r: np.ndarray) -> float:
    """Condition number of a least-squares design from its triangular factor.

    Parameters
    ----------
    r : ndarray, shape (k, m)
        ``R`` of the QR factorisation of the design ``A`` (``AᵀA = RᵀR``); ``k ≥ m``
        rows are not required (missing rows count as zero).

    Returns
    -------
    float
        ``σ_max / σ_min`` of ``R`` with unit-norm columns (``inf`` if singular): invariant to
        the scale of each column, so it measures collinearity, not units.
    """
    m = r.shape[1]
    rr = np.zeros((m, m))
    k = min(m, r.shape[0])
    rr[:k] = r[:k]
    norms = np.linalg.norm(rr, axis=0)
    if np.any(norms == 0):
        return float("inf")
    s = np.linalg.svd(rr / norms, compute_uv=False)
    return float("inf") if s[-1] <= 0 else float(s[0] / s[-1])


def collinear_inputs(
    x: np.ndarray, orders: Sequence[int], limit: float = COLLINEAR_ERROR_R
) -> list[str]:
    """Pairs of used inputs that are collinear (``|r| >`` :data:`COLLINEAR_R`), in words.

    Parameters
    ----------
    x : ndarray, shape (n, k)
        Inputs ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C].
    orders : sequence of int
        Polynomial order of each input (0: unused).
    limit : float
        ``|r|`` above which a pair is reported.

    Returns
    -------
    list of str
        One sentence per collinear pair (correlations over at most ~400 000 samples).
    """
    found: list[str] = []
    used = [v for v, o in enumerate(orders) if o > 0]
    for i, a in enumerate(used):
        for b in used[i + 1 :]:
            step = max(1, x.shape[0] // 200_000)  # a correlation needs no million samples
            xa, xb = x[::step, a], x[::step, b]
            if np.ptp(xa) == 0 or np.ptp(xb) == 0:
                continue
            r = float(np.corrcoef(xa, xb)[0, 1])
            if abs(r) > limit:
                found.append(
                    f"{INPUT_LABELS[a]} and {INPUT_LABELS[b]} are collinear (r = {r:.6f}), as "
                    "on a single exponential warm-up, so their terms cannot be told apart: "
                    "record runs at other chamber temperatures or a ramp, or leave the "
                    "rate term out (orders= with 0 for it, or method='poly-t')"
                )
    return found


def diagnose_inputs(x: np.ndarray, orders: Sequence[int]) -> list[str]:
    """Why a polynomial design in the inputs may be singular, in words.

    Parameters
    ----------
    x : ndarray, shape (n, k)
        Inputs ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C] (the first ``len(orders)`` used).
    orders : sequence of int
        Polynomial order of each input (0: unused).

    Returns
    -------
    list of str
        One sentence per finding (empty when none is found).
    """
    found: list[str] = []
    used = [v for v, o in enumerate(orders) if o > 0]
    for v in used:
        col = x[:, v]
        distinct = np.unique(col[np.isfinite(col)])
        name = INPUT_LABELS[v]
        if distinct.size <= 1:
            val = f" ({distinct[0]:.6g})" if distinct.size else ""
            found.append(f"{name} is constant{val}: a thermal model needs it to vary")
        elif distinct.size <= orders[v]:
            step = float(np.min(np.diff(distinct)))
            found.append(
                f"{name} takes only {distinct.size} distinct values (steps of {step:.3g}), too "
                f"few for a polynomial of order {orders[v]}: quantised temperatures?"
            )
    return found + collinear_inputs(x, orders, COLLINEAR_R)


def check_design(
    r: np.ndarray,
    x: np.ndarray,
    orders: Sequence[int],
    what: str,
    warn_collinear: bool = True,
) -> float:
    """Refuse a rank-deficient polynomial design, warn about an ill-conditioned one.

    Parameters
    ----------
    r : ndarray, shape (k, m)
        Triangular factor of the design (columns: intercept, then the powers of each input).
    x : ndarray, shape (n, k)
        The inputs the design was built from (for the diagnosis).
    orders : sequence of int
        Polynomial order of each input.
    what : str
        The model, for messages (e.g. ``"regression (3, 3, 3)"``).
    warn_collinear : bool
        Warn about inputs collinear below the error level (off for a sectional model's
        segments, each of which is one warm-up by design).

    Returns
    -------
    float
        The condition number (see :func:`design_condition`).

    Raises
    ------
    DesignError
        Condition number above :data:`COND_ERROR`, or two used inputs collinear beyond
        :data:`COLLINEAR_ERROR_R` (:func:`collinear_inputs`): the split of the fit between
        them would be arbitrary.

    Warns
    -----
    TrainingDataWarning
        Condition number above :data:`COND_WARN`, or inputs collinear beyond
        :data:`COLLINEAR_R`.
    """
    cond = design_condition(r)
    collinear = collinear_inputs(x, orders)
    if collinear:
        raise DesignError(
            f"the training data cannot determine a {what} model: {'; '.join(collinear)}"
        )
    near = collinear_inputs(x, orders, COLLINEAR_R) if warn_collinear else []
    if near:
        warnings.warn(
            f"{what} model is weakly determined by the training data: {'; '.join(near)}",
            TrainingDataWarning,
            stacklevel=3,
        )
    if cond <= COND_WARN:
        return cond
    why = diagnose_inputs(x, orders)
    because = "; ".join(why) if why else "its inputs are nearly dependent"
    if cond > COND_ERROR:
        raise DesignError(
            f"the training data cannot determine a {what} model (rank-deficient design, "
            f"condition number {cond:.3g}): {because}"
        )
    warnings.warn(
        f"{what} model is weakly determined by the training data (condition number "
        f"{cond:.3g}): {because}; its coefficients are unreliable, prefer lower orders",
        TrainingDataWarning,
        stacklevel=3,
    )
    return cond


def temperature_resolution(values: np.ndarray) -> float:
    """Resolution of a temperature reading: the smallest change between consecutive samples.

    A quantised reading changes in multiples of its step, and a slowly varying temperature
    changes by one step at a time, so the smallest nonzero change is the step (O(n), no
    sort).

    Parameters
    ----------
    values : ndarray [°C]
        Readings in time order (NaN ignored).

    Returns
    -------
    float [°C]
        The smallest nonzero ``|v[i+1] − v[i]|`` (``inf`` if the reading never changes).
    """
    v = values
    if not np.isfinite(np.sum(v)):  # some NaN or inf (a finite sum: none, no copy)
        v = v[np.isfinite(v)]
    d = np.diff(v)
    d = d[d != 0]  # the changes: few, a quantised reading mostly repeats
    return float(np.abs(d).min()) if d.size else float("inf")


def check_temperatures(
    columns: dict[str, np.ndarray],
    plausible: tuple[float, float] = PLAUSIBLE_TEMP_C,
    rows: np.ndarray | None = None,
    *,
    warn: bool = True,
) -> dict[str, float]:
    """Check temperature readings: plausible range (error) and resolution (warning).

    Parameters
    ----------
    columns : dict of str to ndarray [°C]
        Temperature columns of a log (or of one of its runs) by name.
    plausible : (float, float) [°C]
        Lowest and highest plausible reading.
    rows : ndarray of int, optional
        Row labels for messages (default 0-based positions).
    warn : bool
        Warn about a coarse resolution here (False: the caller combines the returned
        resolutions of several runs and calls :func:`warn_resolution`).

    Returns
    -------
    dict of str to float [°C]
        Resolution of each column (:func:`temperature_resolution`).

    Raises
    ------
    ValueError
        Naming the column, the first implausible row and its value.

    Warns
    -----
    TrainingDataWarning
        When a column's resolution is coarser than :data:`RESOLUTION_LIMIT_C`.
    """
    lo, hi = plausible
    if not lo < hi:
        raise ValueError(f"plausible temperature range must have low < high, got {plausible}")
    out = {}
    for name, v in columns.items():
        if v.size and lo <= np.min(v) and np.max(v) <= hi:  # all finite and plausible
            out[name] = temperature_resolution(v)
            continue
        bad = np.flatnonzero(np.isfinite(v) & ((v < lo) | (v > hi)))
        if bad.size:
            i = int(bad[0])
            row = int(rows[i]) if rows is not None else i
            raise ValueError(
                f"column {name!r}: {bad.size} reading(s) outside the plausible range "
                f"{lo:g} … {hi:g} °C, first at data row {row} ({v[i]:.6g} °C); fix or drop "
                "those rows, or widen the range (temp_range=)"
            )
        out[name] = temperature_resolution(v)
    if warn:
        warn_resolution(out)
    return out


def check_temperature_span(low: float, high: float, what: str) -> None:
    """Refuse a fit over too little temperature range; warn about a narrow one.

    Parameters
    ----------
    low, high : float [°C]
        The training data's lowest and highest temperature.
    what : str
        The channel and column, for messages.

    Raises
    ------
    ValueError
        Span below :data:`MIN_TEMP_SPAN_C`: the message gives the range found and the range
        needed.

    Warns
    -----
    TrainingDataWarning
        Span below :data:`WEAK_TEMP_SPAN_C`.
    """
    span = high - low
    found = f"the training data span {low:.2f} .. {high:.2f} °C ({span:.2f} °C)"
    how = (
        f"a thermal model needs at least {MIN_TEMP_SPAN_C:g} °C, and PX4's thermal "
        f"calibration asks for a 24 °C rise (SYS_CAL_TDEL): log a warm-up from cold, or "
        "a chamber ramp"
    )
    if not span >= MIN_TEMP_SPAN_C:
        raise ValueError(f"{what}: too little temperature range to fit: {found}; {how}")
    if span < WEAK_TEMP_SPAN_C:
        warnings.warn(
            f"{what}: narrow temperature range: {found}, less than {WEAK_TEMP_SPAN_C:g} °C; "
            "the model holds only inside it (outside, the clamp or out-of-range policy "
            "applies)",
            TrainingDataWarning,
            stacklevel=3,
        )


def warn_resolution(resolutions: dict[str, float]) -> None:
    """Warn about each temperature column whose resolution is coarser than the limit.

    Parameters
    ----------
    resolutions : dict of str to float [°C]
        From :func:`check_temperatures` (the least over the runs of a log).
    """
    for name, res in resolutions.items():
        if np.isfinite(res) and res > RESOLUTION_LIMIT_C * (1 + 1e-9):
            warnings.warn(
                f"column {name!r}: temperature resolution {res:.3g} °C is coarser than "
                f"{RESOLUTION_LIMIT_C:g} °C (quantised readings, cf. PX4 issue #13551): the "
                "rate Ṫ and gradient ΔT become staircases and the model is weak; log the "
                "temperature at full resolution",
                TrainingDataWarning,
                stacklevel=3,
            )

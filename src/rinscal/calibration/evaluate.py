"""How well a thermal model compensates a log: RMS before and after, steps at segment edges.

RMS (Eq. 16)
    Per run and channel, ``sqrt(mean((y − ȳ_run)²))`` of the output before and after
    compensation, over the run's inlier samples (finite, not masked as outliers), **about
    the run mean**: a constant offset per power-on (turn-on bias repeatability) is not a
    thermal effect and no thermal model can predict it, so it is left out of both figures.
Step at a segment edge (the paper's Figure 7)
    Where the channel's inner temperature crosses a segment edge (with a hysteresis of
    ``hysteresis_c`` so that noise around the edge counts once), a straight line is fitted
    by least squares to the output over ``window_s`` seconds just before the crossing and
    another over ``window_s`` seconds just after; the step is the difference of the two
    lines at the crossing time. The local trends are thus extrapolated to the crossing, and
    the step is what they do not explain; for a smooth output the quadratic terms of the two
    one-sided extrapolations cancel and only a third-order term (``~ y''' h³``) remains.
    The largest absolute step per run and channel is reported, for the raw output (a
    control: a smooth output has none) and for the compensated output. The edges are the
    sectional model's own, or, for the other methods, the midpoints between the
    calibration set points stored in the model file.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from rinscal.calibration.allan import AllanCurve, allan_deviation, noise_parameters
from rinscal.calibration.compensate import imu_calibrated_frame
from rinscal.calibration.compensator import Compensator, model_features
from rinscal.calibration.modelfile import FittedModel, Policy
from rinscal.calibration.regression import least_squares
from rinscal.calibration.thermal.features import DerivativeConfig, Features, OutlierConfig
from rinscal.errors import ConfigError

__all__ = [
    "Prepared",
    "StepConfig",
    "allan_table",
    "edge_crossings",
    "edge_steps",
    "evaluate",
    "evaluate_runs",
    "prepare",
]


@dataclass(frozen=True)
class StepConfig:
    """How steps at segment edges are measured.

    Parameters
    ----------
    window_s : float [s]
        Length of the fit windows before and after a crossing.
    hysteresis_c : float [°C]
        The temperature must leave the band ``edge ± hysteresis_c`` to count as a crossing.
    min_samples : int
        Least number of samples in each window.
    """

    window_s: float = 120.0
    hysteresis_c: float = 0.05
    min_samples: int = 10

    def __post_init__(self) -> None:
        if not (np.isfinite(self.window_s) and self.window_s > 0):
            raise ConfigError(f"step window_s must be positive, got {self.window_s!r}")
        if not (np.isfinite(self.hysteresis_c) and self.hysteresis_c >= 0):
            raise ConfigError(f"hysteresis_c must be >= 0, got {self.hysteresis_c!r}")
        if self.min_samples < 2:
            raise ConfigError(f"min_samples must be at least 2, got {self.min_samples!r}")


def edge_crossings(temp: np.ndarray, edge: float, hysteresis: float) -> np.ndarray:
    """Indices where a temperature series crosses an edge (first sample on the new side).

    Parameters
    ----------
    temp : ndarray, shape (n,) [°C]
        Temperature of one run.
    edge : float [°C]
        Segment edge.
    hysteresis : float [°C]
        Half-width of the dead band around the edge.

    Returns
    -------
    ndarray of int
        Index of the first sample past the edge (``T > edge`` going up, ``T ≤ edge`` going
        down, matching the segment rule ``edges[k−1] < T ≤ edges[k]``) for each crossing.
    """
    n = temp.size
    state = np.zeros(n, dtype=np.int8)
    state[temp > edge + hysteresis] = 1
    state[temp < edge - hysteresis] = -1
    nz = np.flatnonzero(state)
    if nz.size < 2:
        return np.zeros(0, dtype=np.int64)
    s = state[nz]
    flips = nz[1:][s[1:] != s[:-1]]
    out = []
    for k in flips:
        up = state[k] > 0
        c = int(k)
        # walk back to the first sample of the final stretch on the new side of the edge
        while c > 0 and ((temp[c - 1] > edge) if up else (temp[c - 1] <= edge)):
            c -= 1
        out.append(c)
    return np.asarray(out, dtype=np.int64)


def _line_at(t: np.ndarray, y: np.ndarray, t0: float) -> float:
    tt = t - t0
    a = np.column_stack([np.ones_like(tt), tt])
    beta = least_squares(a, y)
    return float(beta[0])


def edge_steps(
    t: np.ndarray,
    y: np.ndarray,
    temp: np.ndarray,
    edges: np.ndarray,
    config: StepConfig,
    ok: np.ndarray | None = None,
) -> list[tuple[float, float, float]]:
    """Steps of a signal where the temperature crosses segment edges, within one run.

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Time.
    y : ndarray, shape (n,)
        Signal.
    temp : ndarray, shape (n,) [°C]
        Temperature deciding the segment.
    edges : ndarray [°C]
        Segment edges.
    config : StepConfig
        Window, hysteresis, minimum samples.
    ok : ndarray of bool, shape (n,), optional
        Samples usable in the line fits.

    Returns
    -------
    list of (time_s, edge, step)
        One entry per crossing with enough samples on both sides; ``step`` is the
        after-minus-before jump [unit of y].
    """
    ok = np.isfinite(y) if ok is None else ok & np.isfinite(y)
    out = []
    h = config.window_s
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    for e in np.asarray(edges, dtype=np.float64):
        for c in edge_crossings(temp, float(e), config.hysteresis_c):
            tc = float(t[c])
            before = ok & (t >= tc - h) & (t < tc)
            after = ok & (t >= tc) & (t < tc + h)
            if before.sum() < config.min_samples or after.sum() < config.min_samples:
                continue
            if tc - h < t[0] or tc + h > t[-1] + dt:
                continue  # a window would reach outside the run
            step = _line_at(t[after], y[after], tc) - _line_at(t[before], y[before], tc)
            out.append((tc, float(e), step))
    return out


#: Features of a log and the model's output and flags on it (:func:`prepare`).
Prepared = tuple[Features, np.ndarray, np.ndarray]


def prepare(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy = "clamp",
    derivative_kind: str | None = None,
    outliers: OutlierConfig | None = None,
    first_row: int = 0,
) -> Prepared:
    """Features of a log (outliers masked as for fitting) and the model's output on it.

    Parameters
    ----------
    log : DataFrame
        Validated calibration log.
    model : FittedModel
        The model.
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Handling of samples outside the training data.
    derivative_kind : {"centred", "causal"}, optional
        Override the model's derivative kind.
    outliers : OutlierConfig, optional
        Outlier masking (default: as for fitting).
    first_row : int
        Data rows of the file before ``log`` (a log read run by run), for messages.

    Returns
    -------
    features : Features
    f : ndarray, shape (n, m) [log units]
        Modelled output per channel.
    flagged : ndarray of bool, shape (n, m)
    """
    feats = model_features(log, model, derivative_kind, outliers or OutlierConfig())
    f, flags = Compensator(model, policy).predict(log, derivative_kind, feats, first_row)
    return feats, f, flags


def evaluate_runs(
    runs: Iterable[tuple[pd.DataFrame, int]],
    model: FittedModel,
    policy: Policy = "clamp",
    derivative_kind: str | None = None,
    step: StepConfig | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame, dict[str, dict[str, dict[str, AllanCurve]]]]:
    """:func:`evaluate` and :func:`allan_table` of a log given a run at a time.

    Both are per run and channel, so each run is prepared, measured and let go a channel at
    a time. Behind an IMU calibration each run first goes through it (:data:`IMU_ORDER
    <rinscal.calibration.imustage.IMU_ORDER>`): "before" is then the IMU-calibrated output
    and every figure is in deg/h and µg. The rows are those of the whole log, in the same
    order (evaluation: channel by channel, runs in file order; Allan deviation: run by run).

    Parameters
    ----------
    runs : iterable of (DataFrame, int)
        The log's runs, each whole and validated, and the data rows of the file before each
        (as :func:`rinscal.io.streaming.iter_log_source` yields them).
    model, policy, derivative_kind, step
        As for :func:`evaluate`.

    Returns
    -------
    table : DataFrame
        :func:`evaluate`'s table.
    allan : DataFrame
        :func:`allan_table`'s table.
    curves : dict
        :func:`allan_table`'s curves.
    """
    parts, allans = [], []
    curves: dict[str, dict[str, dict[str, AllanCurve]]] = {}
    stage = model.imu_stage
    thermal = model.with_imu(None)
    deriv = DerivativeConfig(
        window_s=model.derivative_window_s, kind=derivative_kind or model.derivative_kind
    )
    for log, first_row in runs:
        if stage is not None:  # "before" is the IMU-calibrated output, in deg/h and µg
            log = imu_calibrated_frame(log, stage, deriv)
        for c in model.channels:  # a channel at a time: memory of one channel's features
            one = thermal.subset((c,))
            prepared = prepare(log, one, policy, derivative_kind, first_row=first_row)
            parts.append(evaluate(log, one, policy, derivative_kind, step, prepared=prepared))
            table, curve = allan_table(log, one, policy, derivative_kind, prepared=prepared)
            allans.append(table)
            for run, by_channel in curve.items():
                curves.setdefault(run, {}).update(by_channel)
    res = pd.concat(parts, ignore_index=True)
    order = {c: j for j, c in enumerate(model.channels)}
    res = res.iloc[np.argsort(res["channel"].map(order).to_numpy(), kind="stable")]
    return res.reset_index(drop=True), pd.concat(allans, ignore_index=True), curves


def evaluate(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy = "clamp",
    derivative_kind: str | None = None,
    step: StepConfig | None = None,
    outliers: OutlierConfig | None = None,
    edges: np.ndarray | list[float] | None = None,
    prepared: Prepared | None = None,
) -> pd.DataFrame:
    """RMS before/after compensation and the largest step at a segment edge, per run and channel.

    Parameters
    ----------
    log : DataFrame
        Validated calibration log.
    model : FittedModel
        The model.
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Handling of samples outside the training data.
    derivative_kind : {"centred", "causal"}, optional
        Override the model's derivative kind.
    step : StepConfig, optional
        Step measurement.
    outliers : OutlierConfig, optional
        Masking of outliers from the statistics (default: as for fitting).
    edges : array_like, optional [°C]
        Segment edges to check for steps, for every channel (default: each channel's
        ``segment_edges`` from the model file), e.g. a sectional model's edges to check
        another model at the same temperatures.

    Returns
    -------
    DataFrame
        One row per run and channel: ``run, channel, unit, samples, outliers,
        out_of_range, rms_before, rms_after, ratio`` (after/before), ``crossings``,
        ``max_step_before, max_step_after`` (NaN without crossings) and
        ``max_step_time_s, max_step_edge_c`` of the compensated output's largest step.

    ``prepared`` (from :func:`prepare`) spares rebuilding the features and the prediction when
    :func:`allan_table` evaluates the same log.
    """
    step = step or StepConfig()
    feats, f, flags = prepared or prepare(log, model, policy, derivative_kind, outliers)
    rows = []
    for j, c in enumerate(model.channels):
        cm = model.models[c]
        ref = cm.static_reference or 0.0
        y = feats.output[:, j]
        comp = y - (f[:, j] - ref)
        for k, run in enumerate(feats.runs):
            r = np.flatnonzero(feats.run_codes == k)
            ok = feats.inlier[r, j]
            yb, ya = y[r][ok], comp[r][ok]
            rms_b = float(np.sqrt(np.mean((yb - yb.mean()) ** 2))) if yb.size else np.nan
            rms_a = float(np.sqrt(np.mean((ya - ya.mean()) ** 2))) if ya.size else np.nan
            row = {
                "run": run,
                "channel": c,
                "unit": cm.unit or "",
                "samples": int(r.size),
                "outliers": int(feats.report.removed[k, j]),
                "out_of_range": int(flags[r, j].sum()),
                "rms_before": rms_b,
                "rms_after": rms_a,
                "ratio": rms_a / rms_b if rms_b > 0 else np.nan,
                "crossings": 0,
                "max_step_before": np.nan,
                "max_step_after": np.nan,
                "max_step_time_s": np.nan,
                "max_step_edge_c": np.nan,
            }
            e = cm.segment_edges if edges is None else np.asarray(edges, dtype=np.float64)
            if e is not None and e.size:
                tr, temp = feats.time_s[r], feats.temp[r, j]
                sa = edge_steps(tr, comp[r], temp, e, step, feats.inlier[r, j])
                sb = edge_steps(tr, y[r], temp, e, step, feats.inlier[r, j])
                row["crossings"] = len(sa)
                if sa:
                    i = int(np.argmax([abs(s[2]) for s in sa]))
                    row["max_step_after"] = abs(sa[i][2])
                    row["max_step_time_s"] = sa[i][0]
                    row["max_step_edge_c"] = sa[i][1]
                if sb:
                    row["max_step_before"] = max(abs(s[2]) for s in sb)
            rows.append(row)
    return pd.DataFrame(rows)


def allan_table(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy = "clamp",
    derivative_kind: str | None = None,
    outliers: OutlierConfig | None = None,
    prepared: Prepared | None = None,
) -> tuple[pd.DataFrame, dict[str, dict[str, dict[str, AllanCurve]]]]:
    """Allan deviation of the raw and the compensated output, per run and channel.

    Overlapping Allan deviation (:func:`rinscal.calibration.allan.allan_deviation`, octave
    spacing) of each run's output before and after compensation, outliers and dropped samples
    as gaps, and the IEEE Std 952 noise parameters read from each curve
    (:func:`rinscal.calibration.allan.noise_parameters`).

    Parameters
    ----------
    log : DataFrame
        Validated calibration log.
    model : FittedModel
        The model.
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Handling of samples outside the training data.
    derivative_kind : {"centred", "causal"}, optional
        Override the model's derivative kind.
    outliers : OutlierConfig, optional
        Outlier masking (default: as for fitting).

    Returns
    -------
    table : DataFrame
        One row per run, channel and output (``raw``, ``compensated``): ``run, channel,
        unit, output, rate_hz``, ``n`` [unit·√s] (angle/velocity random walk: σ at τ = 1 s
        on the −½ line; deg/h·√s ÷ 60 = deg/√h), ``b`` [unit] (bias instability, the flat
        minimum ÷ 0.664) with ``b_tau_s``, ``k`` [unit/√s] (rate random walk: σ at τ = 3 s
        on the +½ line); NaN where the curve has no region of that slope.
    curves : dict
        ``curves[run][channel][output]`` the :class:`~rinscal.calibration.allan.AllanCurve`.
    """
    feats, f, _ = prepared or prepare(log, model, policy, derivative_kind, outliers)
    rows: list[dict[str, object]] = []
    curves: dict[str, dict[str, dict[str, AllanCurve]]] = {}
    for k, run in enumerate(feats.runs):
        r = np.flatnonzero(feats.run_codes == k)
        rate = 1.0 / float(np.median(np.diff(feats.time_s[r])))
        curves[run] = {}
        for j, c in enumerate(model.channels):
            cm = model.models[c]
            y = np.where(feats.inlier[r, j], feats.output[r, j], np.nan)
            comp = y - (f[r, j] - (cm.static_reference or 0.0))
            curves[run][c] = {}
            for label, series in (("raw", y), ("compensated", comp)):
                try:
                    curve = allan_deviation(series, rate)
                except ValueError:  # too few samples for an Allan deviation
                    continue
                p = noise_parameters(curve)
                curves[run][c][label] = curve
                rows.append(
                    {
                        "run": run,
                        "channel": c,
                        "unit": cm.unit or "",
                        "output": label,
                        "rate_hz": rate,
                        "n": np.nan if p.n is None else p.n,
                        "b": np.nan if p.b is None else p.b,
                        "b_tau_s": np.nan if p.b_tau_s is None else p.b_tau_s,
                        "k": np.nan if p.k is None else p.k,
                    }
                )
    return pd.DataFrame(rows), curves

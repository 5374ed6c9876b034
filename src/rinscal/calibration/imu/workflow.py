"""``calibrate_imu``: a multi-position calibration log in, the IMU's calibration over
temperature out (the function behind ``rinscal calibrate-imu``).

The steps: check the units and the site (:func:`calibrate_imu`), cut each run into segments
(:mod:`~rinscal.calibration.imu.segments`), check that every run holds the same sequence and
that it observes every parameter (:mod:`~rinscal.calibration.imu.design`), estimate the
parameters at each set point (:mod:`~rinscal.calibration.imu.estimate`), then each
parameter's law in temperature (:mod:`~rinscal.calibration.imu.laws`).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from rinscal import _check, units
from rinscal._version import __version__
from rinscal.calibration.imu.design import SegmentStats, check_observable, segment_stats
from rinscal.calibration.imu.estimate import BlockEstimate, estimate_block
from rinscal.calibration.imu.laws import Law, fit_law
from rinscal.calibration.imu.segments import TABLE_COLUMNS, Segment, find_segments
from rinscal.calibration.regression import polynomial_fit
from rinscal.errors import ConfigError, DesignError, LogError
from rinscal.io.imucal import IMU_CALIBRATION_FILE_SCHEMA, imu_calibration_file_doc, unit_identity
from rinscal.schema import CHAMBER, CHANNELS, RUN, TIME, temperature_column, unit_factors
from rinscal.sensormodel import PARAMETERS, ImuCalibration

__all__ = ["IMU_CALIBRATION_FILE_SCHEMA", "ImuCalibrationResult", "calibrate_imu"]

_ROWS = "data row numbers are 1-based, header not counted"
#: A fit whose positions disagree more than this (reduced chi-square) gets a warning.
_CHI2_WARN = 4.0


@dataclass(frozen=True)
class ImuCalibrationResult:
    """What :func:`calibrate_imu` returns.

    Attributes
    ----------
    calibration : ImuCalibration
        Every estimated parameter as a law in temperature (and its rate, from a ramp).
    estimates : DataFrame
        The estimate at each set point in the parameter-table format of
        :mod:`rinscal.io.params` (``temperature_c, parameter, value, sd, unit``).
    laws : DataFrame
        One row per parameter: ``parameter, unit, degree, rate_degree, heldout_score,
        value_t0, slope_per_c, rate_coef``; ``heldout_score`` is the leave-one-temperature-out
        RMS error in units of the estimates' sd.
    segments : DataFrame
        The segments used: ``run, kind, number, outer_deg, inner_deg, axis, rate_dps, turns,
        t_start_s, t_end_s, samples``.
    fits : DataFrame
        Per run (or ramp repetition) and channel: ``block, temperature_c, channel, chi2_nu,
        dof, temp_c`` (``temp_c`` the channel's mean inner temperature [°C]).
    warnings : tuple of str
    settings : dict
        The options the fit ran with.
    input_units : dict of str to str or None
        Raw unit of each channel of the log (its metadata's ``units``): a log the calibration
        is applied to must be in the same units.
    input_unit_to_si : dict of str to float
        SI value of one raw unit per channel (the metadata's ``unit_to_si``).
    unit : dict
        The unit's identity as the log's metadata gives it
        (:data:`rinscal.io.imucal.UNIT_KEYS`: ``imu``, ``serial``, ``device_ids``).
    """

    calibration: ImuCalibration
    estimates: pd.DataFrame
    laws: pd.DataFrame
    segments: pd.DataFrame
    fits: pd.DataFrame
    warnings: tuple[str, ...]
    settings: dict[str, Any]
    input_units: dict[str, str | None] = field(default_factory=dict)
    input_unit_to_si: dict[str, float] = field(default_factory=dict)
    unit: dict[str, Any] = field(default_factory=dict)

    def file_dict(self, log: str = "") -> dict[str, Any]:
        """The JSON layout of ``imu.json`` (schema :data:`IMU_CALIBRATION_FILE_SCHEMA`),
        checksummed (:func:`rinscal.io.imucal.imu_calibration_file_doc`).

        Parameters
        ----------
        log : str
            Name of the log the calibration came from.
        """
        laws = [
            {
                k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in r.items()
            }
            for r in self.laws.to_dict("records")
        ]
        return imu_calibration_file_doc(
            {
                "imu_calibration": self.calibration.to_dict(),
                "input": {
                    "units": {c: self.input_units.get(c) for c in CHANNELS},
                    "unit_to_si": {c: self.input_unit_to_si.get(c) for c in CHANNELS},
                },
                "unit": self.unit,
                "laws": laws,
                "log": log,
                "settings": self.settings,
                "generator": f"rinscal calibrate-imu {__version__}",
            }
        )


@dataclass(frozen=True)
class _Block:
    """The segments estimated together: one run, or one repetition of a ramp."""

    name: str
    temperature_c: float
    stats: list[SegmentStats]
    tdot: np.ndarray | None  # [°C/min] per channel (ramp)


def _factors(meta: Mapping[str, Any]) -> tuple[dict[str, str | None], np.ndarray]:
    """Unit and SI per log unit of each channel; a DesignError naming the columns otherwise."""
    try:
        names, factors = unit_factors(meta)
    except ConfigError as exc:
        raise DesignError(f"unknown unit: {exc}") from None
    for sensor, chans in (("gyro", CHANNELS[:3]), ("accel", CHANNELS[3:])):
        got = {c: names[c] for c in chans}
        if len(set(got.values())) > 1:
            listed = ", ".join(f"{c} in {u or 'no unit'}" for c, u in got.items())
            raise DesignError(f"mixed units in the {sensor} triad: {listed}; give one unit")
    none = [c for c in CHANNELS if names[c] is None]
    if none:
        raise DesignError(
            f"the metadata gives no unit for {', '.join(none)} (meta['units']); the fit needs "
            "SI to compare with gravity and the Earth rate"
        )
    pulses = [c for c in CHANNELS if factors[c] is None]
    if pulses:
        raise DesignError(
            f"{', '.join(pulses)} are in {names[pulses[0]]} without a factor to SI "
            "(meta['unit_to_si'][channel]: the pulse weight divided by the sample interval)"
        )
    return dict(names), np.array([factors[c] for c in CHANNELS], dtype=float)


def _site(meta: Mapping[str, Any]) -> tuple[float, float, float]:
    out = []
    for key, default in (("latitude_deg", None), ("heading_deg", None), ("altitude_m", 0.0)):
        v = meta.get(key, default)
        try:
            f = float(v)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            f = math.nan
        if not math.isfinite(f):
            raise ConfigError(
                f"the metadata's {key!r} is {v!r}: the fit needs the site's latitude [deg], the "
                "outer axis' azimuth heading_deg [deg from north] and altitude_m [m]"
            )
        out.append(f)
    return out[0] * units.DEG_TO_RAD, out[1] * units.DEG_TO_RAD, out[2]


def _numeric(df: pd.DataFrame, col: str, run: str) -> np.ndarray:
    """A column of one run as floats; a LogError naming the run, the column and the data row
    (counted from the log's start, as every reader counts them) of its first bad value."""
    v = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(v))
    if bad.size:
        raw = df[col].iloc[bad[0]]
        missing = raw is None or (
            raw.strip().lower() in ("", "nan", "+nan", "-nan")
            if isinstance(raw, str)
            else isinstance(raw, float | np.floating) and np.isnan(raw)
        )
        if missing:
            what = "missing value (NaN or empty cell)"
        elif isinstance(raw, str):
            what = f"non-numeric value {raw!r}"
        else:
            what = f"value {float(raw) if isinstance(raw, np.number) else raw}"
        raise LogError(
            f"run {run}, column {col!r}, data row {int(df.index[bad[0]]) + 1}: {what}; the "
            f"fit needs a finite number in every row ({_ROWS})"
        )
    return v


def _looks_like_radians(table: np.ndarray, run: str) -> None:
    """Refuse turntable angles that look like radians: every position's angles within ±2π
    and none a whole degree (a degree design has positions such as 90° and 180°; a rate
    test's angle may run over several turns, so only the positions count)."""
    static = (table[:, 2] == 0) & (table[:, 3] == 0)
    held = np.abs(table[static, :2]).ravel()
    held = held[held > 1e-9]
    if not held.size or held.max() > 2 * np.pi + 1e-6:
        return
    if np.any(np.abs(held - np.round(held)) < 1e-6):
        return  # a whole degree among the positions: degrees
    rates = np.abs(table[:, 2:]).max()
    shown = ", ".join(f"{v:.4g}" for v in np.unique(np.round(held, 4))[:4])
    raise DesignError(
        f"run {run}: the angles of {TABLE_COLUMNS[0]} and {TABLE_COLUMNS[1]} look like radians "
        f"(every position within ±2π, at {shown}, none a whole degree); the "
        "turntable columns must be in degrees"
        + (
            f", and their rates in deg/s ({TABLE_COLUMNS[2]}, {TABLE_COLUMNS[3]} reach "
            f"{rates:.4g}: {np.degrees(rates):.4g} °/s if that was rad/s)"
            if rates > 0
            else ""
        )
    )


def _run_stats(
    df: pd.DataFrame,
    run: str,
    factors: np.ndarray,
    site: tuple[float, float, float],
    settle_s: float,
    min_samples: int,
    notes: list[str],
) -> tuple[list[SegmentStats], np.ndarray, np.ndarray]:
    """Segments of one run with their means; also the run's times and temperatures."""
    y = df[list(CHANNELS)].to_numpy(dtype=float)
    good = np.isfinite(y).all(axis=1)
    if not good.all():
        notes.append(f"run {run}: {int((~good).sum())} sample(s) with a missing output left out")
        df, y = df[good], y[good]
    t = _numeric(df, TIME, run)
    table = np.stack([_numeric(df, c, run) for c in TABLE_COLUMNS], axis=1)
    _looks_like_radians(table, run)
    temps = np.stack([_numeric(df, temperature_column(df, c), run) for c in CHANNELS], axis=1)
    split = find_segments(run, t, table, settle_s=settle_s, min_samples=min_samples)
    if split.short and not any(s.kind == "static" for s in split.segments):
        dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        fix = (
            f"use a settle time of at most {split.short_settle_max_s:.3g} s (settle_s=), or "
            if split.short_settle_max_s is not None
            else ""
        )
        raise DesignError(
            f"run {run}: no static position is left: each of its {split.short} stops is "
            f"shorter than the settle time cut from its start ({settle_s:g} s, settle_s=) plus "
            f"{min_samples} samples (the longest stop lasts {split.short_longest_s:.3g} s); "
            f"{fix}dwell at least {settle_s + min_samples * dt:.3g} s at each position "
            "(rinscal simulate multiposition --dwell)"
        )
    if split.short:
        notes.append(
            f"run {run}: {split.short} stop(s) shorter than {min_samples} samples after the "
            f"settle time of {settle_s:g} s left out"
        )
    stats = [segment_stats(s, t, table, y * factors, temps, site) for s in split.segments]
    return stats, t, temps


def _check_sequences(runs: dict[str, list[SegmentStats]]) -> None:
    """Every run must hold the same sequence; name the runs that differ and how."""
    sigs = {r: tuple(s.segment.signature for s in st) for r, st in runs.items()}
    empty = [r for r, s in sigs.items() if not s]
    if empty:
        raise DesignError(
            f"run(s) {', '.join(empty)}: no static position or whole-revolution rate segment "
            "(check the turntable columns and the settle time)"
        )
    common, _ = Counter(sigs.values()).most_common(1)[0]
    odd = [r for r, s in sigs.items() if s != common]
    if not odd:
        return
    ref = next(r for r, s in sigs.items() if s == common)
    parts = []
    for r in odd:
        st = runs[r]
        missing = Counter(common) - Counter(sigs[r])
        extra = Counter(sigs[r]) - Counter(common)
        what = []
        if missing:
            refs = {s.segment.signature: s.segment for s in runs[ref]}
            what.append("lacks " + ", ".join(_sig_text(refs[k]) for k in list(missing)[:4]))
        if extra:
            have = {s.segment.signature: s.segment for s in st}
            what.append("has extra " + ", ".join(_sig_text(have[k]) for k in list(extra)[:4]))
        if not what:
            what.append("holds the segments in another order")
        parts.append(f"run {r} {' and '.join(what)}")
    raise DesignError(
        f"the runs' sequences differ (each set point must repeat the sequence of run {ref}): "
        + "; ".join(parts)
    )


def _sig_text(seg: Segment) -> str:
    if seg.kind == "static":
        return f"position (outer {seg.outer_deg:g}°, inner {seg.inner_deg:g}°)"
    return f"rate test ({seg.axis} axis at {seg.rate_dps:+g} °/s)"


def _repetitions(stats: list[SegmentStats], run: str, notes: list[str]) -> list[list[SegmentStats]]:
    """Split a ramp run's segments into repetitions of its sequence."""
    sigs = [s.segment.signature for s in stats]
    n = len(sigs)
    for p in range(1, n + 1):
        if all(sigs[k] == sigs[k % p] for k in range(n)):
            break
    reps = n // p
    if n % p:
        notes.append(
            f"run {run}: the last repetition of the sequence is incomplete "
            f"({n % p} of {p} segments) and is left out"
        )
    return [stats[k * p : (k + 1) * p] for k in range(reps)]


def _tdot(t: np.ndarray, temps: np.ndarray, seg_stats: list[SegmentStats]) -> np.ndarray:
    """Temperature rate of each channel over a repetition [°C/min]."""
    a, b = seg_stats[0].segment.start, seg_stats[-1].segment.stop
    tt = t[a:b] - t[a]
    slope = polynomial_fit(tt, temps[a:b], 1)[0]
    return np.asarray(slope, dtype=float) * units.MIN_TO_S


def _blocks(
    log: pd.DataFrame,
    meta: Mapping[str, Any],
    factors: np.ndarray,
    site: tuple[float, float, float],
    settle_s: float,
    min_samples: int,
    notes: list[str],
) -> tuple[list[_Block], bool]:
    """The blocks to estimate, and whether the log is a ramp."""
    order = list(dict.fromkeys(log[RUN].astype(str)))
    set_points = meta.get("set_points_c")
    ramp = isinstance(set_points, Mapping) and not set_points
    if isinstance(set_points, Mapping) and set_points:
        absent = [str(r) for r in set_points if str(r) not in order]
        if absent:
            listed = ", ".join(f"{set_points[r]} °C (run {r})" for r in absent)
            raise DesignError(f"set point(s) of the metadata with no rows in the log: {listed}")
        extra = [r for r in order if r not in set_points]
        if extra:
            notes.append(f"run(s) {', '.join(extra)} not in the metadata's set_points_c: left out")
        order = [r for r in order if r in set_points]
    if ramp and len(order) != 1:
        raise DesignError(
            f"a ramp calibration (set_points_c empty) is one run; the log has {len(order)}: "
            + ", ".join(order)
        )
    groups = log.groupby(log[RUN].astype(str), sort=False)
    per_run = {}
    extras = {}
    for r in order:
        stats, t, temps = _run_stats(
            groups.get_group(r), r, factors, site, settle_s, min_samples, notes
        )
        per_run[r] = stats
        extras[r] = (t, temps, groups.get_group(r))
    if ramp:
        r = order[0]
        t, temps, df = extras[r]
        if not per_run[r]:
            _check_sequences(per_run)
        blocks = []
        chamber = (
            pd.to_numeric(df[CHAMBER], errors="coerce").to_numpy(float) if CHAMBER in df else None
        )
        for k, rep in enumerate(_repetitions(per_run[r], r, notes)):
            rows = np.concatenate([np.arange(s.segment.start, s.segment.stop) for s in rep])
            temp = (
                float(np.nanmean(chamber[rows]))
                if chamber is not None
                else float(np.mean(temps[rows]))
            )
            blocks.append(
                _Block(f"run {r} repetition {k + 1}", round(temp, 3), rep, _tdot(t, temps, rep))
            )
        return blocks, True
    _check_sequences(per_run)
    blocks = []
    for r in order:
        if isinstance(set_points, Mapping) and set_points:
            temp = float(set_points[r])
        else:
            df = extras[r][2]
            col = CHAMBER if CHAMBER in df else None
            temp = round(
                float(pd.to_numeric(df[col], errors="coerce").mean())
                if col
                else float(extras[r][1].mean()),
                3,
            )
        blocks.append(_Block(f"run {r}", temp, per_run[r], None))
    return blocks, False


def calibrate_imu(
    log: pd.DataFrame,
    meta: Mapping[str, Any],
    *,
    settle_s: float = 5.0,
    nonlinear: bool = True,
    max_degree: int = 3,
    motion_sigma: float = 10.0,
    scatter_limit: float = 5.0,
    min_samples: int = 10,
) -> ImuCalibrationResult:
    """Calibrate an IMU's scale factors, misalignments, nonlinear terms and biases over
    temperature from a multi-position log on a two-axis turntable.

    Parameters
    ----------
    log : DataFrame
        A canonical calibration log with the turntable's commanded columns
        (``table_outer_deg, table_inner_deg`` [deg] at ``time_s``,
        ``table_outer_rate_dps, table_inner_rate_dps`` [deg/s]), one run per chamber set point
        (or one run along a ramp, the sequence repeated).
    meta : mapping
        Its metadata: ``units`` and ``unit_to_si`` per channel (pulses: the pulse weight
        over the sample interval), ``latitude_deg`` [deg], ``heading_deg`` (azimuth of the
        outer axis) [deg], ``altitude_m`` [m], ``set_points_c`` ({run: set point [°C]}; ``{}``
        for a ramp; absent: each run's mean chamber temperature).
    settle_s : float [s]
        Time dropped after each change of the table's commanded state.
    nonlinear : bool
        Estimate the gyros' asymmetry and quadratic terms and the accelerometers' quadratic
        term (they need rate tests at two or more rates of both signs about each axis);
        ``False`` leaves them at zero.
    max_degree : int
        Highest degree of a law in temperature, 0-3 (0 for one set point).
    motion_sigma : float
        A position whose deleted residual exceeds this many robust residual scales is
        refused as not static.
    scatter_limit : float
        A position whose within-segment scatter exceeds this many times the positions'
        median is refused as not static.
    min_samples : int
        Fewest samples a position keeps after the settle time.

    Returns
    -------
    ImuCalibrationResult

    Raises
    ------
    DesignError
        A parameter the design does not observe, a position that was not static, a set point
        with no rows, too few set points for a law, runs with different sequences, mixed or
        unknown units.
    LogError
        A missing or non-numeric column.
    ConfigError
        The metadata lacks the site.
    """
    log = _check.log_table("log", log, validate=False)
    log = log.reset_index(drop=True)  # row labels: data rows from the log's start, 0-based
    meta = _check.mapping("meta", meta)
    for name, v in (
        ("settle_s", settle_s),
        ("motion_sigma", motion_sigma),
        ("scatter_limit", scatter_limit),
    ):
        _check.number(name, v)
    _check.number("max_degree", max_degree, integer=True, min=0, max=3)  # as --max-degree
    _check.number("min_samples", min_samples, integer=True, min=1)
    _check.flag("nonlinear", nonlinear)
    missing = [c for c in (TIME, RUN, *CHANNELS, *TABLE_COLUMNS) if c not in log.columns]
    if missing:
        raise LogError(
            f"missing column(s) {', '.join(missing)}: a multi-position log has the turntable's "
            f"commanded {', '.join(TABLE_COLUMNS)}"
        )
    if not (settle_s >= 0 and max_degree >= 0 and motion_sigma > 0 and scatter_limit > 1):
        raise ConfigError(
            "calibrate_imu: settle_s >= 0, max_degree >= 0, motion_sigma > 0 and "
            f"scatter_limit > 1 (got {settle_s}, {max_degree}, {motion_sigma}, {scatter_limit})"
        )
    unit_names, factors = _factors(meta)
    site = _site(meta)
    notes: list[str] = []
    blocks, ramp = _blocks(log, meta, factors, site, settle_s, min_samples, notes)
    if max_degree > 0 and len(blocks) < 2:
        what = "repetition of the sequence" if ramp else "set point"
        raise DesignError(
            f"a temperature law needs at least two set points; the log has one {what} "
            f"({blocks[0].name if blocks else 'none'}); for a calibration at one temperature "
            "ask for max_degree=0"
        )
    estimates: list[BlockEstimate] = []
    for b in blocks:
        check_observable(b.stats, nonlinear, b.name)
        estimates.append(
            estimate_block(
                b.stats,
                b.name,
                nonlinear=nonlinear,
                motion_sigma=motion_sigma,
                scatter_limit=scatter_limit,
            )
        )
    names = [p for p in PARAMETERS if p.name in estimates[0].values]
    rows = [
        (b.temperature_c, p.name, e.values[p.name], e.sds[p.name], p.unit)
        for b, e in zip(blocks, estimates, strict=True)
        for p in names
    ]
    table = pd.DataFrame(rows, columns=["temperature_c", "parameter", "value", "sd", "unit"])
    temps = np.array([e.temp for e in estimates])  # (blocks, 6)
    t0 = float(temps.mean())
    t_range = (float(temps.min()), float(temps.max()))
    tdots = np.array([b.tdot for b in blocks]) if ramp else None
    laws: dict[str, Law] = {}
    for p in names:
        c = p.channel
        laws[p.name] = fit_law(
            temps[:, c],
            np.array([e.values[p.name] for e in estimates]),
            np.array([e.sds[p.name] for e in estimates]),
            t0,
            max_degree,
            None if tdots is None else tdots[:, c],
        )
    laws_df = pd.DataFrame(
        [
            {
                "parameter": p.name,
                "unit": p.unit,
                "degree": laws[p.name].degree,
                "rate_degree": laws[p.name].rate_degree,
                "heldout_score": laws[p.name].heldout_score,
                "value_t0": laws[p.name].t_coefs[0],
                "slope_per_c": laws[p.name].t_coefs[1] if laws[p.name].degree >= 1 else 0.0,
                "rate_coef": laws[p.name].rate_coefs[0] if laws[p.name].rate_coefs else 0.0,
            }
            for p in names
        ]
    )
    source = str(meta.get("log", "")) or "a multi-position log"
    calibration = ImuCalibration(
        t0_c=t0,
        t_range_c=t_range,
        t_coefs={n: law.t_coefs for n, law in laws.items()},
        rate_coefs={n: law.rate_coefs for n, law in laws.items() if law.rate_coefs},
        source=f"rinscal calibrate-imu of {source}",
    )
    seg_rows = [
        {
            "run": s.segment.run,
            "kind": s.segment.kind,
            "number": s.segment.number,
            "outer_deg": s.segment.outer_deg,
            "inner_deg": s.segment.inner_deg,
            "axis": s.segment.axis or "",
            "rate_dps": s.segment.rate_dps,
            "turns": s.segment.turns,
            "t_start_s": s.segment.t_start_s,
            "t_end_s": s.segment.t_end_s,
            "samples": s.segment.n,
        }
        for b in blocks
        for s in b.stats
    ]
    fit_rows = []
    for b, e in zip(blocks, estimates, strict=True):
        for c, ch in enumerate(CHANNELS):
            fit_rows.append(
                {
                    "block": b.name,
                    "temperature_c": b.temperature_c,
                    "channel": ch,
                    "chi2_nu": e.chi2_nu[ch],
                    "dof": e.dof[ch],
                    "temp_c": float(e.temp[c]),
                }
            )
            if e.dof[ch] >= 5 and e.chi2_nu[ch] > _CHI2_WARN:
                notes.append(
                    f"{b.name}, {ch}: the segments disagree {math.sqrt(e.chi2_nu[ch]):.1f}× "
                    "beyond their own noise (turntable errors, drift?); the sds include it"
                )
    settings = {
        "settle_s": settle_s,
        "nonlinear": nonlinear,
        "max_degree": max_degree,
        "motion_sigma": motion_sigma,
        "scatter_limit": scatter_limit,
        "min_samples": min_samples,
        "ramp": ramp,
    }
    return ImuCalibrationResult(
        calibration=calibration,
        estimates=table,
        laws=laws_df,
        segments=pd.DataFrame(seg_rows),
        fits=pd.DataFrame(fit_rows),
        warnings=tuple(notes),
        settings=settings,
        input_units={c: unit_names[c] for c in CHANNELS},
        input_unit_to_si={c: float(k) for c, k in zip(CHANNELS, factors, strict=True)},
        unit=unit_identity(meta),
    )

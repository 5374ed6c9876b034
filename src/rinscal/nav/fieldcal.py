r"""Thermal calibration without a chamber: a RINS calibrated from its own parked cold starts.

Each recording is a parked cold start at a known site: the unit powers on at rest, the
turntable indexes through its positions, and the IMU output, the encoder angle and the
temperatures are recorded. :func:`rinscal.nav.fieldbias.estimate_bias_series` turns each
into the bias of every channel over time with its sd (the engine's static aiding and a
smoother; heading and tilt estimated, nothing read from a reference). Those series, from
power-on, become a calibration log (one run per start, the channels in deg/h and µg, no
static reference: the series *are* the errors), and the thermal models are fitted on it with
the same fitters and held-out choice as ``fit`` (leave one start out), into the same model
file, so ``compensate``, ``navigate``, ``export`` and the study use it unchanged. The default
form is method 2's order in ``T`` with ``Ṫ`` and ``ΔT`` to first order
(:data:`FIELD_MAX_ORDER`: every start warms the same way, so their powers would only fit the
warm-up's shape in time).

Before the fit, :func:`rinscal.calibration.observability.observability` measures what the
starts determine of each channel's terms (``T``, its curvature, ``Ṫ``, ``ΔT``) and with
what sd; a term they do not determine is left out of that channel's model (the fallback):
the ``ΔT`` terms by fitting it without the gradient, the ``Ṫ`` terms by polynomials in
``T`` alone (the level and curvature in ``T`` are reported; the held-out choice decides the
degree).
"""

from __future__ import annotations

import math
import os
import threading
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal import _check, units
from rinscal.calibration.modelfile import FittedModel
from rinscal.calibration.observability import (
    TermObservability,
    observability,
    observability_table,
    undetermined,
)
from rinscal.calibration.thermal.features import build_features
from rinscal.calibration.thermal.model import DEFAULTS
from rinscal.calibration.workflow import FitResult, fit
from rinscal.errors import ConfigError, LogError
from rinscal.imunoise import NoiseSource, load_noise
from rinscal.io.navopen import nav_log_header, open_nav_log
from rinscal.nav.fieldbias import BiasSeries, estimate_bias_series, field_noise
from rinscal.nav.gnss_ins import ImuNoise
from rinscal.nav.recorded.kind import calibration_log
from rinscal.parallel import map_jobs
from rinscal.schema import CHANNELS, sensor_type

__all__ = [
    "DEFAULT_TURN_ON",
    "FIELD_MAX_ORDER",
    "FIELD_UNITS",
    "FieldCalibration",
    "calibrate_field",
    "calibrate_field_series",
    "field_noise_of",
    "field_orders",
    "series_log",
]

#: Units of the calibration log built from the series (and of the model file).
FIELD_UNITS: dict[str, str] = {c: ("deg/h" if c.startswith("gyro") else "ug") for c in CHANNELS}
_TO_SI = {"deg/h": units.DPH_TO_RPS, "ug": units.UG_TO_MPS2}
#: Turn-on repeatability assumed when neither the recording nor ``imu=`` gives it, 1σ
#: (gyros [deg/h], accelerometers [µg]): broad, so the level comes from the data.
DEFAULT_TURN_ON: tuple[float, float] = (0.05, 50.0)
#: Spacing of the calibration log's rows [s] (the series vary on thermal time scales).
LOG_STEP_S = 10.0


def series_log(
    series: Mapping[str, BiasSeries], step_s: float = LOG_STEP_S
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The calibration log of a set of bias series, and its metadata.

    Each start is a run (its name the key); its rows every ``step_s`` from the series' start
    (power-on, where the table stood still through the coarse alignment): ``time_s`` [s since
    power-on], ``run``, the six channels' bias in deg/h and µg, ``temp_<channel>`` and
    ``temp_out`` [°C] (left out where the recording has no outer temperature). Every
    channel from the start: before the table first reverses, a horizontal bias is told from
    the tilt only through the smoother, which carries the tilt (constant on a static base)
    back from the later positions; the fastest part of the warm-up, right after power-on,
    is what a thermal model most needs to see (measured: docs/navigation.md).

    Returns
    -------
    DataFrame, dict
        The log and its metadata (units, their SI factors, a zero static reference).
    """
    parts = []
    for name, s in series.items():
        if s.t.size < 2:
            raise ConfigError(f"start {name!r}: too short to estimate its biases")
        if not math.isfinite(s.first_period_s):
            raise ConfigError(
                f"start {name!r}: the table never completed a rotation period (the recording "
                f"is {float(s.t[-1]):g} s long): its biases cannot be told from heading and tilt"
            )
        epoch = float(np.median(np.diff(s.t)))
        k = max(1, round(step_s / epoch))
        keep = np.arange(0, s.t.size, k)
        df = pd.DataFrame({"time_s": s.t[keep], "run": name})
        for j, c in enumerate(CHANNELS):
            df[c] = s.bias[keep, j] / _TO_SI[FIELD_UNITS[c]]
        for j, c in enumerate(CHANNELS):
            df[f"temp_{c}"] = s.temps[keep, j]
        if np.all(np.isfinite(s.temp_out[keep])):
            df["temp_out"] = s.temp_out[keep]
        parts.append(df)
    log = pd.concat(parts, ignore_index=True)
    if "temp_out" in log.columns and log["temp_out"].isna().any():
        log = log.drop(columns="temp_out")  # some start without: the gradient for none
    meta = {
        "protocol": "field",
        "units": dict(FIELD_UNITS),
        "unit_to_si": {c: _TO_SI[FIELD_UNITS[c]] for c in CHANNELS},
        "static_reference": dict.fromkeys(CHANNELS, 0.0),
    }
    return log, meta


@dataclass(frozen=True)
class FieldCalibration:
    """A thermal model calibrated from parked cold starts, and what the starts determined.

    Attributes
    ----------
    model : FittedModel
        The model file (save it with ``.save(path)``), as ``fit`` writes.
    table : DataFrame
        The fit's table (as ``fit``'s: one row per channel, the chosen model and its
        training and held-out RMS), each channel's row from the fit of its inputs, and
        ``inputs``: the inputs it was allowed (``T, Tdot, dT`` unless it fell back).
    warnings : tuple of str
        What the fits warned of.
    observability : list of TermObservability
        Per channel and term: coefficient, sd, effect sd, determined or why not.
    fallback : dict
        Channel → what its model was restricted to (``"T, Tdot"`` …), for the channels
        restricted.
    series : dict
        Start name → :class:`~rinscal.nav.fieldbias.BiasSeries`.
    log : DataFrame
        The calibration log the model was fitted on (:func:`series_log`).
    notes : tuple of str
        What the user should know, in words.
    """

    model: FittedModel
    table: pd.DataFrame
    warnings: tuple[str, ...]
    observability: list[TermObservability]
    fallback: dict[str, str]
    series: dict[str, BiasSeries] = field(repr=False)
    log: pd.DataFrame = field(repr=False)
    notes: tuple[str, ...] = ()

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model file (JSON, atomically); returns its path."""
        return self.model.save(path)

    def observability_table(self) -> pd.DataFrame:
        """The observability report, one row per channel and term."""
        return observability_table(self.observability)

    def report(self) -> dict[str, Any]:
        """JSON-able: the starts, the observability per channel and term, the fallbacks."""
        starts = {
            name: {
                "duration_s": float(s.t[-1] - s.t[0]),
                "first_period_s": float(s.first_period_s),
                "temp_range_c": [float(np.nanmin(s.temps)), float(np.nanmax(s.temps))],
                "median_sd_si": [float(v) for v in np.median(s.sd, axis=0)],
            }
            for name, s in self.series.items()
        }
        tab = self.observability_table()
        return {
            "starts": starts,
            "observability": tab.to_dict(orient="records"),
            "fallback": dict(self.fallback),
            "notes": list(self.notes),
        }


#: Highest order of ``Ṫ`` and of ``ΔT`` in a field model of fixed orders (``regression``,
#: ``sectional``; ``T`` keeps the method's order for the sensor). Every parked start warms
#: the unit the same way, so ``Ṫ`` and ``ΔT`` follow much the same curve in time in every
#: start: their squares and cubes are further functions of the time since power-on, which
#: fit the warm-up's shape in the series rather than a dependence on the inputs, and which
#: the observability report does not examine (it judges first-order terms). Navigation
#: compensates with the causal rate of the thermometers, which lags that shape by half its
#: window in the first minutes; a cubic in ``Ṫ`` turns the lag into an error at alignment.
#: Measured (docs/navigation.md), mean over three cold starts per plant: method 2's cubic
#: form moved the alignment heading by +36″ (``paper``) and +107″ (``paper_mechanistic``)
#: from the true bias's, first order in ``Ṫ`` and ``ΔT`` by +7″ and −24″ (the chamber's
#: method 2: −28″ and +31″).
FIELD_MAX_ORDER = 1

#: Inputs a channel may keep, most to fewest, and how each is fitted.
_GROUPS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("T, Tdot, dT", {"gradient": True}),
    ("T, Tdot", {"gradient": False}),
    ("T", {"gradient": False, "candidates": ("none", "poly-t")}),
)


def field_orders(method: str, channel: str, gradient: bool) -> tuple[int, ...] | None:
    """The orders a field model of ``method`` fits for ``channel``: the method's own for
    ``T``, at most :data:`FIELD_MAX_ORDER` for ``Ṫ`` and ``ΔT`` (``gradient``: with ``ΔT``);
    None for a method without orders (``auto`` chooses its own, ``neural``, ``poly-t``)."""
    if method not in ("regression", "sectional"):
        return None
    d = DEFAULTS[method][sensor_type(channel)]
    orders = [d["t_order"], min(d["rate_order"], FIELD_MAX_ORDER)]
    if method == "regression":
        orders.append(min(d["grad_order"], FIELD_MAX_ORDER) if gradient else 0)
    return tuple(orders)


def _group_of(missing: set[str], has_gradient: bool) -> str:
    """The richest input group a channel may use given its undetermined terms."""
    if "Tdot" in missing:
        return "T"
    if "dT" in missing or not has_gradient:
        return "T, Tdot"
    return "T, Tdot, dT"


def calibrate_field_series(
    series: Mapping[str, BiasSeries],
    *,
    method: str = "regression",
    turn_on_sd: Sequence[float] | None = None,
    span_c: tuple[float, float] | None = None,
    seed: int = 0,
    source: Mapping[str, Any] | None = None,
) -> FieldCalibration:
    """Fit the thermal models on the bias series of parked cold starts (no I/O).

    Parameters
    ----------
    series : mapping
        Start name → its :class:`~rinscal.nav.fieldbias.BiasSeries` (at least three starts
        for the held-out choice and the jackknife over starts).
    method : str
        As :func:`rinscal.fit`'s (``regression``, ``auto``, ``poly-t`` …); ``regression``
        and ``sectional`` at the orders of :func:`field_orders` (first order in ``Ṫ`` and
        ``ΔT``); ``auto`` chooses among every order on the series. A channel whose starts do
        not determine a term is fitted without it.
    turn_on_sd : sequence of 6 float, optional [deg/h ×3, µg ×3]
        The unit's turn-on repeatability: the floor below which a term's effect sd counts
        as determined (a thermal model cannot beat it). Default :data:`DEFAULT_TURN_ON`.
    span_c : (float, float), optional [°C]
        The inner temperatures the model must cover (default the starts' own).
    seed : int
        Seed of a neural fit.
    source : mapping, optional
        Provenance written into the model file's ``source``.

    Returns
    -------
    FieldCalibration
    """
    _check.mapping("series", series)
    if len(series) < 3:
        raise ConfigError(
            f"calibrate_field: {len(series)} start(s) given; at least 3 are needed (each is "
            "left out in turn to choose and to judge the model)"
        )
    log, meta = series_log(series)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        feats = build_features(log)
    obs = observability(feats, span_c=span_c)
    floor = np.repeat(DEFAULT_TURN_ON, 3) if turn_on_sd is None else np.asarray(turn_on_sd)
    obs = [_with_floor(o, float(floor[CHANNELS.index(o.channel)])) for o in obs]
    missing = {c: {o.term for o in obs if o.channel == c and not o.determined} for c in CHANNELS}
    group = {c: _group_of(missing[c], feats.has_gradient) for c in CHANNELS}
    fallback = {c: g for c, g in group.items() if g != "T, Tdot, dT"}
    fits: dict[tuple[str, tuple[int, ...] | None], FitResult] = {}
    used: dict[str, tuple[str, tuple[int, ...] | None]] = {}
    for name, opts in _GROUPS:
        # the series are smoothed estimates: their warm-up is no spike to screen out
        m, kw = method, {"gradient": opts["gradient"], "seed": seed, "screen_outliers": False}
        if "candidates" in opts and method not in ("poly-t", "none"):  # T alone: auto's
            m, kw["candidates"] = "auto", opts["candidates"]
        for c in [c for c in CHANNELS if group[c] == name]:
            used[c] = (name, field_orders(m, c, opts["gradient"]))
            if used[c] not in fits:
                # every channel is fitted (the fit is over 10 s rows: seconds); the
                # channels of this group and orders are kept
                fits[used[c]] = fit(log, m, meta=meta, orders=used[c][1], **kw)
    model = _merge(fits, used, source)
    notes = _notes(obs, fallback, series)
    rows = []
    for c in CHANNELS:
        tab = fits[used[c]].table
        rows.append(tab[tab["channel"] == c].assign(inputs=group[c]))
    table = pd.concat(rows, ignore_index=True)
    said = tuple(dict.fromkeys(w for f in fits.values() for w in f.warnings))
    return FieldCalibration(model, table, said, obs, fallback, dict(series), log, tuple(notes))


def _with_floor(o: TermObservability, floor: float) -> TermObservability:
    """The report's verdict with the turn-on floor: a term whose effect sd is below the
    unit's turn-on repeatability is determined as well as any thermal model can be."""
    if o.determined or not o.effect_sd <= floor or "collinear" in o.why:
        return o
    return replace(o, determined=True, why="")


def _merge(
    fits: Mapping[Any, FitResult], used: Mapping[str, Any], source: Mapping[str, Any] | None
) -> FittedModel:
    """One model file from the fits of the input groups and orders, each channel from the
    fit it ``used``."""
    use_gradient = any(f.model.use_gradient for f in fits.values())
    base = next((f.model for f in fits.values() if f.model.use_gradient), None)
    base = base or next(iter(fits.values())).model
    models = {c: fits[used[c]].model.models[c] for c in CHANNELS}
    src = dict(base.source) | {"protocol": "field"} | dict(source or {})
    return replace(base, models=models, use_gradient=use_gradient, source=src)


def _notes(
    obs: Sequence[TermObservability], fallback: Mapping[str, str], series: Mapping[str, BiasSeries]
) -> list[str]:
    """What the report says in words."""
    out = []
    for term, chans in undetermined(obs).items():
        what = {"T": "the level in T", "T2": "the curvature in T", "Tdot": "the Ṫ terms",
                "dT": "the ΔT terms"}[term]  # fmt: skip
        out.append(f"{what}: not determined by these starts for {', '.join(chans)}")
    for c, g in fallback.items():
        out.append(f"{c}: fitted on {g} only (the fallback)")
    temps = np.concatenate([s.temps[np.isfinite(s.temps)] for s in series.values()])
    if temps.size:
        out.append(
            f"the starts cover inner temperatures {temps.min():.1f} … {temps.max():.1f} °C; "
            "outside, the model is held at its edge (policy clamp) or falls back"
        )
    return out


def calibrate_field(
    runs: Sequence[str | os.PathLike[str]],
    *,
    site: tuple[float, float, float] | None = None,
    mapping: Any = None,
    method: str = "regression",
    imu: str | os.PathLike[str] | NoiseSource | None = None,
    span_c: tuple[float, float] | None = None,
    step_s: float = 1.0,
    seed: int = 0,
    progress: Callable[[float, float], None] | None = None,
    n_jobs: int | None = None,
) -> FieldCalibration:
    """Calibrate the thermal model of a RINS from recordings of its parked cold starts.

    Parameters
    ----------
    runs : sequence of path-like
        Recordings in the recorded-navigation format (``navigate --log``'s; a foreign layout
        through ``mapping``), one parked cold start each, at least three.
    site : (lat [rad], lon [rad], height [m]), optional
        The static site; default each recording's metadata.
    mapping : ColumnMapping, optional
        How to read a foreign file.
    method : str
        The thermal model, as ``fit``'s; default ``regression``: method 2's order in ``T``
        and first order in ``Ṫ`` and ``ΔT`` (:func:`field_orders`).
    imu : str, path-like or ImuConfig, optional
        The IMU whose noise and turn-on repeatability the filter assumes; default each
        recording's metadata ``noise``, with :data:`DEFAULT_TURN_ON` where it gives none.
    span_c : (float, float), optional [°C]
        The inner temperatures the model must cover (the observability report).
    step_s : float [s]
        Filter step.
    seed : int
        Seed of a neural fit.
    progress : callable, optional
        ``progress(done, total)``: recordings estimated (from the threads that estimate them,
        one call at a time).
    n_jobs : int or None
        Threads the recordings' bias series are estimated on, side by side (None or 0: every
        core; :func:`rinscal.parallel.map_jobs`). The result is the same whatever the number.

    Returns
    -------
    FieldCalibration
    """
    _check.instance("runs", runs, (list, tuple), "a list of recordings' paths")
    for k, p in enumerate(runs):
        _check.path_like(f"runs[{k}]", p)
    _check.numbers_of("site", site, length=3, optional=True)
    _check.number("step_s", step_s, above=0.0, unit="s")
    _check.callback("progress", progress)
    _check.number("n_jobs", n_jobs, min=0, integer=True, optional=True)
    names = [Path(p).stem for p in runs]
    if len(set(names)) != len(names):
        raise ConfigError(f"calibrate_field: two recordings share a name: {names}")
    todo = []  # every recording checked before any is estimated
    turn_on = None
    for path in runs:
        header = nav_log_header(path, mapping)
        cal, _ = calibration_log(path, header.columns, header.meta, header.runs)
        if cal is not None:  # as navigate names it, before its units are read
            raise LogError(
                f"{cal.text}: calibrate-field learns from parked cold starts (the RINS at rest "
                "from power-on, its table indexing, recorded as navigate --log reads). Fit a "
                f"thermal calibration log with `rinscal fit {path} --out M.json`"
            )
        if header.runs and len(header.runs) > 1:
            raise LogError(f"{path}: holds several runs ({', '.join(header.runs)}); give one each")
        log = open_nav_log(path, mapping)
        where = log.site if site is None else site
        if where is None:
            raise ConfigError(
                f"{path}: where was it recorded? Give the site (site=: latitude, longitude, "
                "height), or a site in its metadata"
            )
        if not log.has_temps:
            raise ConfigError(f"{path}: a parked start needs the sensor temperatures (temp_*)")
        noise, turn_on = _field_noise(path, log.noise, imu)
        lat, lon, h = (float(v) for v in where)
        todo.append((log, (lat, lon, h), noise))
    lock, done = threading.Lock(), [0]

    def estimate(job: tuple[Any, tuple[float, float, float], ImuNoise]) -> BiasSeries:
        log, where, noise = job
        out = estimate_bias_series(log.pieces(), site=where, noise=noise, step_s=step_s)
        if progress is not None:
            with lock:
                done[0] += 1
                progress(done[0], len(runs))
        return out

    series = dict(zip(names, map_jobs(estimate, todo, n_jobs), strict=True))
    to_log = None
    if turn_on is not None:
        to_log = [turn_on[0] / units.DPH_TO_RPS] * 3 + [turn_on[1] / units.UG_TO_MPS2] * 3
    return calibrate_field_series(
        series,
        method=method,
        turn_on_sd=to_log,
        span_c=span_c,
        seed=seed,
        source={"log": [str(p) for p in runs]},
    )


def field_noise_of(path: Any, meta: Mapping[str, Any] | None, imu: Any = None) -> ImuNoise:
    """The field filter's noise for a recording ``path`` from its metadata ``noise`` (or the
    IMU ``imu``: a preset, TOML file or ``ImuConfig``), as :func:`calibrate_field` uses."""
    return _field_noise(path, meta, imu)[0]


def _field_noise(
    path: Any, meta: Mapping[str, Any] | None, imu: Any
) -> tuple[ImuNoise, tuple[float, float]]:
    """The filter's noise and the turn-on repeatability (gyro [rad/s], accel [m/s²])."""
    if imu is not None:
        cfg = load_noise(imu) if isinstance(imu, str | os.PathLike) else imu.noise
        wd, rw, on = cfg.white_density_si(), cfg.bias_rw_si(), cfg.turn_on_sd_si()
        gyro_on, accel_on = float(on[0]), float(on[3])
        return field_noise(
            float(wd[0]), float(wd[3]), gyro_on, accel_on, float(rw[0]), float(rw[3])
        ), (gyro_on, accel_on)
    if not meta or "gyro_noise_density" not in meta or "accel_noise_density" not in meta:
        raise ConfigError(
            f"{path}: the filter needs the unit's noise: give the IMU (imu=: a preset or TOML "
            "file) or a metadata 'noise' with gyro_noise_density and accel_noise_density"
        )
    gyro_on = float(meta.get("gyro_turn_on", DEFAULT_TURN_ON[0] * units.DPH_TO_RPS))
    accel_on = float(meta.get("accel_turn_on", DEFAULT_TURN_ON[1] * units.UG_TO_MPS2))
    if not (gyro_on > 0 and accel_on > 0 and math.isfinite(gyro_on + accel_on)):
        raise ConfigError(f"{path}: metadata noise turn-on values must be > 0, got {meta!r}")
    noise = field_noise(
        float(meta["gyro_noise_density"]),
        float(meta["accel_noise_density"]),
        gyro_on,
        accel_on,
        float(meta.get("gyro_bias_rw", 0.0)),
        float(meta.get("accel_bias_rw", 0.0)),
    )
    return noise, (gyro_on, accel_on)

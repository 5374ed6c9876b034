"""Fit, compensate and evaluate a whole calibration log: the library side of the commands.

Each function takes a log as a file (read run by run, so memory stays bounded by the longest
runs: fit and compensate read the next run while they work on one) or as a validated
:class:`pandas.DataFrame`, and returns data: a fitted model with its
report (:class:`FitResult`), a compensated table or a compensation summary
(:class:`CompensationSummary`), an evaluation (:class:`Evaluation`). They print nothing;
only :func:`compensate_file` writes, because it streams a log too large to hold.

The command-line interface (``rinscal fit``, ``compensate``, ``evaluate``) is a thin layer
over these; they are also :func:`rinscal.fit`, :func:`rinscal.compensate` and
:func:`rinscal.evaluate`.

Why one module: these are the public API's calibration functions, each the same few steps
(check the arguments at the boundary, read the log as a file run by run or take a table,
apply the model, return data); split, the shared log and model handling would be imported
back and forth.
"""

from __future__ import annotations

import contextlib
import math
import os
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal import _check
from rinscal.calibration.compensate import (
    FLAG_COLUMN,
    check_units,
    describe_reference,
    imu_calibrated_frame,
    physical_meta,
)
from rinscal.calibration.compensate import compensate as _compensate_frame
from rinscal.calibration.compensator import Compensator
from rinscal.calibration.evaluate import StepConfig, evaluate_runs
from rinscal.calibration.imulog import (
    CalibrationRangeTally,
    check_log_for_imu,
    imu_stage,
    imu_stage_notes,
)
from rinscal.calibration.modelfile import FittedModel, check_policy
from rinscal.calibration.selection.rule import AUTO_TOLERANCE
from rinscal.calibration.thermal.features import (
    DerivativeConfig,
    MissingGradientWarning,
    OutlierConfig,
    run_slices,
)
from rinscal.calibration.thermal.guards import TrainingDataWarning
from rinscal.calibration.thermal.model import ThermalFitter
from rinscal.errors import ConfigError
from rinscal.io.foreign import foreign_meta
from rinscal.io.mapping import ColumnMapping
from rinscal.io.metadata import meta_path
from rinscal.io.streaming import LogStreamWriter, by_runs
from rinscal.io.tables import SourceLog, check_mapping, format_of
from rinscal.parallel import in_background, one_behind, read_ahead, resolve_jobs
from rinscal.sensormodel import ImuCalibration

__all__ = [
    "CompensationSummary",
    "Evaluation",
    "FitResult",
    "compensate",
    "compensate_file",
    "evaluate",
    "fit",
    "imu_stage",
    "load_model",
    "model_label",
    "run_counts",
]

LogLike = str | os.PathLike[str] | pd.DataFrame
ModelLike = str | os.PathLike[str] | FittedModel
ImuCalLike = str | os.PathLike[str] | ImuCalibration
#: What the metadata of a log compensated behind an IMU calibration says of its units.
OUTPUT_UNITS_IMU = (
    "deg/h (gyros) and ug (accelerometers): the IMU calibration (scale factor, nonlinear "
    "terms, misalignment) was applied to the raw output, then the thermal bias removed"
)


@dataclass(frozen=True)
class FitResult:
    """A fitted thermal model and its report.

    Attributes
    ----------
    model : FittedModel
        The model, as it is saved (:meth:`save`) and loaded (:func:`load_model`).
    table : DataFrame
        One row per channel: ``channel``, ``unit`` (the log's), ``model`` (the fitted
        family, the auto choice), ``samples``, ``masked`` (outliers left out),
        ``t_min_c``, ``t_max_c`` (training temperatures [°C]), ``rms_train`` (RMS per
        sample of the training residual about each run's mean, Eq. 16, log units) and, for
        ``method="auto"``, ``train_rms``, ``heldout_rms`` and ``none_heldout_rms``: one
        figure, the RMS of 60 s means of the residual about each scored part's mean (log
        units), of the chosen model fitted on all the data, of the chosen with each part's
        fold left out, and of no compensation left out alike (the selection's table).
    warnings : tuple of str
        What the fit warned of, in words: a missing gradient first, then weak training
        data (prefixed with the log's path when the log was a file).
    note : str
        How to read the table (the held-out scheme, what each RMS is).
    """

    model: FittedModel
    table: pd.DataFrame
    warnings: tuple[str, ...] = ()
    note: str = ""

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model file (JSON, atomically); returns its path."""
        return self.model.save(path)


def load_model(path: str | os.PathLike[str]) -> FittedModel:
    """Load and validate a thermal model file (JSON; nothing is unpickled).

    Parameters
    ----------
    path : str or PathLike
        A file written by :func:`rinscal.fit` / ``rinscal fit``.

    Returns
    -------
    FittedModel
        Predicts the thermal bias of each channel in the log's units
        (:meth:`FittedModel.predict`) or in SI (``predict_bias_si``).

    Examples
    --------
    >>> import rinscal
    >>> model = rinscal.load_model("model.json")  # doctest: +SKIP
    >>> model.channels  # doctest: +SKIP
    ('gyro_x', 'gyro_y', 'gyro_z', 'accel_x', 'accel_y', 'accel_z')
    """
    return FittedModel.load(_check.path_like("path", path))


#: What a ``model`` and an ``imu_calibration`` argument accept, in words.
MODEL_ACCEPTED = "a model file's path (str or os.PathLike) or a loaded model (rinscal.load_model)"
IMUCAL_ACCEPTED = "an ImuCalibration or an IMU calibration file's path (str or os.PathLike)"


def _model(model: ModelLike) -> FittedModel:
    """A model argument: a loaded model as it is, a path loaded (a wrong type named)."""
    if isinstance(model, FittedModel):
        return model
    return FittedModel.load(_check.instance("model", model, (str, os.PathLike), MODEL_ACCEPTED))


def _frame_runs(log: pd.DataFrame) -> Iterator[tuple[pd.DataFrame, int]]:
    """A validated log's runs in order of first appearance, each with its first row."""
    for _, part in log.groupby("run", sort=False):
        yield part, int(part.index[0]) if isinstance(part.index, pd.RangeIndex) else 0


def fit(
    log: LogLike,
    method: str = "auto",
    *,
    meta: Mapping[str, Any] | None = None,
    mapping: ColumnMapping | Any | None = None,
    orders: Sequence[int] | None = None,
    hidden: int | None = None,
    edges: Sequence[float] | None = None,
    window_s: float = 60.0,
    causal: bool = False,
    gradient: bool | None = None,
    temp_range: tuple[float, float] = (-60.0, 150.0),
    tolerance: float = AUTO_TOLERANCE,
    candidates: Sequence[str] | None = None,
    seed: int = 0,
    max_samples: int | None = None,
    on_run: Callable[[int], None] | None = None,
    on_channel: Callable[[str, int], None] | None = None,
    imu_calibration: ImuCalLike | None = None,
    progress: Callable[[float, float], None] | None = None,
    screen_outliers: bool = True,
    n_jobs: int | None = None,
) -> FitResult:
    """Fit a thermal bias model per channel on a calibration log.

    Parameters
    ----------
    log : str, PathLike or DataFrame
        A calibration log file (CSV, TSV, Parquet, PX4 ``.ulg``, ArduPilot ``.bin``; read
        run by run) or a validated log table (:func:`rinscal.read_log`).
    method : str
        ``auto`` (each channel's model of least held-out error, the simplest within noise of
        the best), ``poly-t`` (cubic-type polynomial in T), ``sectional`` (paper method 1),
        ``regression`` (method 2), ``neural`` (method 3), ``px4`` or ``ardupilot``.
    meta : mapping, optional
        The log's metadata (units, ``latitude_deg``, ``heading_deg``, ``static_reference``).
        Default: the file's ``.meta.json`` sidecar, if any.
    mapping : ColumnMapping or FlightLogOptions, optional
        How to read a foreign file (:func:`rinscal.io.mapping.read_mapping`).
    orders : sequence of int, optional
        ``regression`` (p, q, s), ``sectional`` (p, q), ``poly-t`` (degree,).
    hidden : int, optional
        ``neural``: hidden neurons.
    edges : sequence of float, optional
        ``sectional``: segment edges [°C].
    window_s : float
        Window of the temperature-rate estimate [s].
    causal : bool
        Causal temperature rate (real-time use) instead of centred.
    gradient : bool, optional
        Use the gradient ΔT (default: where the log has ``temp_out``).
    temp_range : (float, float)
        Plausible temperature readings [°C]; others are refused.
    tolerance : float [dimensionless]
        ``auto``: also take a simpler model whose held-out RMS exceeds the best's by at most
        this fraction, on top of the paired test (the rule shared by ``select`` and the IMU
        laws: :mod:`rinscal.calibration.selection.rule`).
    candidates : sequence of str, optional
        ``auto``: the candidate families.
    seed : int
        ``neural``: seed of the first start.
    max_samples : int, optional
        ``neural``: decimate training to this many rows.
    on_run, on_channel : callable, optional
        Deprecated (the next release removes them; use ``progress``): called with the
        number of runs read so far, and with each fitted channel's name and the number of
        channels.
    imu_calibration : ImuCalibration or path-like, optional
        An IMU calibration (or a file holding one, :func:`rinscal.io.imucal.read_imu_calibration`)
        applied to the log before the thermal model is fitted: raw × the metadata's
        ``unit_to_si`` → SI → the inverse sensor model at each channel's temperature (scale
        factors, nonlinear terms, misalignments; its biases are left for the thermal model)
        → deg/h and µg. The thermal model is fitted on that output, in deg/h and µg
        (``--static-ref`` values too), and the model file holds the calibration, applied in
        the same order by every compensator.

    progress : callable, optional
        ``progress(done, total)``: while a file is read, ``done`` runs read and ``total``
        NaN (not known yet); then ``done`` channels fitted out of ``total``.
    screen_outliers : bool
        Leave out samples far from their running median (spikes of a raw sensor; the
        table's ``masked``). False for a log that is already a smoothed estimate (the bias
        series of :func:`rinscal.calibrate_field`), whose fastest part is its warm-up, not
        a spike.
    n_jobs : int, optional
        Threads for the channels' independent work (features, per-run factors, ``auto``'s
        held-out choice); None or 0: every core. The model does not depend on it.

    Returns
    -------
    FitResult

    Raises
    ------
    ConfigError
        A meaningless model (implausible temperatures, a rank-deficient design): the message
        names the column and why.
    LogError
        A log that cannot be read, named with its row.

    Examples
    --------
    >>> import rinscal
    >>> result = rinscal.fit("soak.parquet", method="regression")  # doctest: +SKIP
    >>> result.table[["channel", "model", "rms_train"]]  # doctest: +SKIP
    >>> result.save("regression.json")  # doctest: +SKIP
    """
    log = _check.log_like("log", log)
    _mapping_for(log, mapping)
    _check.text("method", method)
    _check.mapping("meta", meta, optional=True)
    _check.numbers_of("orders", orders, optional=True, integer=True, min=0)
    _check.number("hidden", hidden, optional=True, integer=True, min=1)
    _check.numbers_of("edges", edges, optional=True)
    _check.number("window_s", window_s, above=0.0, unit="s")
    _check.flag("causal", causal)
    _check.flag("gradient", gradient, optional=True)
    lo, hi = _check.numbers_of("temp_range", temp_range, length=2)  # type: ignore[misc]
    _check.number("tolerance", tolerance, min=0.0)
    _check.strings("candidates", candidates, optional=True)
    _check.number("seed", seed, min=0, integer=True)
    _check.number("max_samples", max_samples, optional=True, integer=True, min=1)
    n_jobs = _check.number("n_jobs", n_jobs, optional=True, integer=True, min=0)
    _check.callback("on_run", _check.deprecated("on_run", on_run, "progress="))
    _check.callback("on_channel", _check.deprecated("on_channel", on_channel, "progress="))
    _check.callback("progress", progress)
    _check.flag("screen_outliers", screen_outliers)
    imucal_types = (str, os.PathLike, ImuCalibration)
    _check.instance(
        "imu_calibration", imu_calibration, imucal_types, IMUCAL_ACCEPTED, optional=True
    )
    if not lo < hi:
        raise ConfigError(f"temp_range must be (lo, hi) in °C with lo < hi, got {temp_range!r}")
    if candidates is not None and method != "auto":
        raise ConfigError("candidates apply to method 'auto' only")
    params = {"max_samples": max_samples} if max_samples is not None else None
    deriv = DerivativeConfig(window_s, "causal" if causal else "centred")
    model = ThermalFitter(
        method,
        orders=None if orders is None else tuple(int(v) for v in orders),
        hidden=hidden,
        edges=None if edges is None else tuple(float(v) for v in edges),
        derivative=deriv,
        outliers=OutlierConfig(enabled=screen_outliers),
        use_gradient=gradient,
        random_state=seed,
        estimator_params=params,
        tolerance=tolerance,
        temp_range=(lo, hi),
        n_jobs=n_jobs,
        **({"candidates": tuple(candidates)} if candidates is not None else {}),
    )

    fitted = 0

    def step(channel: str) -> None:
        nonlocal fitted
        fitted += 1
        if on_channel is not None:
            on_channel(channel, len(model.channels))
        if progress is not None:
            progress(float(fitted), float(len(model.channels)))

    def read(k: int) -> None:
        if on_run is not None:
            on_run(k)
        if progress is not None:
            progress(float(k), math.nan)

    if not isinstance(log, pd.DataFrame) and meta is None:
        meta = foreign_meta(Path(log), mapping)
    stage = None
    imu_notes: list[str] = []
    if imu_calibration is not None:
        stage, imu_notes = imu_stage_notes(
            imu_calibration, meta, "the log" if isinstance(log, pd.DataFrame) else str(log)
        )
        meta = physical_meta(meta)

    tally = None if stage is None else CalibrationRangeTally(stage.calibration.t_range_c)

    def calibrated(frame: pd.DataFrame) -> pd.DataFrame:
        if stage is None or tally is None:
            return frame
        out = imu_calibrated_frame(frame, stage, deriv)  # first: it names a missing column
        tally.add(frame)
        return out

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrainingDataWarning)
        warnings.simplefilter("always", MissingGradientWarning)
        if isinstance(log, pd.DataFrame):
            model.fit(calibrated(log), meta, on_channel=step)
            source = None
        else:
            path = Path(log)

            def runs(sources: Iterator[SourceLog]) -> Iterator[tuple[pd.DataFrame, int]]:
                for src in sources:  # no enumerate: it would hold one more run while the
                    yield calibrated(src.log), src.first_row  # next is read
                    del src

            by_runs(  # run by run: memory bounded by two runs (fit_runs reads one ahead)
                path,
                mapping,
                lambda s: model.fit_runs(
                    runs(s), meta, on_channel=step, source=str(path), on_run=read
                ),
            )
            source = {"log": path.name}
    mf = model.to_file(source=source).with_imu(stage)
    if tally is not None:
        imu_notes += tally.notes(
            "the log" if isinstance(log, pd.DataFrame) else str(log),
            "the IMU calibration"
            if isinstance(imu_calibration, ImuCalibration)
            else f"the IMU calibration {imu_calibration}",
        )
    told = imu_notes + [
        f"{w.message}" for w in caught if issubclass(w.category, MissingGradientWarning)
    ]
    where = "" if isinstance(log, pd.DataFrame) else f"{log}: "
    told += [f"{where}{w.message}" for w in caught if issubclass(w.category, TrainingDataWarning)]
    missing = describe_reference(mf)[1]
    if missing:  # said now, not first at compensate, after 1 g was taken off accel_z
        told.append(
            f"{where}no site and no static reference (latitude_deg/heading_deg or "
            f"static_reference in the metadata): {', '.join(missing)} keep no static output, "
            "so compensating with this model removes their static level (gravity, 1 g on a "
            "vertical accelerometer; the Earth rate) with the thermal bias; give the site "
            "(fit --latitude and --heading) or --static-ref mean|CHANNEL=VALUE to keep it"
        )
    return FitResult(mf, fit_table(mf), tuple(told), fit_note(mf, method))


def fit_table(mf: FittedModel) -> pd.DataFrame:
    """One row per channel of a fitted model: its family, data and residuals (see
    :class:`FitResult`)."""
    rows = []
    for c in mf.channels:
        cm = mf.models[c]
        m = cm.metrics
        row: dict[str, Any] = {
            "channel": c,
            "unit": cm.unit,
            "model": model_label(cm),
            "samples": int(m["n_train"]),
            "masked": int(m["n_outliers"]),
            "t_min_c": float(cm.train_range[0, 0]),
            "t_max_c": float(cm.train_range[0, 1]),
            "rms_train": m["rms_train_about_run_mean"],
        }
        if cm.selection is not None:
            by_name = {r["name"]: r for r in cm.selection["table"]}
            row["train_rms"] = by_name[cm.selection["chosen"]].get("train_rms")
            row["heldout_rms"] = by_name[cm.selection["chosen"]]["heldout_rms"]
            row["none_heldout_rms"] = by_name.get("none", {}).get("heldout_rms")
        rows.append(row)
    return pd.DataFrame(rows)


def model_label(cm: Any) -> str:
    """A channel's model in words: the auto choice, or the method and its settings
    (``regression 3,3,3``, ``poly-t 3``, ``neural 2``, ``none``)."""
    if cm.selection is not None:
        return str(cm.selection["chosen"])
    p = cm.params
    if p["method"] == "regression":
        return "regression " + ",".join(str(o) for o in p["orders"])
    if p["method"] == "poly-t":
        return "none" if len(p["coef"]) == 1 else f"poly-t {len(p['coef']) - 1}"
    if p["method"] == "neural":
        return f"neural {len(p['b'])}"
    return str(p["method"])


def fit_note(mf: FittedModel, method: str) -> str:
    """How to read :func:`fit_table`: masked samples, what each RMS is, the held-out scheme."""
    note = "masked: outlier samples left out of the fit."
    if method != "auto":
        note += (
            " RMS/sample: RMS per sample of the training residual about each run's mean "
            "(Eq. 16, turn-on offsets removed)."
        )
    else:
        first = next(iter(mf.models.values())).selection or {}
        scheme, parts = first.get("scheme", "?"), len(first.get("folds", []))
        how = (
            f"leave-one-leg-out, scored on {parts} blocks"
            if scheme == "legs"
            else f"{scheme} over {parts} folds"
        )
        note += (
            " Train and held-out RMS are one figure: the RMS of 60 s means of the residual "
            "about each scored part's mean (turn-on offsets removed), over the samples inside "
            f"the other folds' temperatures; held-out: {how}, each part predicted by the fit "
            "without its fold; train: the fit on all the data (rinscal select LOG --method "
            "auto shows every candidate)."
        )
    return note


def compensate(
    log: LogLike,
    model: ModelLike,
    *,
    policy: str = "clamp",
    causal: bool = False,
    mapping: ColumnMapping | Any | None = None,
    n_jobs: int | None = None,
) -> pd.DataFrame:
    """Subtract the modelled thermal bias from every sensor channel (Eq. 10), in memory.

    Parameters
    ----------
    log : str, PathLike or DataFrame
        A calibration log (file, read whole, or a validated table).
    model : str, PathLike or FittedModel
        The thermal model (a model file's path, or loaded).
    policy : str
        Outside the training data: ``clamp`` (hold the model at its domain's edge),
        ``extrapolate``, ``fallback`` (the model of T alone) or ``error`` (refuse).
    causal : bool
        Use the causal temperature rate (as in real time).
    mapping : ColumnMapping, optional
        How to read a foreign file.
    n_jobs : int, optional
        Threads over the channels (None or 0: every core); the output does not depend on it.

    Returns
    -------
    DataFrame
        The log, every modelled channel compensated (log units), plus the boolean column
        ``out_of_range`` (the row is outside the training data).

    Examples
    --------
    >>> import rinscal
    >>> table = rinscal.compensate("soak.parquet", "regression.json")  # doctest: +SKIP
    """
    # deferred: reading a file needs the table readers only here
    from rinscal.io.tables import read_log

    log = _check.log_like("log", log)
    _mapping_for(log, mapping)
    check_policy(policy)
    _check.flag("causal", causal)
    n_jobs = _check.number("n_jobs", n_jobs, optional=True, integer=True, min=0)
    mf = _model(model)
    frame = log if isinstance(log, pd.DataFrame) else read_log(log, mapping)
    kind = "causal" if causal else None
    return _compensate_frame(frame, mf, policy, kind, n_jobs=n_jobs)  # type: ignore[arg-type]


@dataclass(frozen=True)
class CompensationSummary:
    """What :func:`compensate_file` wrote.

    Attributes
    ----------
    rows : int
        Rows written.
    model : FittedModel
        The model applied.
    policy : str
        What was done outside the training data.
    flagged : dict of str to (int, int)
        Per run (in order of first appearance): rows flagged ``out_of_range``, and rows.
    reference : str
        What the compensation keeps of the static output (gravity, Earth rate), in words.
    missing_reference : list of str
        Channels whose static level was removed with the thermal bias (no static reference
        in the model).
    meta : dict or None
        The metadata written beside the output (None: the input had none).
    warnings : tuple of str
        Behind an IMU calibration: channels whose unit the log does not declare, a log of
        another unit than the calibration's.
    """

    rows: int
    model: FittedModel
    policy: str
    flagged: dict[str, tuple[int, int]]
    reference: str
    missing_reference: list[str]
    meta: dict[str, Any] | None = field(default=None)
    warnings: tuple[str, ...] = ()

    @property
    def flagged_rows(self) -> int:
        """Rows flagged ``out_of_range`` over all runs."""
        return sum(k for k, _ in self.flagged.values())


def compensate_file(
    log: str | os.PathLike[str],
    model: ModelLike,
    out: str | os.PathLike[str],
    *,
    policy: str = "clamp",
    causal: bool = False,
    mapping: ColumnMapping | Any | None = None,
    meta: Mapping[str, Any] | None = None,
    ignore_units: bool = False,
    n_jobs: int | None = None,
) -> CompensationSummary:
    """Compensate a log file run by run into ``out`` (the same table back, its sensor channels
    compensated, the ``out_of_range`` column added, nothing else touched).

    Memory stays bounded by three runs (the next is read and the last written while one
    is compensated). The
    output is written as it is computed, in the input's format where ``out`` has the same
    kind (CSV/TSV), else Parquet by suffix; the caller writes the metadata sidecar
    (``summary.meta``) if it wants one. Behind an IMU
    calibration all six channels are written in deg/h and µg, and ``summary.meta`` says so
    (``units``, ``unit_to_si``, ``compensated.output_units``).

    Parameters
    ----------
    log, out : str or PathLike
        Input and output files; ``out`` must not be ``log``.
    model : str, PathLike or FittedModel
        The thermal model.
    policy, causal, mapping
        As :func:`compensate`.
    meta : mapping, optional
        The log's metadata (units); default its sidecar, with the mapping's units and
        ``log`` (the file's name).
    ignore_units : bool
        Compensate even where the log's units differ from the model's.
    n_jobs : int, optional
        Threads over the channels (None or 0: every core); the output does not depend on it.

    Returns
    -------
    CompensationSummary

    Raises
    ------
    UnitsError
        The log's units differ from the model's (unless ``ignore_units``).
    RangeError
        A row outside the training data under ``policy="error"``.
    """
    log_path = _check.log_like("log", log, table=False)
    _mapping_for(log_path, mapping)
    out_path = _check.path_like("out", out)
    check_policy(policy)
    _check.flag("causal", causal)
    _check.mapping("meta", meta, optional=True)
    _check.flag("ignore_units", ignore_units)
    n_jobs = _check.number("n_jobs", n_jobs, optional=True, integer=True, min=0)
    inputs = [log_path, meta_path(log_path)]
    if isinstance(model, str | os.PathLike):
        inputs.append(Path(model))
    for src in inputs:  # a command never overwrites its input, the API neither
        if _same_file(out_path, src):
            raise ConfigError(f"out {out_path}: refusing to overwrite the input {src}")
    mf = _model(model)
    meta = dict(foreign_meta(log_path, mapping) if meta is None else meta)
    if not ignore_units:
        check_units(mf, meta, str(log_path))
    notes = _stage_notes(mf, meta, str(log_path), ignore_units)
    kind = "causal" if causal else None
    # the rate's compiled kernel (numba and its own machinery: about a second) loads on a
    # thread of its own while the log's runs are found and the first is read
    kernel = in_background(partial(_load_rate_kernel, kind or mf.derivative_kind), n_jobs)
    rows, flagged = by_runs(  # run by run: memory bounded by three runs
        log_path, mapping, lambda s: _write_runs(s, mf, policy, kind, out_path, n_jobs, kernel)
    )
    if mf.imu_stage is not None:  # the output is in deg/h and µg whatever the input's unit
        meta = physical_meta(meta)
    if meta:
        meta["compensated"] = {
            "model": Path(model).name if not isinstance(model, FittedModel) else None,
            "sha256": mf.to_dict()["sha256"],
            "method": mf.method,
            "policy": policy,
            "derivative": "causal" if causal else mf.derivative_kind,
            "imu_calibration": mf.imu_stage is not None,
            "output_units": OUTPUT_UNITS_IMU if mf.imu_stage is not None else "the input's",
        }
    reference, missing = describe_reference(mf)
    return CompensationSummary(
        rows, mf, policy, flagged, reference, missing, meta or None, tuple(notes)
    )


def _mapping_for(log: Path | pd.DataFrame, mapping: object) -> None:
    """Refuse a ``mapping=`` of a wrong type, or one given with a table (it says how to read
    a file: a table is read already, and the mapping would be ignored)."""
    check_mapping(mapping)
    if mapping is not None and isinstance(log, pd.DataFrame):
        raise ConfigError(
            "mapping: a column mapping says how to read a log file; log is a DataFrame "
            "already (read a foreign file with rinscal.read_log(path, mapping))"
        )


def _same_file(a: Path, b: Path) -> bool:
    """Whether two paths name the same file (also through links and relative paths)."""
    if a.resolve() == b.resolve():
        return True
    return a.exists() and b.exists() and os.path.samefile(a, b)


def _stage_notes(
    mf: FittedModel, meta: Mapping[str, Any] | None, source: str, ignore_units: bool
) -> list[str]:
    """What applying a model's IMU calibration to a log cannot check (undeclared units, another
    unit); differing units were refused by :func:`check_units` already."""
    if mf.imu_stage is None or ignore_units:
        return []
    stage = mf.imu_stage
    return check_log_for_imu(
        stage.input_units, stage.unit, meta, source, "the model's IMU calibration", refuse=False
    )


def _load_rate_kernel(kind: str) -> None:
    """Load the compiled kernel of the ``kind`` of rate (numba with it)."""
    # deferred: rate loads numba's kernels; only a command that computes a rate needs them
    from rinscal.calibration.thermal.rate import load_kernel

    load_kernel(kind)


def _write_runs(
    sources: Iterator[SourceLog],
    mf: FittedModel,
    policy: str,
    kind: str | None,
    out: Path,
    n_jobs: int | None = None,
    kernel: Callable[[], None] | None = None,
) -> tuple[int, dict[str, tuple[int, int]]]:
    """Compensate runs as they are read and write each at once; rows written, and per run
    the rows flagged out of range and the rows. ``kernel()`` waits for the rate's compiled
    kernel (loaded here when not given)."""
    shares: dict[str, tuple[int, int]] = {}
    writer: LogStreamWriter | None = None
    several = resolve_jobs(n_jobs) > 1
    # on several threads, the next run read (and its run_slices found: once, for the channels
    # and the counts) while this one is compensated
    with_slices = ((src, run_slices(src.log["run"])) for src in sources)
    runs = read_ahead(with_slices, 2) if several else with_slices
    if kernel is None:
        _load_rate_kernel(kind or mf.derivative_kind)  # meanwhile, as the first run is read
    with contextlib.ExitStack() as stack:
        for src, slices in runs:
            if kernel is not None:  # the first run read meanwhile; at once after that
                kernel()
            if writer is None:
                same_kind = format_of(out) != "parquet" and src.sep is not None
                writer = stack.enter_context(
                    LogStreamWriter(
                        out, validate=False, sep=src.sep if same_kind else None, writeback=True
                    )
                )
                # and the last written (left before the writer closes: waited for)
                write = stack.enter_context(one_behind(writer.write)) if several else writer.write
            values, flagged = Compensator(mf, policy).batch(  # type: ignore[arg-type]
                src.log, kind, first_row=src.first_row, n_jobs=n_jobs, slices=slices
            )
            write(src.write_back(values, {FLAG_COLUMN: flagged}))
            for run, k, n in zip(*_slice_counts(slices, flagged), strict=True):
                k0, n0 = shares.get(run, (0, 0))
                shares[run] = (k0 + k, n0 + n)
    # counted once the last run is written (on several threads, after the stack waited for it)
    return (writer.rows if writer is not None else 0), shares


def run_counts(run: pd.Series, flagged: np.ndarray) -> tuple[list[str], list[int], list[int]]:
    """Each run's name, flagged rows and rows, in order of first appearance."""
    codes, names = pd.factorize(run, sort=False)
    k = np.bincount(codes, weights=flagged, minlength=len(names))
    n = np.bincount(codes, minlength=len(names))
    return [str(v) for v in names], [int(v) for v in k], [int(v) for v in n]


def _slice_counts(
    slices: tuple[np.ndarray, tuple[str, ...], list[np.ndarray]], flagged: np.ndarray
) -> tuple[list[str], list[int], list[int]]:
    """:func:`run_counts` from the :func:`run_slices` of the run column."""
    codes, names, rows = slices
    k = np.bincount(codes[flagged], minlength=len(names))
    return list(names), [int(v) for v in k], [r.size for r in rows]


@dataclass(frozen=True)
class Evaluation:
    """RMS before and after a model, steps at segment edges, Allan deviation.

    Attributes
    ----------
    table : DataFrame
        Per run and channel: ``rms_before``, ``rms_after`` (Eq. 16, about each run's mean,
        inlier samples, log units), ``ratio``, ``out_of_range`` and ``samples``,
        ``crossings``, ``max_step_before``, ``max_step_after`` (log units).
    allan : DataFrame
        Per run, channel and output (raw, compensated): the IEEE Std 952 noise parameters
        ``n`` (random walk at τ = 1 s), ``b`` (bias instability), ``b_tau_s``, ``k``.
    curves : dict
        Per run and channel, the Allan deviation curves (for a figure).
    model : FittedModel
        The model evaluated.
    warnings : tuple of str
        As :attr:`CompensationSummary.warnings`.
    """

    table: pd.DataFrame
    allan: pd.DataFrame
    curves: dict[str, Any]
    model: FittedModel
    warnings: tuple[str, ...] = ()


def evaluate(
    log: LogLike,
    model: ModelLike,
    *,
    policy: str = "clamp",
    causal: bool = False,
    step_window_s: float = 120.0,
    mapping: ColumnMapping | Any | None = None,
    meta: Mapping[str, Any] | None = None,
    ignore_units: bool = False,
) -> Evaluation:
    """How much a model removes: RMS before and after (Eq. 16), steps, Allan deviation.

    Parameters
    ----------
    log : str, PathLike or DataFrame
        A calibration log (a file is read run by run) the model did or did not see.
    model : str, PathLike or FittedModel
        The thermal model.
    policy, causal, mapping
        As :func:`compensate`.
    step_window_s : float
        Fit window on each side of a segment edge [s] (Figure 7).
    meta : mapping, optional
        The log's metadata (units); default its sidecar.
    ignore_units : bool
        Evaluate even where the log's units differ from the model's.

    Returns
    -------
    Evaluation

    Examples
    --------
    >>> import rinscal
    >>> ev = rinscal.evaluate("soak.parquet", "regression.json")  # doctest: +SKIP
    >>> ev.table[["run", "channel", "rms_before", "rms_after"]]  # doctest: +SKIP
    """
    log = _check.log_like("log", log)
    _mapping_for(log, mapping)
    check_policy(policy)
    _check.flag("causal", causal)
    _check.number("step_window_s", step_window_s, above=0.0, unit="s")
    _check.mapping("meta", meta, optional=True)
    _check.flag("ignore_units", ignore_units)
    mf = _model(model)
    deriv = "causal" if causal else None
    step = StepConfig(window_s=step_window_s)
    notes: list[str] = []
    if isinstance(log, pd.DataFrame):
        res, allan, curves = evaluate_runs(_frame_runs(log), mf, policy, deriv, step)  # type: ignore[arg-type]
    else:
        path = Path(log)
        if not ignore_units:
            known = meta if meta is not None else foreign_meta(path, mapping)
            check_units(mf, dict(known or {}), str(path))
            notes = _stage_notes(mf, dict(known or {}), str(path), ignore_units)
        res, allan, curves = by_runs(  # run by run: memory bounded by the longest run
            path,
            mapping,
            lambda runs: evaluate_runs(
                ((s.log, s.first_row) for s in runs),
                mf,
                policy,  # type: ignore[arg-type]
                deriv,
                step,
            ),
        )
    return Evaluation(res, allan, curves, mf, tuple(notes))

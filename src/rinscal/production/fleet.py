"""Fleet calibration: every unit's log fitted as its own task on Dask, checked against limits.

A production line calibrates many units, each with its own soak runs. ``run_fleet`` fits
every log as an independent task on the same Dask layer as ``rinscal study``
(:func:`rinscal.cluster.dask_client`: a local cluster by default, any cluster by
its scheduler address) and writes each result as it arrives into a folder that is also its
memory, so that an interrupted fleet resumes without refitting finished units. A unit is
named by the shortest end of its log's path that tells the units apart (:func:`unit_names`:
``SN001/imu.csv`` is ``SN001``), and keeps the name the folder knows it by:

``fleet.json``
    The fit options (method, export format); a folder never mixes two settings.
``units/<unit>.json``
    The unit's model file (checksummed JSON, as ``rinscal fit`` writes).
``units/<unit>.summary.json``
    Per channel: the model, its parameters, its held-out (or training) RMS, the thermal span
    it models over the training data and the white-noise density of the raw output; the log's
    size and modification time (a changed log is refitted).
``exports/<unit>.<ext>``
    The unit's export (C header by default; PX4 or ArduPilot on request).
``failed/<unit>.json``
    A unit whose fit raised: its error. The fleet goes on without it.

:func:`fleet_report` then reads the folder: the distribution of every coefficient and
figure across units, and a verdict per unit against the user's limits (:class:`FleetLimits`,
a TOML file: e.g. a maximum thermal span, held-out RMS and noise density per sensor type or
channel, as a production test's pass/fail).
"""

from __future__ import annotations

import itertools
import json
import math
import os
import time
import tomllib
import traceback
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal.calibration.inference import coefficient_unit
from rinscal.cluster import TLSFiles, dask_client
from rinscal.errors import ConfigError, RinscalError
from rinscal.io.atomic import write_atomic
from rinscal.io.metadata import side_files
from rinscal.schema import CHANNELS

__all__ = [
    "EXPORTS",
    "LIMIT_KEYS",
    "UNIT_SEP",
    "FleetLimits",
    "FleetReport",
    "FleetRun",
    "FleetStore",
    "fit_unit",
    "fleet_report",
    "run_fleet",
    "split_side_files",
    "unit_names",
    "write_fleet_report",
]

#: Export formats and their file suffixes.
EXPORTS: dict[str, str] = {"c": ".h", "px4": ".params", "ardupilot": ".parm", "none": ""}
#: Limit keys (each in the log's units of the channel): the thermal span the model describes
#: over its training data, the held-out RMS of the chosen model, the white-noise density of
#: the raw output [unit·√s].
LIMIT_KEYS: tuple[str, ...] = ("max_thermal_span", "max_heldout_rms", "max_noise_density")


# --------------------------------------------------------------------------- limits
@dataclass(frozen=True)
class FleetLimits:
    """Pass/fail limits of a fleet, per sensor type (``gyro``, ``accel``) or channel.

    Attributes
    ----------
    limits : dict of str to dict of str to float
        ``{"gyro": {"max_noise_density": 0.01}, "accel_z": {"max_thermal_span": 300}}``; a
        channel's own entry overrides its sensor type's. Values in the log's units.
    source : str
        Where they came from, for messages.
    """

    limits: dict[str, dict[str, float]] = field(default_factory=dict)
    source: str = "<limits>"

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> FleetLimits:
        """Read ``[limits.<gyro|accel|channel>]`` tables from a TOML file.

        Raises
        ------
        ConfigError
            Naming the file, the table and the key for anything unknown or not a positive
            finite number.
        """
        p = Path(path)
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
            raise ConfigError(f"{p}: cannot read the limits: {exc}") from None
        table = data.get("limits")
        if not isinstance(table, dict) or set(data) - {"limits"}:
            raise ConfigError(
                f"{p}: expected only [limits.gyro], [limits.accel] or [limits.<channel>]"
            )
        out: dict[str, dict[str, float]] = {}
        for who, keys in table.items():
            where = f"{p}: [limits.{who}]"
            if who not in ("gyro", "accel", *CHANNELS) or not isinstance(keys, dict):
                raise ConfigError(f"{where}: not gyro, accel or a channel ({', '.join(CHANNELS)})")
            for key, value in keys.items():
                if key not in LIMIT_KEYS:
                    raise ConfigError(
                        f"{where}: unknown key {key!r}; known: {', '.join(LIMIT_KEYS)}"
                    )
                ok = isinstance(value, int | float) and not isinstance(value, bool)
                if not ok or not math.isfinite(value) or value <= 0:
                    raise ConfigError(f"{where}: {key} must be a positive number, got {value!r}")
            out[who] = {k: float(v) for k, v in keys.items()}
        return cls(out, str(p))

    def for_channel(self, channel: str) -> dict[str, float]:
        """The limits of one channel: its sensor type's, overridden by its own."""
        sensor = "gyro" if channel.startswith("gyro") else "accel"
        return {**self.limits.get(sensor, {}), **self.limits.get(channel, {})}


# --------------------------------------------------------------------------- one unit
def _noise_density(y: np.ndarray, t: np.ndarray, codes: np.ndarray) -> float:
    """White-noise density of a raw output [unit·√s]: σ of first differences / √2 · √dt.

    σ from the median absolute deviation (an outlier does not move it); the median over runs
    (a thermal drift adds nothing at the sample interval).
    """
    out = []
    for k in np.unique(codes):
        m = codes == k
        yk, tk = y[m], t[m]
        ok = np.isfinite(yk)
        if ok.sum() < 3:
            continue
        dt = float(np.median(np.diff(tk[ok])))
        d = np.diff(yk[ok])
        sigma = 1.4826 * float(np.median(np.abs(d - np.median(d))))  # robust to outliers
        out.append(sigma / math.sqrt(2.0) * math.sqrt(dt))
    return float(np.median(out)) if out else math.nan


def fit_unit(
    log_path: str,
    method: str = "auto",
    export: str = "c",
    unit: str | None = None,
) -> dict[str, Any]:
    """Fit one unit's log: its model file, its export and its summary (a Dask task).

    Parameters
    ----------
    log_path : str
        The unit's calibration log (canonical, with its sidecar metadata if any).
    method : str
        Fit method (``auto`` by default, as ``rinscal fit``).
    export : {"c", "px4", "ardupilot", "none"}
        Export format.
    unit : str, optional
        The unit's name in its fleet, recorded in the model file's ``source`` beside the
        log's file name (several units' logs may share one).

    Returns
    -------
    dict
        ``model`` (model-file JSON text), ``export`` (text or None), ``channels`` (per channel:
        ``model``, ``unit``, ``params`` (flat name -> value, internal), ``coefficients``
        (:func:`rinscal.calibration.inference.physical_coefficients`), ``heldout_rms``,
        ``thermal_span``, ``noise_density``), ``warnings``, ``elapsed_s``.
    """
    # deferred: the fitting stack (numba, the log readers) loads on the worker that fits
    from rinscal.calibration.export import to_ardupilot_parm, to_c_header, to_px4_params
    from rinscal.calibration.inference import physical_coefficients, predict_params
    from rinscal.calibration.thermal.model import ThermalFitter
    from rinscal.io.flightinfo import FlightLogOptions
    from rinscal.io.flightlog import scan_flight_log
    from rinscal.io.metadata import read_meta
    from rinscal.io.tables import is_flight_log, read_log

    t0 = time.perf_counter()
    log = read_log(log_path)
    meta = dict(read_meta(log_path) or {})
    if is_flight_log(log_path):  # a one-IMU .ulg/.bin: its units, ids and instance
        meta = scan_flight_log(log_path).meta(FlightLogOptions()) | meta
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = ThermalFitter(method=method).fit(log, meta, source=Path(log_path).name)
        source = {"log": Path(log_path).name} | ({"unit": unit} if unit else {})
        mf = model.to_file(source)
    feats = model.features_
    channels: dict[str, Any] = {}
    for j, c in enumerate(mf.channels):
        cm = mf.models[c]
        x = feats.matrix(j)
        ok = feats.usable(j, x)
        step = max(1, int(ok.sum()) // 200_000)
        pred = predict_params(model.params_[c], x[ok][::step])
        sel = cm.selection
        heldout = None
        if sel is not None:
            heldout = next(r["heldout_rms"] for r in sel["table"] if r["name"] == sel["chosen"])
        channels[c] = {
            "model": sel["chosen"] if sel else cm.params["method"],
            "unit": cm.unit,
            "params": _flat_params(cm.params),
            "coefficients": physical_coefficients(cm.params),
            "heldout_rms": heldout,
            "train_rms": cm.metrics.get("rms_train_about_run_mean"),
            "thermal_span": float(np.ptp(pred)) if pred.size else math.nan,
            "noise_density": _noise_density(feats.output[:, j], feats.time_s, feats.run_codes),
        }
    text = None
    if export == "c":
        text = to_c_header(mf, "unit")
    elif export == "px4":
        text = to_px4_params(mf)
    elif export == "ardupilot":
        text = to_ardupilot_parm(mf)
    return {
        "model": mf.dumps(),
        "export": text,
        "channels": channels,
        "warnings": sorted({f"{w.category.__name__}: {w.message}" for w in caught}),
        "elapsed_s": time.perf_counter() - t0,
    }


def _flat_params(params: Mapping[str, Any]) -> dict[str, float]:
    """Numeric parameters of a channel model, flattened: ``coef[0]``, ``coef[1]``, ..."""

    def number(v: Any) -> bool:
        return isinstance(v, int | float) and not isinstance(v, bool)

    out: dict[str, float] = {}
    for key, value in params.items():
        if isinstance(value, list | tuple) and value and all(number(v) for v in value):
            out.update({f"{key}[{i}]": float(v) for i, v in enumerate(value)})
        elif number(value):
            out[key] = float(value)
    return out


# --------------------------------------------------------------------------- the folder
#: Joins the folder names (and file name) of a unit name: ``lineA/SN001/imu.csv`` is unit
#: ``lineA+SN001`` when ``SN001`` alone does not tell it apart.
UNIT_SEP = "+"


def unit_names(logs: Sequence[str | os.PathLike[str]]) -> list[str]:
    """Unit name of each log: the shortest end of its path that tells the units apart.

    The file name without its suffix when those are unique (``units/SN0042.parquet`` is
    ``SN0042``). Else the fewest trailing folder names that tell every unit apart, the same
    number for every unit, joined by :data:`UNIT_SEP`, and followed by the file name unless
    every log has the same one: ``SN001/imu.csv``, ``SN002/imu.csv`` are ``SN001``, ``SN002``;
    ``lineA/SN001/imu.csv``, ``lineB/SN001/imu.csv`` are ``lineA+SN001``, ``lineB+SN001``.
    Paths are made absolute first (not resolving links), so the names do not depend on the
    folder the command runs in.

    Raises
    ------
    ConfigError
        A log given twice, or two logs that no part of their paths tells apart (naming both).
    """
    paths = [os.path.abspath(p) for p in logs]
    first: dict[str, int] = {}
    for i, p in enumerate(paths):
        if p in first:
            raise ConfigError(f"{logs[i]} is given twice (one log per unit)")
        first[p] = i
    stems = [Path(p).stem for p in paths]
    if len(set(stems)) == len(stems):
        return stems
    # the file name is dropped when every log has it (and a folder above it to name it by)
    keep_stem = len(set(stems)) > 1 or any(Path(p).parent == Path(p).parent.parent for p in paths)
    parts = [
        [*Path(p).parent.parts[1:], *([s] if keep_stem else [])]
        for p, s in zip(paths, stems, strict=True)
    ]
    names: list[str] = []
    for k in range(1, max(len(q) for q in parts) + 1):
        names = [UNIT_SEP.join(q[-k:]) for q in parts]
        if len(set(names)) == len(names) and all(names):
            return names
    i, j = next(
        (i, j) for i, j in itertools.combinations(range(len(names)), 2) if names[i] == names[j]
    )
    k = max(len(parts[i]), len(parts[j]))  # the shortest end from which the two names agree
    while k > 1 and UNIT_SEP.join(parts[i][1 - k :]) == UNIT_SEP.join(parts[j][1 - k :]):
        k -= 1
    raise ConfigError(
        f"{logs[i]} and {logs[j]} both give the unit name {UNIT_SEP.join(parts[i][-k:])!r}: "
        "nothing in their paths tells the two units apart (one log per unit)"
    )


class FleetStore:
    """The results folder of one fleet (see the module docstring for its layout)."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root)

    def model_path(self, unit: str) -> Path:
        return self.root / "units" / f"{unit}.json"

    def summary_path(self, unit: str) -> Path:
        return self.root / "units" / f"{unit}.summary.json"

    def failure_path(self, unit: str) -> Path:
        return self.root / "failed" / f"{unit}.json"

    def export_path(self, unit: str, export: str) -> Path:
        return self.root / "exports" / f"{unit}{EXPORTS[export]}"

    def options(self) -> dict[str, Any]:
        """The fit options the folder was opened with (``fleet.json``)."""
        marker = self.root / "fleet.json"
        return json.loads(marker.read_text("utf-8")).get("options", {})

    def open(self, options: Mapping[str, Any]) -> None:
        """Create the folder for ``options``, or check that it holds a fleet fitted so."""
        if self.root.exists() and not self.root.is_dir():
            raise ConfigError(f"{self.root}: exists and is not a folder")
        marker = self.root / "fleet.json"
        if marker.exists():
            old = json.loads(marker.read_text(encoding="utf-8"))
            if old.get("options") != dict(options):
                raise ConfigError(
                    f"{self.root}: holds a fleet fitted with {old.get('options')}, not "
                    f"{dict(options)}; choose another --out"
                )
            return
        for sub in ("units", "failed", "exports"):
            (self.root / sub).mkdir(parents=True, exist_ok=True)
        text = json.dumps({"options": dict(options)}, indent=1)
        write_atomic(marker, lambda tmp: tmp.write_text(text, encoding="utf-8"))

    def is_done(self, unit: str, log: str) -> bool:
        """Whether ``unit`` is fitted from this very log (same size and modification time)."""
        p = self.summary_path(unit)
        if not p.exists() or not self.model_path(unit).exists():
            return False
        st = Path(log).stat()
        seen = json.loads(p.read_text(encoding="utf-8")).get("log", {})
        return seen.get("size") == st.st_size and seen.get("mtime_ns") == st.st_mtime_ns

    def write(self, unit: str, log: str, result: Mapping[str, Any], export: str) -> None:
        """Write a unit's model, export and summary (the summary last: it marks it done)."""
        write_atomic(self.model_path(unit), lambda t: t.write_text(result["model"], "utf-8"))
        if result.get("export") is not None:
            text = result["export"]
            write_atomic(self.export_path(unit, export), lambda t: t.write_text(text, "utf-8"))
        self.failure_path(unit).unlink(missing_ok=True)
        st = Path(log).stat()
        doc = {k: v for k, v in result.items() if k not in ("model", "export")}
        doc["log"] = {"path": os.path.abspath(log), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
        text = json.dumps(doc, indent=1, allow_nan=True)
        write_atomic(self.summary_path(unit), lambda t: t.write_text(text, "utf-8"))

    def write_failure(self, unit: str, log: str, error: str, tb: str) -> None:
        doc = json.dumps({"log": os.path.abspath(log), "error": error, "traceback": tb}, indent=1)
        write_atomic(self.failure_path(unit), lambda t: t.write_text(doc, "utf-8"))

    def summaries(self) -> dict[str, dict[str, Any]]:
        """Every fitted unit's summary, by unit name."""
        out = {}
        for p in sorted((self.root / "units").glob("*.summary.json")):
            out[p.name.removesuffix(".summary.json")] = json.loads(p.read_text("utf-8"))
        return out

    def units_by_log(self) -> dict[str, str]:
        """The unit each log was fitted (or failed) as, by the log's absolute path.

        A path recorded relative (by an older rinscal) is taken from the current folder.
        """
        out = {os.path.abspath(s["log"]["path"]): u for u, s in self.summaries().items()}
        for p in sorted((self.root / "failed").glob("*.json")):
            out.setdefault(os.path.abspath(json.loads(p.read_text("utf-8"))["log"]), p.stem)
        return out

    def failures(self) -> dict[str, str]:
        """Every failed unit's error, by unit name."""
        return {
            p.stem: json.loads(p.read_text("utf-8"))["error"]
            for p in sorted((self.root / "failed").glob("*.json"))
        }


# --------------------------------------------------------------------------- running
@dataclass
class FleetRun:
    """What one call of :func:`run_fleet` did."""

    units: int = 0
    skipped: int = 0
    fitted: int = 0
    failed: int = 0
    workers: int = 0
    elapsed_s: float = 0.0
    #: Files given that are another log's side files (truth, metadata), not units: left out.
    side_files: list[str] = field(default_factory=list)


def split_side_files(
    logs: Sequence[str | os.PathLike[str]],
) -> tuple[list[str], list[str]]:
    """Split ``logs`` into the units' logs and the side files of a log beside them.

    A side file is one the simulator (or a command) writes beside a log, named from it by
    :func:`rinscal.io.metadata.side_files` (``cal.truth.parquet``, ``cal.params.truth.csv``,
    ``cal.parquet.meta.json``), whose log is in the same folder: ``runs/*.parquet`` matches
    both ``cal.parquet`` and its truth.

    Returns
    -------
    (list of str, list of str)
        The logs, then the side files, each in the order given.
    """
    owners: dict[str, set[str]] = {}  # folder -> the side files of every file in it
    kept: list[str] = []
    side: list[str] = []
    for log in logs:
        p = Path(log)
        folder = os.path.abspath(p.parent)
        if folder not in owners:
            try:
                siblings = [q for q in Path(folder).iterdir() if q.is_file()]
            except OSError:
                siblings = []
            owners[folder] = {os.path.abspath(s) for q in siblings for s in side_files(q) if s != q}
        (side if os.path.abspath(p) in owners[folder] else kept).append(str(p))
    return kept, side


def _task(log: str, method: str, export: str, unit: str) -> dict[str, Any]:
    """A unit's fit on a worker; its error returned, not raised (a unit's bad log is a
    result of the fleet, not a failure of the cluster)."""
    from threadpoolctl import threadpool_limits  # deferred: needed on the worker only

    try:
        with threadpool_limits(limits=1):  # one core per task: the cluster is the parallelism
            return fit_unit(log, method, export, unit)
    except Exception as exc:  # any error of one unit is reported, not raised
        return {"error": failure_of(exc), "traceback": traceback.format_exc()}


def run_fleet(
    logs: Sequence[str | os.PathLike[str]],
    store: FleetStore,
    *,
    method: str = "auto",
    export: str = "c",
    workers: int | None = None,
    scheduler: str | None = None,
    tls: TLSFiles | None = None,
    retry_failed: bool = False,
    on_unit: Callable[[str, str], None] | None = None,
    client: Any = None,
) -> FleetRun:
    """Fit every unit not yet in ``store`` on Dask, writing each result as it arrives.

    Parameters
    ----------
    logs : sequence of path-like
        One calibration log per unit, named by :func:`unit_names`; a log that ``store``
        holds a unit of keeps that unit's name. A log's side files among them (its truth,
        its metadata: :func:`split_side_files`) are left out and listed in
        :attr:`FleetRun.side_files`.
    store : FleetStore
        The results folder.
    method, export : str
        Fit method and export format (:data:`EXPORTS`).
    workers, scheduler : optional
        A local cluster of ``workers`` processes, or the cluster at ``scheduler``.
    tls : TLSFiles, optional
        Certificate files for a ``tls://`` scheduler (else Dask's configuration).
    retry_failed : bool
        Fit again the units that failed before (default: leave them failed).
    on_unit : callable, optional
        Called with (unit, "fitted" | "failed") as each unit finishes.
    client : distributed.Client, optional
        An existing client (tests); else one is made.

    Returns
    -------
    FleetRun
    """
    if export not in EXPORTS:
        raise ConfigError(f"export must be one of {', '.join(EXPORTS)}, got {export!r}")
    paths, side = split_side_files([str(Path(p)) for p in logs])
    names = unit_names(paths)
    store.open({"method": method, "export": export})
    names = _keep_known_names(store, paths, names)
    run = FleetRun(units=len(names), side_files=side)
    failed_before = set(store.failures())
    todo = []
    for name, path in zip(names, paths, strict=True):
        if store.is_done(name, path) or (name in failed_before and not retry_failed):
            run.skipped += 1
        else:
            todo.append((name, path))
    t0 = time.perf_counter()
    if todo:
        if client is not None:
            _submit(client, todo, store, method, export, run, on_unit)
        else:
            with dask_client(workers, scheduler, tls) as c:
                _submit(c, todo, store, method, export, run, on_unit)
    run.elapsed_s = time.perf_counter() - t0
    return run


def _keep_known_names(store: FleetStore, paths: list[str], names: list[str]) -> list[str]:
    """``names``, but a log that ``store`` holds a unit of keeps that unit's name (a unit's
    name depends on the other logs given with it; its files stay where they are)."""
    known = store.units_by_log()
    out = [known.get(os.path.abspath(p), n) for p, n in zip(paths, names, strict=True)]
    for i, j in itertools.combinations(range(len(out)), 2):
        if out[i] == out[j]:
            a, b = (i, j) if known.get(os.path.abspath(paths[i])) == out[i] else (j, i)
            raise ConfigError(
                f"{paths[b]} would be unit {out[b]!r}, but {store.root} holds unit {out[b]!r} "
                f"fitted from {paths[a]} (a unit keeps its name in its folder): fit these logs "
                "into another --out"
            )
    return out


def _submit(
    client: Any,
    todo: list[tuple[str, str]],
    store: FleetStore,
    method: str,
    export: str,
    run: FleetRun,
    on_unit: Callable[[str, str], None] | None,
) -> None:
    run.workers = len(client.scheduler_info().get("workers", {}))
    futures = {
        client.submit(_task, path, method, export, name, key=f"fleet-{name}-{time.time_ns()}"): (
            name,
            path,
        )
        for name, path in todo
    }
    try:
        _collect(futures, store, export, run, on_unit)
    finally:  # interrupted (Ctrl-C): what is not finished is cancelled, the rest is on disk
        if futures:
            client.cancel(list(futures))


def _collect(
    futures: dict[Any, tuple[str, str]],
    store: FleetStore,
    export: str,
    run: FleetRun,
    on_unit: Callable[[str, str], None] | None,
) -> None:
    """Write each unit's result as its future completes (``futures`` emptied as it goes)."""
    from distributed import as_completed  # deferred: Dask is heavy

    for fut in as_completed(list(futures)):
        name, path = futures.pop(fut)
        if fut.status == "finished" and "error" not in (result := fut.result()):
            store.write(name, path, result, export)
            run.fitted += 1
            status = "fitted"
        else:  # the unit's error, or the task's (a worker lost)
            if fut.status == "finished":
                msg, tb = result["error"], result["traceback"]
            else:
                msg = failure_of(fut.exception())
                tb = "".join(traceback.format_tb(fut.traceback()))
            store.write_failure(name, path, msg, tb)
            run.failed += 1
            status = "failed"
        fut.release()
        if on_unit is not None:
            on_unit(name, status)


# --------------------------------------------------------------------------- the report
@dataclass(frozen=True)
class FleetReport:
    """The fleet's tables.

    Attributes
    ----------
    verdicts : DataFrame
        One row per unit: ``unit``, ``verdict`` (``pass``, ``fail`` or ``failed``), ``why``.
    figures : DataFrame
        Long form, one row per unit, channel and figure (``heldout_rms``, ``thermal_span``,
        ``noise_density`` [unit·√s] in the log's unit, every physical coefficient in its own):
        ``unit, channel, model, unit_of, name, value``.
    distribution : DataFrame
        Per channel, model and figure (with its ``unit_of``) across units: ``n, mean, sd,
        min, median, max``.
    """

    verdicts: pd.DataFrame
    figures: pd.DataFrame
    distribution: pd.DataFrame


_KEYS = ("channel", "model", "name", "unit_of")  # one row of the distribution


def fleet_report(store: FleetStore, limits: FleetLimits | None = None) -> FleetReport:
    """Verdicts against ``limits`` and the distribution of every figure across units."""
    limits = limits or FleetLimits()
    rows, verdicts = [], []
    for unit, summ in store.summaries().items():
        why = []
        for c, ch in summ["channels"].items():
            figures = {
                "heldout_rms": ch.get("heldout_rms"),
                "thermal_span": ch.get("thermal_span"),
                "noise_density": ch.get("noise_density"),
            }
            # never the model's internals: an old summary without coefficients shows none
            for name, value in [*figures.items(), *ch.get("coefficients", {}).items()]:
                rows.append(
                    {
                        "unit": unit,
                        "channel": c,
                        "model": ch["model"],
                        "unit_of": coefficient_unit(name, ch.get("unit") or "", figures),
                        "name": name,
                        "value": np.nan if value is None else float(value),
                    }
                )
            held = ch.get("heldout_rms")
            held = ch.get("train_rms") if held is None else held
            checks = {
                "max_thermal_span": ch.get("thermal_span"),
                "max_heldout_rms": held,
                "max_noise_density": ch.get("noise_density"),
            }
            for key, limit in limits.for_channel(c).items():
                v = checks[key]
                if v is not None and np.isfinite(v) and v > limit:
                    what = key.removeprefix("max_").replace("_", " ")
                    why.append(f"{c} {what} {v:.4g} > {limit:.4g} {ch.get('unit') or ''}".rstrip())
        verdicts.append({"unit": unit, "verdict": "fail" if why else "pass", "why": "; ".join(why)})
    for unit, error in store.failures().items():
        verdicts.append({"unit": unit, "verdict": "failed", "why": error})
    figures = pd.DataFrame(rows, columns=["unit", "channel", "model", "unit_of", "name", "value"])
    dist = (
        figures.groupby(list(_KEYS), sort=False)["value"]
        .agg(n="count", mean="mean", sd="std", min="min", median="median", max="max")
        .reset_index()
        if not figures.empty
        else pd.DataFrame(columns=[*_KEYS, "n", "mean", "sd", "min", "median", "max"])
    )
    verd = pd.DataFrame(verdicts, columns=["unit", "verdict", "why"]).sort_values("unit")
    return FleetReport(verd.reset_index(drop=True), figures, dist)


def write_fleet_report(store: FleetStore, report: FleetReport, page: str) -> dict[str, Path]:
    """Write ``report.html`` (the rendered ``page``), ``verdicts.csv``, ``figures.csv`` and
    ``distribution.csv``."""
    html_path = store.root / "report.html"
    write_atomic(html_path, lambda tmp: tmp.write_text(page, encoding="utf-8"))
    out = {"report": html_path}
    for name, frame in (
        ("verdicts", report.verdicts),
        ("figures", report.figures),
        ("distribution", report.distribution),
    ):
        path = store.root / f"{name}.csv"
        write_atomic(path, lambda tmp, f=frame: f.to_csv(tmp, index=False, lineterminator="\n"))
        out[name] = path
    return out


def failure_of(exc: BaseException) -> str:
    """A one-line error for a unit (the message a RinscalError carries, else its type too)."""
    return str(exc) if isinstance(exc, RinscalError) else f"{type(exc).__name__}: {exc}"

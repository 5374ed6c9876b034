"""CLI commands: fit, select, compensate, evaluate, export (thermal calibration).

Thin wrappers over :mod:`rinscal.calibration`: read the log (through a column mapping for a
foreign log), call a library function that returns data, print a table or JSON, write files
atomically. Library errors become messages and exit code 2.
"""

from __future__ import annotations

import contextlib
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from rinscal.cli._app import app, print_table
from rinscal.cli._options import (
    ColOpt,
    InstanceOpt,
    LogArg,
    MapOpt,
    PolicyOpt,
    RelTimeOpt,
    SepOpt,
    TempColOpt,
    TimeColOpt,
    TimeUnitOpt,
    refuse_inputs,
)

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd

    from rinscal.calibration.modelfile import ThermalModelFile
    from rinscal.io.tables import SourceLog

_METHODS = ("auto", "poly-t", "sectional", "regression", "neural", "px4", "ardupilot")

ModelOpt = Annotated[Path, typer.Option("--model", "-m", help="Thermal model file (JSON).")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")]
IgnoreUnitsOpt = Annotated[
    bool,
    typer.Option(
        "--ignore-units",
        help="Compensate even where the log's units (metadata or mapping) differ from the model's.",
    ),
]


def _read(
    log: Path,
    map_file: Path | None,
    col: list[str] | None,
    time_col: str | None,
    time_unit: str | None,
    sep: str | None,
    temp_col: str | None,
    relative_time: bool = False,
    instance: str | None = None,
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Read a log and its metadata (units from the mapping when there is no sidecar)."""
    from rinscal.io.foreign import read_foreign_source

    src, meta = read_foreign_source(
        log,
        map_file,
        col,
        time_col,
        time_unit,
        sep,
        temp_col,
        relative_time=relative_time,
        instance=instance,
    )
    return src.log, meta


def _static_options(
    latitude: float | None, heading: float | None, static_ref: str | None
) -> dict[str, Any]:
    """Metadata for the static reference from ``--latitude/--heading`` and ``--static-ref``."""
    from rinscal.cli._app import fail
    from rinscal.schema import CHANNELS

    out: dict[str, Any] = {}
    if (latitude is None) != (heading is None):
        raise fail("--latitude and --heading go together (the static output needs both)")
    if latitude is not None:
        out["latitude_deg"], out["heading_deg"] = float(latitude), float(heading or 0.0)
    if static_ref is not None:
        text = static_ref.strip()
        if text == "mean":
            out["static_reference"] = "mean"
            return out
        given: dict[str, float] = {}
        for item in filter(None, (v.strip() for v in text.split(","))):
            ch, eq, val = item.partition("=")
            try:
                number = float(val)
            except ValueError:
                number = math.nan
            if not eq or ch.strip() not in CHANNELS or not math.isfinite(number):
                raise fail(
                    f"--static-ref: {item!r} is not CHANNEL=VALUE with a channel among "
                    f"{', '.join(CHANNELS)} and a finite number (or give 'mean')"
                )
            given[ch.strip()] = number
        out["static_reference"] = given
    return out


def _ints(text: str | None, option: str) -> tuple[int, ...] | None:
    from rinscal.cli._app import fail

    if text is None:
        return None
    try:
        return tuple(int(v) for v in text.split(","))
    except ValueError:
        raise fail(f"{option}: {text!r} is not a comma-separated list of integers") from None


def _floats(text: str | None, option: str) -> tuple[float, ...] | None:
    from rinscal.cli._app import fail

    if text is None:
        return None
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise fail(f"{option}: {text!r} is not a comma-separated list of numbers") from None


def model_label(cm: Any) -> str:
    """A channel's model in words: the auto choice, or the method and its settings."""
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


def _fmt(v: Any, digits: int = 4) -> str:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return str(v)
    if f != f:  # NaN
        return "-"
    return f"{f:.{digits}g}"


@app.command("fit")
def fit(
    log: LogArg,
    out: Annotated[Path, typer.Option("--out", "-o", help="Model file to write (JSON).")],
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help="auto (each channel's model chosen by held-out error), poly-t, sectional, "
            "regression, neural, px4 or ardupilot.",
        ),
    ] = "auto",
    candidates: Annotated[
        str | None,
        typer.Option(
            "--candidates",
            help="auto: candidate families, e.g. none,px4,ardupilot,poly-t,regression,neural "
            "(default all but neural).",
        ),
    ] = None,
    tolerance: Annotated[
        float,
        typer.Option(
            "--tolerance",
            min=0.0,
            max=0.99,
            help="auto: also take a simpler model within this relative tolerance of the best "
            "held-out mean square error (on top of the paired test, which always applies).",
        ),
    ] = 0.0,
    temp_range: Annotated[
        str,
        typer.Option("--temp-range", help="Plausible temperature readings LO,HI in °C."),
    ] = "-60,150",
    orders: Annotated[
        str | None,
        typer.Option(
            "--orders",
            help="regression p,q,s; sectional p,q; poly-t degree (default by sensor type).",
        ),
    ] = None,
    hidden: Annotated[
        int | None,
        typer.Option(
            "--hidden", min=1, max=64, help="neural: hidden neurons, 1-64 (default 2 / 6)."
        ),
    ] = None,
    edges: Annotated[
        str | None,
        typer.Option("--edges", help="sectional: segment edges in °C, e.g. 3.5,10.5,17.5."),
    ] = None,
    window: Annotated[
        float,
        typer.Option("--window", min=1.0, max=3600.0, help="Temperature-rate window [s], 1-3600."),
    ] = 60.0,
    causal: Annotated[
        bool, typer.Option("--causal", help="Causal temperature rate (for real-time use).")
    ] = False,
    no_gradient: Annotated[
        bool, typer.Option("--no-gradient", help="Leave out the gradient ΔT.")
    ] = False,
    max_samples: Annotated[
        int | None,
        typer.Option(
            "--max-samples", min=100, help="neural: decimate training to this many rows (≥ 100)."
        ),
    ] = None,
    seed: Annotated[
        int, typer.Option("--seed", min=0, help="neural: seed of the first start (≥ 0).")
    ] = 0,
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
    relative_time: RelTimeOpt = False,
    instance: InstanceOpt = None,
    latitude: Annotated[
        float | None,
        typer.Option(
            "--latitude",
            min=-90.0,
            max=90.0,
            help="Site latitude [deg] (with --heading): the static output (gravity, Earth "
            "rate) compensation keeps; for a log without it in its metadata.",
        ),
    ] = None,
    heading: Annotated[
        float | None,
        typer.Option(
            "--heading",
            min=-360.0,
            max=360.0,
            help="Heading of the IMU's x axis on the table [deg from north] (with --latitude).",
        ),
    ] = None,
    static_ref: Annotated[
        str | None,
        typer.Option(
            "--static-ref",
            help="Static output compensation keeps, in log units: 'mean' (each channel's "
            "training mean) or CHANNEL=VALUE pairs, e.g. accel_z=-9.7949,gyro_z=0.",
        ),
    ] = None,
) -> None:
    """Fit a thermal model per channel and write it as a JSON model file.

    With --method auto (the default) each channel gets the model of least held-out error
    among no compensation, the PX4 and ArduPilot fits, cubic-type polynomials in T and the
    paper's regression, the simplest within noise of the best.
    """
    import warnings

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from rinscal.calibration.thermal.features import DerivativeConfig, MissingGradientWarning
    from rinscal.calibration.thermal.guards import TrainingDataWarning
    from rinscal.calibration.thermal.model import ThermalModel
    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.errors import RinscalError
    from rinscal.io.streaming import by_runs

    if method not in _METHODS:
        raise fail(f"--method must be one of {', '.join(_METHODS)}, got {method!r}")
    lo_hi = _floats(temp_range, "--temp-range")
    if lo_hi is None or len(lo_hi) != 2 or not lo_hi[0] < lo_hi[1]:
        raise fail(f"--temp-range must be LO,HI in °C with LO < HI, got {temp_range!r}")
    fams = None if candidates is None else tuple(v.strip() for v in candidates.split(","))
    if fams is not None and method != "auto":
        raise fail("--candidates applies to --method auto only")
    inputs = [log] + ([map_file] if map_file is not None else [])
    refuse_inputs(out, inputs)
    params: dict[str, Any] = {}
    if max_samples is not None:
        params["max_samples"] = max_samples
    try:
        with Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total}"),
            TimeElapsedColumn(),
            console=err_console,
            transient=True,
        ) as progress:
            task = progress.add_task("reading log", total=None)
            mapping, meta = _mapping_meta(
                log, (map_file, col, time_col, time_unit, sep, temp_col), relative_time, instance
            )
            meta.update(_static_options(latitude, heading, static_ref))
            model = ThermalModel(
                method,
                orders=_ints(orders, "--orders"),
                hidden=hidden,
                edges=_floats(edges, "--edges"),
                derivative=DerivativeConfig(window, "causal" if causal else "centred"),
                use_gradient=False if no_gradient else None,
                random_state=seed,
                estimator_params=params or None,
                tolerance=tolerance,
                temp_range=(lo_hi[0], lo_hi[1]),
                **({"candidates": fams} if fams is not None else {}),
            )

            def runs(sources: Iterator[SourceLog]) -> Iterator[tuple[pd.DataFrame, int]]:
                # no enumerate: its reused result tuple would hold the last run while the
                # next is read (two runs in memory at once)
                k = 0
                for src in sources:
                    k += 1
                    progress.update(task, description=f"features of run {k}")
                    yield src.log, src.first_row
                    del src  # nor this frame

            def step(channel: str) -> None:
                progress.update(task, advance=1, description=f"fitted {channel}")
                progress.update(task, total=len(model.channels))

            with warnings.catch_warnings(record=True) as fit_warnings:
                warnings.simplefilter("always", TrainingDataWarning)
                warnings.simplefilter("always", MissingGradientWarning)
                by_runs(  # run by run: memory bounded by the longest run
                    log,
                    mapping,
                    lambda s: model.fit_runs(runs(s), meta, on_channel=step, source=str(log)),
                )
            mf = model.to_file(source={"log": log.name})
            mf.save(out)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for w in fit_warnings:
        if issubclass(w.category, MissingGradientWarning):
            err_console.print(styled("warning:", "yellow", f" {w.message}"), highlight=False)
    for w in fit_warnings:
        if issubclass(w.category, TrainingDataWarning):
            err_console.print(
                styled("warning:", "yellow", f" {log}: {w.message}"),
                highlight=False,
            )
    table = Table(title=f"{method} model of {log.name}: training residual (Eq. 16)")
    cols = ["channel", "model", "samples", "masked", "T range [°C]", "RMS*"]
    if method == "auto":
        cols += ["held-out", "none held-out"]
    for name in cols:
        left = name in ("channel", "model", "T range [°C]")
        table.add_column(name, justify="left" if left else "right")
    for c in mf.channels:
        cm = mf.models[c]
        m = cm.metrics
        row = [
            f"{c} ({cm.unit or '?'})",
            model_label(cm),
            f"{int(m['n_train']):,}",
            f"{int(m['n_outliers']):,}",
            f"{cm.train_range[0, 0]:.2f} .. {cm.train_range[0, 1]:.2f}",
            _fmt(m["rms_train_about_run_mean"]),
        ]
        if method == "auto" and cm.selection is not None:
            by_name = {r["name"]: r for r in cm.selection["table"]}
            row += [
                _fmt(by_name[cm.selection["chosen"]]["heldout_rms"]),
                _fmt(by_name.get("none", {}).get("heldout_rms")),
            ]
        table.add_row(*row)
    print_table(console, table)
    note = (
        "masked: outlier samples left out of the fit; RMS* of the training residual about "
        "each run's mean (turn-on offsets removed)."
    )
    if method == "auto":
        first = next(iter(mf.models.values())).selection or {}
        scheme, parts = first.get("scheme", "?"), len(first.get("folds", []))
        how = (
            f"leave-one-leg-out, scored on {parts} blocks"
            if scheme == "legs"
            else f"{scheme} over {parts} folds"
        )
        note += (
            f" Held-out: RMS of 60 s means of the residual, {how} (rinscal select LOG "
            "--method auto shows every candidate)."
        )
    console.print(f"{note} wrote {out}", highlight=False, soft_wrap=True)


@app.command("select")
def select(
    log: LogArg,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help="auto (every candidate of fit --method auto, held-out folds as there), "
            "regression or neural.",
        ),
    ] = "auto",
    tolerance: Annotated[
        float | None,
        typer.Option(
            "--tolerance",
            min=0.0,
            max=0.99,
            help="Recommend the smallest setting within this relative tolerance of the best "
            "held-out RMS (regression/neural: default 0.02; auto: of the mean square error, "
            "default 0, on top of the paired test).",
        ),
    ] = None,
    candidates: Annotated[
        str | None,
        typer.Option("--candidates", help="auto: candidate families (as fit --candidates)."),
    ] = None,
    settings: Annotated[
        str | None,
        typer.Option("--settings", help="Orders or neuron counts to try, e.g. 1,2,3,4."),
    ] = None,
    window: Annotated[
        float,
        typer.Option("--window", min=1.0, max=3600.0, help="Temperature-rate window [s], 1-3600."),
    ] = 60.0,
    max_samples: Annotated[
        int | None,
        typer.Option(
            "--max-samples", min=100, help="neural: decimate training to this many rows (≥ 100)."
        ),
    ] = 20000,
    seed: Annotated[
        int, typer.Option("--seed", min=0, help="neural: seed of the first start (≥ 0).")
    ] = 0,
    as_json: JsonOpt = False,
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
    relative_time: RelTimeOpt = False,
    instance: InstanceOpt = None,
) -> None:
    """Held-out RMS per channel: of every auto candidate, or of orders 1-4 / 1-8 neurons."""
    import warnings

    if method == "auto":
        _select_auto(
            log,
            0.0 if tolerance is None else tolerance,
            candidates,
            window,
            seed,
            as_json,
            (map_file, col, time_col, time_unit, sep, temp_col, relative_time, instance),
        )
        return
    tolerance = 0.02 if tolerance is None else tolerance
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from rinscal.calibration.selection.heldout import (
        DEFAULT_SETTINGS,
        select_model,
        select_regression_runs,
    )
    from rinscal.calibration.thermal.features import DerivativeConfig, MissingGradientWarning
    from rinscal.calibration.thermal.model import unit_factors
    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.errors import RinscalError
    from rinscal.io.streaming import by_runs
    from rinscal.io.tables import read_log_source

    if method not in DEFAULT_SETTINGS:
        raise fail(f"--method must be regression or neural, got {method!r}")
    tried = _ints(settings, "--settings") or DEFAULT_SETTINGS[method]
    params = {"max_samples": max_samples} if method == "neural" else None
    try:
        with Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total}"),
            TimeElapsedColumn(),
            console=err_console,
            transient=True,
        ) as progress:
            task = progress.add_task("reading log", total=None)
            mapping, meta = _mapping_meta(
                log, (map_file, col, time_col, time_unit, sep, temp_col), relative_time, instance
            )

            def step(channel: str, setting: int) -> None:
                progress.update(task, advance=1, description=f"{channel}: {setting}")
                progress.update(task, total=6 * len(tried))

            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", MissingGradientWarning)
                if method == "regression":  # run by run, from per-run factors
                    res = by_runs(
                        log,
                        mapping,
                        lambda runs: select_regression_runs(
                            (s.log for s in runs),
                            tried,
                            tolerance,
                            derivative=DerivativeConfig(window),
                            on_fit=step,
                        ),
                    )
                else:
                    res = select_model(
                        read_log_source(log, mapping).log,
                        method,
                        tried,
                        tolerance,
                        derivative=DerivativeConfig(window),
                        random_state=seed,
                        estimator_params=params,
                        on_fit=step,
                    )
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for w in caught:
        if issubclass(w.category, MissingGradientWarning):
            err_console.print(styled("warning:", "yellow", f" {w.message}"), highlight=False)
    units, _ = unit_factors(meta)
    if as_json:
        doc = res.to_dict()
        doc["units"] = units
        typer.echo(json.dumps(doc, indent=1))
        return
    what = "orders p=q=s" if method == "regression" else "hidden neurons n"
    table = Table(
        title=f"{method} selection on {log.name}: RMS (Eq. 16) about each run's mean, "
        f"held-out = leave-one-run-out over {len(res.runs)} runs"
    )
    table.add_column("channel")
    table.add_column(what, justify="right")
    table.add_column("train RMS", justify="right")
    table.add_column("held-out RMS", justify="right")
    table.add_column("", justify="left")
    for c, grp in res.table.groupby("channel", sort=False):
        for _, r in grp.iterrows():
            mark = []
            if r["setting"] == res.recommended[c]:
                mark.append("recommended")
            if r["setting"] == res.best[c]:
                mark.append("best")
            table.add_row(
                f"{c} ({units.get(c) or '?'})",
                str(int(r["setting"])),
                _fmt(r["rms_train"], 5),
                _fmt(r["rms_heldout"], 5),
                ", ".join(mark),
            )
        table.add_section()
    print_table(console, table)
    console.print(
        f"recommended: smallest setting within {tolerance:.1%} of the best held-out RMS",
        highlight=False,
    )


def _select_auto(
    log: Path,
    tolerance: float,
    candidates: str | None,
    window: float,
    seed: int,
    as_json: bool,
    read_args: tuple[Any, ...],
) -> None:
    """``select --method auto``: every candidate's held-out RMS, the choice and the fallback."""
    import warnings

    from rich.table import Table

    from rinscal.calibration.thermal.features import DerivativeConfig
    from rinscal.calibration.thermal.model import ThermalModel
    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.errors import RinscalError

    fams = None if candidates is None else tuple(v.strip() for v in candidates.split(","))
    try:
        with err_console.status("selecting (held-out fits of every candidate)"):
            df, meta = _read(log, *read_args)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                model = ThermalModel(
                    "auto",
                    derivative=DerivativeConfig(window),
                    random_state=seed,
                    tolerance=tolerance,
                    **({"candidates": fams} if fams is not None else {}),
                )
                mf = model.fit(df, meta, source=str(log)).to_file()
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for w in caught:
        if issubclass(w.category, UserWarning):
            err_console.print(styled("warning:", "yellow", f" {w.message}"), highlight=False)
    if as_json:
        doc = {
            "log": log.name,
            "rms": "held-out RMS of 60 s means of the residual about each part's mean, log units",
            "channels": {
                c: {"unit": mf.models[c].unit, **(mf.models[c].selection or {})}
                for c in mf.channels
            },
        }
        typer.echo(json.dumps(doc, indent=1))
        return
    for c in mf.channels:
        sel = mf.models[c].selection or {}
        table = Table(
            title=f"{c} ({mf.models[c].unit or '?'}): held-out RMS of 60 s means, "
            f"{sel.get('scheme')}, {len(sel.get('folds', []))} scored parts "
            f"({', '.join(sel.get('folds', []))})"
        )
        for name in ("candidate", "params", "held-out RMS", "per fold", "train RMS", ""):
            table.add_column(
                name, justify="left" if name in ("candidate", "per fold", "") else "right"
            )
        rows = sorted(
            sel.get("table", []),
            key=lambda r: (r["heldout_rms"] is None, r["heldout_rms"] or 0.0),
        )
        for r in rows:
            mark = []
            if r["name"] == sel.get("chosen"):
                mark.append("chosen")
            if r["name"] == sel.get("fallback"):
                mark.append("fallback")
            table.add_row(
                r["name"],
                str(r["n_params"]),
                _fmt(r["heldout_rms"], 5),
                " ".join(_fmt(v, 3) for v in r["fold_rms"]),
                _fmt(r["train_rms"], 5),
                ", ".join(mark),
            )
        print_table(console, table)
    console.print(
        "chosen: among the models a paired t-test (90 %, log ratios over the folds) cannot "
        "tell from the best held-out error"
        f"{f' or within {tolerance:.1%} of it' if tolerance else ''}: none, then ArduPilot's "
        "fit, then PX4's, then the fewest thermal parameters; "
        "fallback: the same among models of T alone, used outside the training domain "
        "(compensate --policy fallback)",
        highlight=False,
        soft_wrap=True,
    )


@app.command("compensate")
def compensate_cmd(
    log: LogArg,
    model: ModelOpt,
    out: Annotated[Path, typer.Option("--out", "-o", help="Compensated log to write.")],
    policy: PolicyOpt = "clamp",
    causal: Annotated[
        bool, typer.Option("--causal", help="Use the causal temperature rate (as in real time).")
    ] = False,
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
    relative_time: RelTimeOpt = False,
    instance: InstanceOpt = None,
    ignore_units: IgnoreUnitsOpt = False,
) -> None:
    """Compensate every sensor channel (Eq. 10); add the out_of_range flag column."""
    from rinscal.calibration.compensate import FLAG_COLUMN, check_units, describe_reference
    from rinscal.calibration.modelfile import POLICIES
    from rinscal.cli._app import console, err_console, fail
    from rinscal.errors import RangeError, RinscalError
    from rinscal.io.metadata import meta_path, write_meta
    from rinscal.io.streaming import by_runs

    if policy not in POLICIES:
        raise fail(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    inputs = [log, meta_path(log), model] + ([map_file] if map_file is not None else [])
    refuse_inputs(out, inputs, also=[meta_path(out)])
    try:
        mf, mapping, meta = _model_for(
            model, log, (map_file, col, time_col, time_unit, sep, temp_col), relative_time, instance
        )
        if not ignore_units:
            check_units(mf, meta, str(log))
        kind = "causal" if causal else None
        rows, shares = by_runs(  # run by run: memory bounded by the longest run
            log, mapping, lambda s: _compensate_runs(s, mf, policy, kind, out, FLAG_COLUMN)
        )
        if meta:
            meta = dict(meta)
            meta["compensated"] = {
                "model": model.name,
                "sha256": mf.to_dict()["sha256"],
                "method": mf.method,
                "policy": policy,
                "derivative": "causal" if causal else mf.derivative_kind,
            }
            write_meta(meta, out)
    except RangeError as exc:  # about a data row of LOG: name the file
        raise fail(f"{log}: {exc}") from None
    except RinscalError as exc:
        raise fail(str(exc)) from None
    n_flag = sum(k for k, _ in shares.values())
    console.print(
        f"wrote {out}: {rows:,} rows, {len(mf.channels)} channel(s) compensated with the "
        f"{mf.method} model; {n_flag:,} row(s) outside the training data ({policy})",
        highlight=False,
        soft_wrap=True,
    )
    for run, (k, n) in shares.items():
        console.print(f"  {run}: {k / n:.1%} of rows flagged", highlight=False)
    summary, missing = describe_reference(mf)
    console.print(summary, highlight=False, soft_wrap=True)
    if missing:
        err_console.print(
            f"warning: {', '.join(missing)}: the model has no static reference, so their "
            "static level (gravity, Earth rate) was removed with the thermal bias; refit with "
            "--latitude/--heading or --static-ref to keep it",
            highlight=False,
            soft_wrap=True,
            markup=False,
        )


def _model_for(
    model: Path,
    log: Path,
    read_args: tuple[Any, ...],
    relative_time: bool,
    instance: str | None = None,
) -> tuple[ThermalModelFile, Any, dict[str, Any]]:
    """A model file, and the mapping and metadata to read ``log`` with (for its units)."""
    from rinscal.calibration.modelfile import ThermalModelFile

    mf = ThermalModelFile.load(model)
    return mf, *_mapping_meta(log, read_args, relative_time, instance)


def _mapping_meta(
    log: Path, read_args: tuple[Any, ...], relative_time: bool, instance: str | None
) -> tuple[Any, dict[str, Any]]:
    """How to read ``log`` (a column mapping, flight-log options or None) and its metadata."""
    from rinscal.io.foreign import foreign_mapping, foreign_meta

    mapping = foreign_mapping(*read_args, relative_time=relative_time, instance=instance, log=log)
    return mapping, foreign_meta(log, mapping)


def _compensate_runs(
    sources: Iterator[SourceLog],
    mf: ThermalModelFile,
    policy: str,
    kind: str | None,
    out: Path,
    flag_column: str,
) -> tuple[int, dict[str, tuple[int, int]]]:
    """Compensate runs as they are read and write each at once (the file's own table back,
    its channels compensated, nothing else touched); rows written, and per run the rows
    flagged out of range and the rows."""
    from rinscal.calibration.compensate import compensated_channels
    from rinscal.io.streaming import LogStreamWriter
    from rinscal.io.tables import format_of

    shares: dict[str, tuple[int, int]] = {}
    writer: LogStreamWriter | None = None
    with contextlib.ExitStack() as stack:
        for src in sources:
            if writer is None:
                same_kind = format_of(out) != "parquet" and src.sep is not None
                writer = stack.enter_context(
                    LogStreamWriter(out, validate=False, sep=src.sep if same_kind else None)
                )
            values, flagged = compensated_channels(
                src.log,
                mf,
                policy,
                kind,
                first_row=src.first_row,  # type: ignore[arg-type]
            )
            writer.write(src.write_back(values, {flag_column: flagged}))
            runs = src.log["run"]
            for run, k, n in zip(*_run_counts(runs, flagged), strict=True):
                k0, n0 = shares.get(run, (0, 0))
                shares[run] = (k0 + k, n0 + n)
        rows = writer.rows if writer is not None else 0
    return rows, shares


def _run_counts(run: pd.Series, flagged: np.ndarray) -> tuple[list[str], list[int], list[int]]:
    """Each run's name, flagged rows and rows, in order of first appearance."""
    import numpy as np
    import pandas as pd

    codes, names = pd.factorize(run, sort=False)
    k = np.bincount(codes, weights=flagged, minlength=len(names))
    n = np.bincount(codes, minlength=len(names))
    return [str(v) for v in names], [int(v) for v in k], [int(v) for v in n]


@app.command("evaluate")
def evaluate_cmd(
    log: LogArg,
    model: ModelOpt,
    policy: PolicyOpt = "clamp",
    causal: Annotated[
        bool, typer.Option("--causal", help="Use the causal temperature rate.")
    ] = False,
    step_window: Annotated[
        float,
        typer.Option(
            "--step-window",
            min=1.0,
            max=86400.0,
            help="Fit window on each side of an edge [s], 1-86400.",
        ),
    ] = 120.0,
    allan_plot: Annotated[
        Path | None,
        typer.Option(
            "--allan-plot",
            help="Write the Allan deviation of raw and compensated output (log-log, one "
            "panel per channel, longest run) to this PNG.",
        ),
    ] = None,
    as_json: JsonOpt = False,
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
    relative_time: RelTimeOpt = False,
    instance: InstanceOpt = None,
    ignore_units: IgnoreUnitsOpt = False,
) -> None:
    """RMS (Eq. 16, about each run's mean) before/after compensation; steps at segment edges.

    Also: each channel's model (the auto choice), the share of samples outside the training
    data per run, and the Allan deviation noise parameters of raw and compensated output.
    """
    from rich.table import Table

    from rinscal.calibration.compensate import check_units
    from rinscal.calibration.evaluate import StepConfig, evaluate_runs
    from rinscal.calibration.modelfile import POLICIES
    from rinscal.cli._app import console, fail
    from rinscal.errors import RangeError, RinscalError
    from rinscal.io.streaming import by_runs

    if policy not in POLICIES:
        raise fail(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    inputs = [log, model] + ([map_file] if map_file is not None else [])
    if allan_plot is not None:
        refuse_inputs(allan_plot, inputs)
    try:
        mf, mapping, meta = _model_for(
            model, log, (map_file, col, time_col, time_unit, sep, temp_col), relative_time, instance
        )
        if not ignore_units:
            check_units(mf, meta, str(log))
        deriv = "causal" if causal else None
        step = StepConfig(window_s=step_window)
        res, allan, curves = by_runs(  # run by run: memory bounded by the longest run
            log,
            mapping,
            lambda runs: evaluate_runs(
                ((s.log, s.first_row) for s in runs),
                mf,
                policy,  # type: ignore[arg-type]
                deriv,
                step,
            ),
        )
        if allan_plot is not None:
            _write_allan_plot(allan_plot, curves, mf, log.name)
    except RangeError as exc:  # about a data row of LOG: name the file
        raise fail(f"{log}: {exc}") from None
    except RinscalError as exc:
        raise fail(str(exc)) from None
    labels = {c: model_label(mf.models[c]) for c in mf.channels}
    if as_json:
        doc = {
            "log": log.name,
            "model": model.name,
            "method": mf.method,
            "channel_models": labels,
            "policy": policy,
            "rms": "Eq. 16 about each run's mean, inlier samples, log units",
            "step": f"difference of {step_window:g} s linear fits before/after an edge crossing",
            "out_of_range": "samples outside the training range or joint domain",
            "rows": json.loads(res.to_json(orient="records")),
            "allan": json.loads(allan.to_json(orient="records")),
        }
        typer.echo(json.dumps(doc, indent=1))
        return
    steps = bool((res["crossings"] > 0).any())  # step columns only where edges are crossed
    table = Table(
        title=f"{mf.method} model on {log.name}: RMS about each run's mean (Eq. 16); "
        + ("largest step at a segment edge; " if steps else "")
        + "share outside the training data"
    )
    names = ["run", "channel", "model", "RMS before", "RMS after", "after/ before", "flagged"]
    if steps:
        names += ["edges crossed", "step raw", "step comp."]
    for name in names:
        table.add_column(name, justify="left" if name in ("run", "channel", "model") else "right")
    for _, r in res.iterrows():
        cells = [
            str(r["run"]),
            f"{r['channel']} ({r['unit'] or '?'})",
            labels[r["channel"]],
            _fmt(r["rms_before"]),
            _fmt(r["rms_after"]),
            _fmt(r["ratio"], 3),
            f"{r['out_of_range'] / max(r['samples'], 1):.1%}",
        ]
        if steps:
            cells += [
                str(int(r["crossings"])),
                _fmt(r["max_step_before"], 3),
                _fmt(r["max_step_after"], 3),
            ]
        table.add_row(*cells)
    print_table(console, table)
    if not allan.empty:
        at = Table(
            title="Allan deviation (overlapping), IEEE Std 952 slopes: N random walk "
            "[unit·√s] at τ = 1 s, B bias instability [unit] (at τ), K rate random walk "
            "[unit/√s] at τ = 3 s; '-' where the curve has no such region"
        )
        for name in ("run", "channel", "output", "N", "B", "τ(B) [s]", "K"):
            at.add_column(name, justify="left" if name in ("run", "channel", "output") else "right")
        for _, r in allan.iterrows():
            at.add_row(
                str(r["run"]),
                f"{r['channel']} ({r['unit'] or '?'})",
                str(r["output"]),
                _fmt(r["n"], 3),
                _fmt(r["b"], 3),
                _fmt(r["b_tau_s"], 3),
                _fmt(r["k"], 3),
            )
        print_table(console, at)
    if allan_plot is not None:
        console.print(f"wrote {allan_plot}", highlight=False)


def _write_allan_plot(path: Path, curves: Any, mf: Any, name: str) -> None:
    """The Allan figure of the longest run, written atomically."""
    from rinscal.io.atomic import write_atomic
    from rinscal.report.allan_plot import allan_figure

    if not curves:
        return
    run = max(
        curves,
        key=lambda r: max((len(v) for c in curves[r].values() for v in c.values()), default=0),
    )
    units = {c: mf.models[c].unit or "?" for c in mf.channels}
    fig = allan_figure(curves[run], units, title=f"{name}, run {run}: Allan deviation")
    write_atomic(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110))


@app.command("export")
def export_cmd(
    model: Annotated[Path, typer.Argument(metavar="MODEL", help="Thermal model file (JSON).")],
    fmt: Annotated[str, typer.Option("--format", help="px4, ardupilot or c.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="File to write.")],
    gyro_id: Annotated[
        int | None,
        typer.Option(
            "--gyro-id",
            help="PX4 TC_G0_ID: the gyro's device id (device_id of sensor_gyro in a ULog, or "
            "CAL_GYRO0_ID). Default: the model's source device_ids; required for px4.",
        ),
    ] = None,
    accel_id: Annotated[
        int | None,
        typer.Option(
            "--accel-id",
            help="PX4 TC_A0_ID: the accelerometer's device id (device_id of sensor_accel in a "
            "ULog, or CAL_ACC0_ID). Default: the model's source device_ids; required for px4.",
        ),
    ] = None,
    instance: Annotated[
        int | None,
        typer.Option(
            "--instance",
            help="The IMU instance, numbered as the readers' --instance (0-based): px4 writes "
            "the set TC_G<N>/TC_A<N> (0-3), ardupilot INS_TCAL<N+1>_* (0-2; IMUs 4 and 5 are "
            "refused). Default: the instance the model was fitted on (.bin/.ulg), else 0.",
        ),
    ] = None,
    imu: Annotated[
        int | None, typer.Option("--imu", hidden=True, help="Old, 1-based, ArduPilot IMU.")
    ] = None,
    prefix: Annotated[str, typer.Option("--prefix", help="C identifier prefix.")] = "rinscal",
) -> None:
    """Export a model: PX4 .params, ArduPilot .parm (poly-t/px4/ardupilot) or a C header."""
    import warnings

    from rinscal.calibration.export import (
        SmallCoefficientWarning,
        to_ardupilot_parm,
        to_c_header,
        to_px4_params,
    )
    from rinscal.calibration.modelfile import ThermalModelFile
    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.errors import RinscalError
    from rinscal.io.atomic import write_atomic

    if fmt not in ("px4", "ardupilot", "c"):
        raise fail(f"--format must be px4, ardupilot or c, got {fmt!r}")
    if imu is not None:
        raise fail(
            f"--imu is now --instance, numbered from 0 as the log readers do: --imu {imu} is "
            f"--instance {imu - 1}"
        )
    refuse_inputs(out, [model])
    try:
        mf = ThermalModelFile.load(model)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SmallCoefficientWarning)
            if fmt == "px4":
                text = to_px4_params(mf, gyro_id, accel_id, instance)
            elif fmt == "ardupilot":
                text = to_ardupilot_parm(mf, instance)
            else:
                text = to_c_header(mf, prefix)
        write_atomic(out, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for w in caught:
        if issubclass(w.category, SmallCoefficientWarning):
            err_console.print(styled("warning:", "yellow", f" {w.message}"), highlight=False)
    console.print(f"wrote {out} ({fmt}, {mf.method} model)", highlight=False)

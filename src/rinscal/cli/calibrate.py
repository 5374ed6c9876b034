"""CLI commands: fit, select, compensate, evaluate, export (thermal calibration).

Thin wrappers over :mod:`rinscal.calibration`: read the log (through a column mapping for a
foreign log), call a library function that returns data, print a table or JSON, write files
atomically. Library errors become messages and exit code 2.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.markup import escape

from rinscal.cli._app import app
from rinscal.cli._options import (
    ColOpt,
    LogArg,
    MapOpt,
    SepOpt,
    TempColOpt,
    TimeColOpt,
    TimeUnitOpt,
    read_foreign_log,
    refuse_inputs,
)

if TYPE_CHECKING:
    import pandas as pd

_METHODS = ("poly-t", "sectional", "regression", "neural")

ModelOpt = Annotated[Path, typer.Option("--model", "-m", help="Thermal model file (JSON).")]
PolicyOpt = Annotated[
    str,
    typer.Option("--policy", help="Outside the training range: clamp, extrapolate or error."),
]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")]


def _read(
    log: Path,
    map_file: Path | None,
    col: list[str] | None,
    time_col: str | None,
    time_unit: str | None,
    sep: str | None,
    temp_col: str | None,
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Read a log and its metadata (units from the mapping when there is no sidecar)."""
    return read_foreign_log(log, map_file, col, time_col, time_unit, sep, temp_col)


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
    method: Annotated[
        str, typer.Option("--method", help="poly-t, sectional, regression or neural.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Model file to write (JSON).")],
    orders: Annotated[
        str | None,
        typer.Option(
            "--orders",
            help="regression p,q,s; sectional p,q; poly-t degree (default by sensor type).",
        ),
    ] = None,
    hidden: Annotated[
        int | None, typer.Option("--hidden", help="neural: hidden neurons (default 2 / 6).")
    ] = None,
    edges: Annotated[
        str | None,
        typer.Option("--edges", help="sectional: segment edges in °C, e.g. 3.5,10.5,17.5."),
    ] = None,
    window: Annotated[
        float, typer.Option("--window", help="Temperature-rate window, seconds.")
    ] = 60.0,
    causal: Annotated[
        bool, typer.Option("--causal", help="Causal temperature rate (for real-time use).")
    ] = False,
    no_gradient: Annotated[
        bool, typer.Option("--no-gradient", help="Leave out the gradient ΔT.")
    ] = False,
    max_samples: Annotated[
        int | None,
        typer.Option("--max-samples", help="neural: decimate training to this many rows."),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="neural: seed of the first start.")] = 0,
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
) -> None:
    """Fit a thermal model per channel and write it as a JSON model file."""
    import warnings

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from rinscal.calibration.features import (
        DerivativeConfig,
        MissingGradientWarning,
        build_features,
    )
    from rinscal.calibration.model import ThermalModel
    from rinscal.cli._app import console, err_console, fail
    from rinscal.errors import RinscalError

    if method not in _METHODS:
        raise fail(f"--method must be one of {', '.join(_METHODS)}, got {method!r}")
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
            df, meta = _read(log, map_file, col, time_col, time_unit, sep, temp_col)
            model = ThermalModel(
                method,
                orders=_ints(orders, "--orders"),
                hidden=hidden,
                edges=_floats(edges, "--edges"),
                derivative=DerivativeConfig(window, "causal" if causal else "centred"),
                use_gradient=False if no_gradient else None,
                random_state=seed,
                estimator_params=params or None,
            )
            progress.update(task, description="features")
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", MissingGradientWarning)
                feats = build_features(
                    df,
                    model.derivative,
                    model.outliers,
                    model.channels,
                    use_gradient=model.use_gradient,
                )
            for w in caught:
                if issubclass(w.category, MissingGradientWarning):
                    err_console.print(
                        f"[yellow]warning:[/] {escape(str(w.message))}", highlight=False
                    )
            progress.update(task, description=f"fitting {method}", total=len(model.channels))

            def step(channel: str) -> None:
                progress.update(task, advance=1, description=f"fitted {channel}")

            model.fit(df, meta, features=feats, on_channel=step)
            mf = model.to_file(source={"log": log.name})
            mf.save(out)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    table = Table(title=f"{method} model of {log.name}: training residual (Eq. 16)")
    for name in ("channel", "unit", "samples", "outliers", "T range [°C]", "RMS", "RMS*"):
        table.add_column(name, justify="right" if name != "channel" else "left")
    for c in mf.channels:
        cm = mf.models[c]
        m = cm.metrics
        table.add_row(
            c,
            cm.unit or "?",
            f"{int(m['n_train']):,}",
            f"{int(m['n_outliers']):,}",
            f"{cm.train_range[0, 0]:.2f} .. {cm.train_range[0, 1]:.2f}",
            _fmt(m["rms_train"]),
            _fmt(m["rms_train_about_run_mean"]),
        )
    console.print(table)
    console.print(
        f"RMS* about each run's mean residual (turn-on offsets removed). wrote {out}",
        highlight=False,
        soft_wrap=True,
    )


@app.command("select")
def select(
    log: LogArg,
    method: Annotated[str, typer.Option("--method", help="regression or neural.")],
    tolerance: Annotated[
        float,
        typer.Option(
            "--tolerance",
            help="Recommend the smallest setting within this relative "
            "tolerance of the best held-out RMS.",
        ),
    ] = 0.02,
    settings: Annotated[
        str | None,
        typer.Option("--settings", help="Orders or neuron counts to try, e.g. 1,2,3,4."),
    ] = None,
    window: Annotated[
        float, typer.Option("--window", help="Temperature-rate window, seconds.")
    ] = 60.0,
    max_samples: Annotated[
        int | None,
        typer.Option("--max-samples", help="neural: decimate training to this many rows."),
    ] = 20000,
    seed: Annotated[int, typer.Option("--seed", help="neural: seed of the first start.")] = 0,
    as_json: JsonOpt = False,
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
) -> None:
    """Training and leave-one-run-out RMS per channel for orders 1-4 or 1-8 neurons."""
    import warnings

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from rinscal.calibration.features import DerivativeConfig, MissingGradientWarning
    from rinscal.calibration.model import unit_factors
    from rinscal.calibration.selection import DEFAULT_SETTINGS, select_model
    from rinscal.cli._app import console, err_console, fail
    from rinscal.errors import RinscalError

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
            df, meta = _read(log, map_file, col, time_col, time_unit, sep, temp_col)
            progress.update(task, description="selecting", total=6 * len(tried))

            def step(channel: str, setting: int) -> None:
                progress.update(task, advance=1, description=f"{channel}: {setting}")

            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", MissingGradientWarning)
                res = select_model(
                    df,
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
            err_console.print(f"[yellow]warning:[/] {escape(str(w.message))}", highlight=False)
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
                mark.append("[bold green]recommended[/]")
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
    console.print(table)
    console.print(
        f"recommended: smallest setting within {tolerance:.1%} of the best held-out RMS",
        highlight=False,
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
) -> None:
    """Compensate every sensor channel (Eq. 10); add the out_of_range flag column."""
    from rich.progress import Progress

    from rinscal.calibration.compensate import FLAG_COLUMN, compensate
    from rinscal.calibration.modelfile import POLICIES, ThermalModelFile
    from rinscal.cli._app import console, err_console, fail
    from rinscal.errors import RinscalError
    from rinscal.io import meta_path, write_log, write_meta

    if policy not in POLICIES:
        raise fail(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    inputs = [log, meta_path(log), model] + ([map_file] if map_file is not None else [])
    refuse_inputs(out, inputs)
    try:
        with Progress(console=err_console, transient=True) as progress:
            task = progress.add_task("reading", total=3)
            mf = ThermalModelFile.load(model)
            df, meta = _read(log, map_file, col, time_col, time_unit, sep, temp_col)
            progress.update(task, advance=1, description="compensating")
            res = compensate(df, mf, policy, "causal" if causal else None)  # type: ignore[arg-type]
            progress.update(task, advance=1, description="writing")
            write_log(res, out)
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
            progress.update(task, advance=1)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    n_flag = int(res[FLAG_COLUMN].sum())
    console.print(
        f"wrote {out}: {len(res):,} rows, {len(mf.channels)} channel(s) compensated with the "
        f"{mf.method} model; {n_flag:,} row(s) outside the training range ({policy})",
        highlight=False,
        soft_wrap=True,
    )


@app.command("evaluate")
def evaluate_cmd(
    log: LogArg,
    model: ModelOpt,
    policy: PolicyOpt = "clamp",
    causal: Annotated[
        bool, typer.Option("--causal", help="Use the causal temperature rate.")
    ] = False,
    step_window: Annotated[
        float, typer.Option("--step-window", help="Fit window on each side of an edge, seconds.")
    ] = 120.0,
    as_json: JsonOpt = False,
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
) -> None:
    """RMS (Eq. 16, about each run's mean) before/after compensation; steps at segment edges."""
    from rich.table import Table

    from rinscal.calibration.evaluate import StepConfig, evaluate
    from rinscal.calibration.modelfile import POLICIES, ThermalModelFile
    from rinscal.cli._app import console, fail
    from rinscal.errors import RinscalError

    if policy not in POLICIES:
        raise fail(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    try:
        mf = ThermalModelFile.load(model)
        df, _ = _read(log, map_file, col, time_col, time_unit, sep, temp_col)
        res = evaluate(
            df,
            mf,
            policy,
            "causal" if causal else None,
            StepConfig(window_s=step_window),  # type: ignore[arg-type]
        )
    except RinscalError as exc:
        raise fail(str(exc)) from None
    if as_json:
        doc = {
            "log": log.name,
            "model": model.name,
            "method": mf.method,
            "policy": policy,
            "rms": "Eq. 16 about each run's mean, inlier samples, log units",
            "step": f"difference of {step_window:g} s linear fits before/after an edge crossing",
            "rows": json.loads(res.to_json(orient="records")),
        }
        typer.echo(json.dumps(doc, indent=1))
        return
    table = Table(
        title=f"{mf.method} model on {log.name}: RMS about each run's mean (Eq. 16); "
        "largest step at a segment edge"
    )
    for name in (
        "run",
        "channel",
        "RMS before",
        "RMS after",
        "after/before",
        "edges crossed",
        "step raw",
        "step comp.",
    ):
        table.add_column(name, justify="left" if name in ("run", "channel") else "right")
    for _, r in res.iterrows():
        table.add_row(
            str(r["run"]),
            f"{r['channel']} ({r['unit'] or '?'})",
            _fmt(r["rms_before"]),
            _fmt(r["rms_after"]),
            _fmt(r["ratio"], 3),
            str(int(r["crossings"])),
            _fmt(r["max_step_before"], 3),
            _fmt(r["max_step_after"], 3),
        )
    console.print(table)


@app.command("export")
def export_cmd(
    model: Annotated[Path, typer.Argument(help="Thermal model file (JSON).")],
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
    imu: Annotated[int, typer.Option("--imu", help="ArduPilot IMU instance (1-3).")] = 1,
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
    from rinscal.cli._app import console, err_console, fail
    from rinscal.errors import RinscalError
    from rinscal.io import write_atomic

    if fmt not in ("px4", "ardupilot", "c"):
        raise fail(f"--format must be px4, ardupilot or c, got {fmt!r}")
    refuse_inputs(out, [model])
    try:
        mf = ThermalModelFile.load(model)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SmallCoefficientWarning)
            if fmt == "px4":
                text = to_px4_params(mf, gyro_id, accel_id)
            elif fmt == "ardupilot":
                text = to_ardupilot_parm(mf, imu)
            else:
                text = to_c_header(mf, prefix)
        write_atomic(out, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for w in caught:
        if issubclass(w.category, SmallCoefficientWarning):
            err_console.print(f"[yellow]warning:[/] {escape(str(w.message))}", highlight=False)
    console.print(f"wrote {out} ({fmt}, {mf.method} model)", highlight=False)

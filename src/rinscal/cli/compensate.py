"""CLI commands: compensate, evaluate, export (applying a fitted thermal model).

Thin wrappers over :mod:`rinscal.calibration.workflow` and :mod:`rinscal.calibration.export`:
read options, call one library function that returns data, print a table or JSON, write
files atomically. Library errors become messages and exit code 2.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Annotated, Any

import typer

from rinscal.cli._app import app, print_table
from rinscal.cli._options import (
    ColOpt,
    InstanceOpt,
    JobsOpt,
    LogArg,
    MapOpt,
    PolicyOpt,
    RelTimeOpt,
    SepOpt,
    TempColOpt,
    TimeColOpt,
    TimeUnitOpt,
    read_options,
    refuse_inputs,
)
from rinscal.cli.calibrate import IgnoreUnitsOpt, JsonOpt, ModelOpt, _fmt, _mapping_meta

#: The figures ``evaluate --allan-plot`` writes, by suffix (as ``rinscal plot``).
ALLAN_SUFFIXES = (".png", ".pdf", ".svg")


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
    jobs: JobsOpt = None,
) -> None:
    """Compensate every sensor channel (Eq. 10); add the out_of_range flag column."""
    # deferred: the library loads numpy, pandas and numba; `rinscal --help` must not
    from rinscal.calibration.modelfile import POLICIES
    from rinscal.calibration.workflow import compensate_file, load_model
    from rinscal.cli._app import console, err_console, fail, streaming_process
    from rinscal.errors import RangeError, RinscalError
    from rinscal.io.metadata import meta_path, write_meta

    if policy not in POLICIES:
        raise fail(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    inputs = [log, meta_path(log), model] + ([map_file] if map_file is not None else [])
    refuse_inputs(out, inputs, also=[meta_path(out)])
    streaming_process()  # the log is read and written run by run
    try:
        mf = load_model(model)
        options = read_options(
            map_file=map_file, col=col, time_col=time_col, time_unit=time_unit, sep=sep,
            temp_col=temp_col, relative_time=relative_time, instance=instance,
        )  # fmt: skip
        mapping, meta = _mapping_meta(log, options)
        done = compensate_file(
            log, mf, out, policy=policy, causal=causal, mapping=mapping, meta=meta,
            ignore_units=ignore_units, n_jobs=jobs,
        )  # fmt: skip
        if done.meta:
            done.meta["compensated"]["model"] = model.name
            write_meta(done.meta, out)
    except RangeError as exc:  # about a data row of LOG: name the file
        raise fail(f"{log}: {exc}") from None
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for note in done.warnings:
        err_console.print(f"warning: {note}", highlight=False, soft_wrap=True, markup=False)
    console.print(
        f"wrote {out}: {done.rows:,} rows, {len(mf.channels)} channel(s) compensated with the "
        f"{mf.method} model; {done.flagged_rows:,} row(s) outside the training data ({policy})",
        highlight=False,
        soft_wrap=True,
    )
    if mf.imu_stage is not None:
        console.print(
            "the model's IMU calibration was applied first (raw x unit_to_si -> SI -> scale "
            "factor, nonlinear terms and misalignment at each channel's temperature): all six "
            f"channels of {out.name} are in deg/h (gyros) and ug (accelerometers), as its "
            "metadata says",
            highlight=False,
            soft_wrap=True,
        )
    for run, (k, n) in done.flagged.items():
        console.print(f"  {run}: {k / n:.1%} of rows flagged", highlight=False)
    console.print(done.reference, highlight=False, soft_wrap=True)
    if done.missing_reference:
        err_console.print(
            f"warning: {', '.join(done.missing_reference)}: the model has no static reference, "
            "so their static level (gravity, Earth rate) was removed with the thermal bias; "
            "refit with --latitude/--heading or --static-ref to keep it",
            highlight=False,
            soft_wrap=True,
            markup=False,
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
            "panel per channel, longest run) to this figure (.png, .pdf or .svg).",
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
    # deferred: the library loads numpy, pandas and numba; `rinscal --help` must not
    from rich.table import Table

    from rinscal.calibration.allan_units import NOISE_TERMS_WORDS, datasheet_units
    from rinscal.calibration.modelfile import POLICIES
    from rinscal.calibration.workflow import evaluate, load_model, model_label
    from rinscal.cli._app import console, err_console, fail
    from rinscal.errors import RangeError, RinscalError

    if policy not in POLICIES:
        raise fail(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    inputs = [log, model] + ([map_file] if map_file is not None else [])
    if allan_plot is not None:
        suffix = allan_plot.suffix.lower()
        if suffix not in ALLAN_SUFFIXES:
            raise fail(
                f"--allan-plot {allan_plot}: unknown figure suffix {suffix or '(none)'!r}; "
                "use .png, .pdf or .svg"
            )
        refuse_inputs(allan_plot, inputs, what="--allan-plot")
    try:
        mf = load_model(model)
        options = read_options(
            map_file=map_file, col=col, time_col=time_col, time_unit=time_unit, sep=sep,
            temp_col=temp_col, relative_time=relative_time, instance=instance,
        )  # fmt: skip
        mapping, meta = _mapping_meta(log, options)
        ev = evaluate(
            log, mf, policy=policy, causal=causal, step_window_s=step_window, mapping=mapping,
            meta=meta, ignore_units=ignore_units,
        )  # fmt: skip
        res, allan = ev.table, ev.allan
        if allan_plot is not None:
            _write_allan_plot(allan_plot, ev.curves, mf, log.name)
    except RangeError as exc:  # about a data row of LOG: name the file
        raise fail(f"{log}: {exc}") from None
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for note in ev.warnings:
        err_console.print(f"warning: {note}", highlight=False, soft_wrap=True, markup=False)
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
            "allan_units": "n [unit·√s], b [unit], k [unit/√s] in the log's unit; the table "
            "quotes them as a data sheet does (n/60 in °/√h for deg/h, µg/√Hz for ug)",
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
            title="Allan deviation (overlapping), IEEE Std 952 slopes: "
            f"{NOISE_TERMS_WORDS}; a channel logged in another unit u: N [u·√s], B [u], "
            "K [u/√s]; '-' where the curve has no such region"
        )
        for name in ("run", "channel", "output", "N", "B", "τ(B) [s]", "K"):
            at.add_column(name, justify="left" if name in ("run", "channel", "output") else "right")
        for _, r in allan.iterrows():
            u = datasheet_units(r["unit"])
            at.add_row(
                str(r["run"]),
                f"{r['channel']} ({r['unit'] or '?'})",
                str(r["output"]),
                _fmt(r["n"] * u.n_factor, 3),
                _fmt(r["b"], 3),
                _fmt(r["b_tau_s"], 3),
                _fmt(r["k"] * u.k_factor, 3),
            )
        print_table(console, at)
    if allan_plot is not None:
        console.print(f"wrote {allan_plot}", highlight=False)


def _write_allan_plot(path: Path, curves: Any, mf: Any, name: str) -> None:
    """The Allan figure of the longest run, written atomically."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
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
    fmt = path.suffix.lower().lstrip(".")  # .png, .pdf or .svg (checked before any work)
    write_atomic(path, lambda tmp: fig.savefig(tmp, format=fmt, dpi=110))


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

    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.calibration.export import (
        SmallCoefficientWarning,
        flight_model,
        to_ardupilot_parm,
        to_c_header,
        to_px4_params,
    )
    from rinscal.calibration.modelfile import FittedModel
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
    changed: tuple[Any, ...] = ()
    try:
        mf = FittedModel.load(model)
        if fmt in ("px4", "ardupilot"):  # a cubic in T per channel: the best one auto kept
            changed = flight_model(mf)[1]  # the exporters make the same change
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
    if changed:
        _print_flight_changes(changed, "PX4" if fmt == "px4" else "ArduPilot")
    console.print(f"wrote {out} ({fmt}, {mf.method} model)", highlight=False)


def _print_flight_changes(changed: tuple[Any, ...], firmware: str) -> None:
    """The channels exported with another candidate than the model's, and the cost."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.table import Table

    from rinscal.cli._app import console

    table = Table(
        title=f"{len(changed)} channel(s) exported with another model than the file's: "
        f"{firmware} holds a clamped cubic in T, so each gets its best one by held-out RMS "
        "(of 60 s means of the residual, as fit --method auto scores; channel's unit)"
    )
    for name in ("channel", "auto chose", "held-out RMS", "exported", "held-out RMS", "cost"):
        left = name in ("channel", "auto chose", "exported")
        table.add_column(name, justify="left" if left else "right")
    for ch in changed:
        table.add_row(
            f"{ch.channel} ({ch.unit or '?'})",
            ch.chosen,
            _fmt(ch.chosen_rms),
            ch.exported,
            _fmt(ch.exported_rms),
            f"{ch.cost:+.3g} (x{ch.ratio:.3g})",
        )
    print_table(console, table)
    console.print(
        "The model file is unchanged: compensate, evaluate and navigate apply its own choice; "
        "export --format c writes it whole.",
        highlight=False,
        soft_wrap=True,
    )

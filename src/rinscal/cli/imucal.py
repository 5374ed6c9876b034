"""CLI command: calibrate-imu (scale factor, misalignment, nonlinear terms and biases over
temperature from a multi-position log on a two-axis turntable).

A thin wrapper over :func:`rinscal.calibration.imu.workflow.calibrate_imu`: read the log and
its metadata, fit, write ``imu.json`` and the estimate table ``imu.params.csv`` beside it
atomically, print a summary. Library errors become messages and exit code 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from rinscal.cli._app import app, print_table
from rinscal.cli._options import (
    ColOpt,
    LogArg,
    MapOpt,
    SepOpt,
    TempColOpt,
    TimeColOpt,
    TimeUnitOpt,
    read_options,
    refuse_inputs,
)


def _pm(value: float, sd: float) -> str:
    """``value ± sd`` with the sd's two significant digits setting the precision."""
    if not sd > 0:
        return f"{value:.6g}"
    digits = max(0, 1 - int(f"{sd:e}".split("e")[1]))
    return f"{value:.{digits}f} ± {sd:.{digits}f}"


@app.command("calibrate-imu")
def calibrate_imu_cmd(
    log: LogArg,
    out: Annotated[
        Path, typer.Option("--out", "-o", help="IMU calibration to write (JSON), e.g. imu.json.")
    ],
    settle: Annotated[
        float,
        typer.Option("--settle", min=0.0, help="Time dropped after each change of the table [s]."),
    ] = 5.0,
    linear: Annotated[
        bool,
        typer.Option(
            "--linear",
            help="Leave the nonlinear scale-factor terms (asymmetry, quadratic) at zero.",
        ),
    ] = False,
    max_degree: Annotated[
        int,
        typer.Option(
            "--max-degree", min=0, max=3, help="Highest degree of a law in temperature, 0-3."
        ),
    ] = 3,
    motion_sigma: Annotated[
        float,
        typer.Option(
            "--motion-sigma",
            min=1.0,
            help="Refuse a position whose residual exceeds this many robust scales.",
        ),
    ] = 10.0,
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
) -> None:
    """Calibrate the IMU over temperature from a multi-position turntable log.

    Writes the calibration (each parameter as a law in temperature) to --out and the
    estimate at each set point, with standard deviations, beside it (imu.params.csv).
    """
    # deferred: the library loads numpy and pandas; `rinscal --help` must not
    import json

    from rich.table import Table

    from rinscal.calibration.imu.workflow import calibrate_imu
    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.errors import RinscalError
    from rinscal.io.atomic import write_atomic
    from rinscal.io.foreign import read_foreign_source
    from rinscal.io.params import params_path, write_params

    table_out = params_path(out, ".params.csv")
    inputs = [log] + ([map_file] if map_file is not None else [])
    refuse_inputs(out, inputs, also=[table_out])
    if out.suffix.lower() != ".json":  # imu.json, read back by fit --imu-cal
        raise fail(f"{out}: an IMU calibration is JSON; give --out a name ending in .json")
    try:
        options = read_options(
            map_file=map_file, col=col, time_col=time_col, time_unit=time_unit, sep=sep,
            temp_col=temp_col,
        )  # fmt: skip
        src, meta = read_foreign_source(log, options)
        result = calibrate_imu(
            src.log,
            meta,
            settle_s=settle,
            nonlinear=not linear,
            max_degree=max_degree,
            motion_sigma=motion_sigma,
        )
    except RinscalError as exc:  # the file named once (a reader's message names it already)
        msg = str(exc)
        raise fail(msg if msg.startswith(f"{log}:") else f"{log}: {msg}") from None
    text = json.dumps(result.file_dict(log.name), indent=2, allow_nan=False) + "\n"
    write_params(result.estimates, table_out)
    write_atomic(out, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    for note in result.warnings:
        err_console.print(styled("warning:", "yellow", f" {note}"), highlight=False)
    est = result.estimates
    temps = sorted(est.temperature_c.unique())
    laws = result.laws.set_index("parameter")
    cal = result.calibration
    table = Table(
        title=f"IMU calibration of {log.name}: estimate ± sd at each set point [°C], "
        f"law about {cal.t0_c:.2f} °C"
    )
    for name in ["parameter", "unit", *(f"{t:g}" for t in temps), "slope /°C", "degree"]:
        table.add_column(name, justify="left" if name in ("parameter", "unit") else "right")
    for name, rows in est.groupby("parameter", sort=False):
        by_t = rows.set_index("temperature_c")
        law = laws.loc[name]
        table.add_row(
            str(name),
            str(law["unit"]),
            *(_pm(by_t.value[t], by_t.sd[t]) for t in temps),
            f"{law['slope_per_c']:.4g}",
            f"{int(law['degree'])}" + ("+Ṫ" if law["rate_degree"] else ""),
        )
    print_table(console, table)
    console.print(
        f"{len(result.segments)} segments in {len(temps)} "
        f"{'repetitions' if result.settings['ramp'] else 'set points'}, range "
        f"{cal.t_range_c[0]:.2f} .. {cal.t_range_c[1]:.2f} °C; wrote {out} and {table_out}",
        highlight=False,
        soft_wrap=True,
    )

"""CLI command: calibrate-field (a thermal model from parked cold starts, no chamber)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from rinscal.cli._app import app, fail
from rinscal.cli._options import JobsOpt

_METHODS = ("auto", "regression", "poly-t", "sectional", "neural")


@app.command("calibrate-field")
def calibrate_field_cmd(
    runs: Annotated[
        list[Path],
        typer.Argument(
            metavar="RUN...",
            help="Recordings of parked cold starts (navigate --log's format), at least three.",
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Model file to write (JSON).")],
    site: Annotated[
        str | None,
        typer.Option(
            "--site",
            help="The static site LAT,LON,HEIGHT [deg, deg, m] (default: each recording's "
            "metadata).",
        ),
    ] = None,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help=f"Thermal model: {', '.join(_METHODS)}. Default regression: method 2's "
            "order in T, first order in Tdot and dT (what parked starts determine).",
        ),
    ] = "regression",
    mapping: Annotated[
        Path | None,
        typer.Option("--map", help="Column mapping (TOML) of a foreign recording layout."),
    ] = None,
    imu: Annotated[
        str | None,
        typer.Option(
            "--imu",
            help="The IMU whose noise and turn-on repeatability the filter assumes: a preset "
            "or TOML file (default: the recordings' metadata).",
        ),
    ] = None,
    span: Annotated[
        str | None,
        typer.Option(
            "--span",
            help="LO,HI [°C]: the inner temperatures the model must cover, for the "
            "observability report (default: the starts' own).",
        ),
    ] = None,
    report: Annotated[
        Path | None,
        typer.Option(
            "--report",
            help="Also write the report (starts, observability per channel and term, "
            "fallbacks) as JSON here (default: beside --out, <name>.field.json).",
        ),
    ] = None,
    jobs: JobsOpt = None,
) -> None:
    """Calibrate the thermal model of a RINS from its own parked cold starts.

    Each recording's biases are estimated over time on the static base (zero velocity, the
    known site and the encoder; heading and tilt estimated), then the thermal models are
    fitted on them as fit does, leaving one start out to choose. Writes the model file and
    a report of what the starts determine of each channel's terms.
    """
    # deferred: the library loads numpy, pandas and numba; `rinscal --help` must not
    from rich.table import Table

    from rinscal.cli._app import console, err_console, styled
    from rinscal.cli._options import input_file, refuse_inputs
    from rinscal.errors import RinscalError
    from rinscal.io.atomic import write_atomic
    from rinscal.io.mapping import read_mapping
    from rinscal.nav.fieldcal import calibrate_field
    from rinscal.nav.recording import parse_site

    if method not in _METHODS:
        raise fail(f"--method must be one of {', '.join(_METHODS)}, got {method!r}")
    if out.suffix.lower() != ".json":
        raise fail(f"{out}: a model file is JSON; give --out a name ending in .json")
    rep = report if report is not None else out.with_suffix(".field.json")
    if rep.resolve() == out.resolve():
        raise fail(f"--report {rep}: that is --out; name another")
    for r in runs:
        input_file(r)
    inputs = [*runs, *([mapping] if mapping is not None else [])]
    refuse_inputs(out, inputs, also=[rep])
    lo_hi = None
    if span is not None:
        try:
            lo, hi = (float(v) for v in span.split(","))
        except ValueError:
            raise fail(f"--span must be LO,HI in °C, got {span!r}") from None
        if not lo < hi:
            raise fail(f"--span must be LO,HI with LO < HI, got {span!r}")
        lo_hi = (lo, hi)
    try:
        where = parse_site(site) if site is not None else None
        mp = read_mapping(mapping, "navigation") if mapping is not None else None
        with console.status("estimating each start's biases") as status:

            def tick(done: float, total: float) -> None:
                status.update(f"estimated {done:.0f} of {total:.0f} starts")

            result = calibrate_field(
                [str(r) for r in runs], site=where, mapping=mp, method=method, imu=imu,
                span_c=lo_hi, progress=tick, n_jobs=jobs,
            )  # fmt: skip
        result.save(out)
        text = json.dumps(result.report(), indent=2) + "\n"
        write_atomic(rep, lambda tmp: tmp.write_text(text))
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for text in result.warnings:
        err_console.print(styled("warning:", "yellow", f" {text}"), highlight=False)
    table = Table(title=f"field calibration from {len(runs)} parked starts (held out by start)")
    for name in ("channel", "inputs", "model", "train RMS", "held-out RMS", "none held-out"):
        table.add_column(
            name, justify="left" if name in ("channel", "inputs", "model") else "right"
        )
    for r in result.table.to_dict("records"):
        table.add_row(
            f"{r['channel']} ({r['unit']})",
            r["inputs"],
            r["model"],
            *(
                f"{r.get(k, float('nan')):.4g}"
                for k in ("train_rms", "heldout_rms", "none_heldout_rms")
            ),
        )
    console.print(table)
    for note in result.notes:
        console.print(f"- {note}", highlight=False, soft_wrap=True)
    console.print(f"wrote {out} and {rep}", highlight=False)

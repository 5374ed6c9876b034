"""CLI commands: fit and select (thermal calibration; applying a model is in
:mod:`rinscal.cli.compensate`).

Thin wrappers over :mod:`rinscal.calibration`: read the log (through a column mapping for a
foreign log), call a library function that returns data, print a table or JSON, write files
atomically. Library errors become messages and exit code 2.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from rinscal.cli._app import app, print_table
from rinscal.cli._options import (
    ColOpt,
    InstanceOpt,
    JobsOpt,
    LogArg,
    MapOpt,
    RelTimeOpt,
    SepOpt,
    TempColOpt,
    TimeColOpt,
    TimeUnitOpt,
    read_options,
    refuse_inputs,
)

if TYPE_CHECKING:
    import pandas as pd

    from rinscal.io.foreign import ReadOptions


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


#: The one meaning of ``--tolerance`` in ``fit`` and ``select``
#: (:mod:`rinscal.calibration.selection.rule`).
TOLERANCE_HELP = (
    "Take the simplest model whose held-out RMS is at most this fraction above the best's "
    "(0.05: 5 %; the same quantity in fit and select)"
)


def _read(log: Path, options: ReadOptions) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Read a log and its metadata (units from the mapping when there is no sidecar)."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.io.foreign import read_foreign_source

    src, meta = read_foreign_source(log, options)
    return src.log, meta


def _static_options(
    latitude: float | None, heading: float | None, static_ref: str | None
) -> dict[str, Any]:
    """Metadata for the static reference from ``--latitude/--heading`` and ``--static-ref``."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import fail
    from rinscal.schema import CHANNELS

    out: dict[str, Any] = {}
    if (latitude is None) != (heading is None):
        raise fail("--latitude and --heading go together (the static output needs both)")
    if latitude is not None and static_ref is not None:
        raise fail(
            "--static-ref and --latitude/--heading both give the static output compensation "
            "keeps: give one (the site for a known latitude and heading, --static-ref otherwise)"
        )
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
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import fail

    if text is None:
        return None
    try:
        return tuple(int(v) for v in text.split(","))
    except ValueError:
        raise fail(f"{option}: {text!r} is not a comma-separated list of integers") from None


def _floats(text: str | None, option: str) -> tuple[float, ...] | None:
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import fail

    if text is None:
        return None
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise fail(f"{option}: {text!r} is not a comma-separated list of numbers") from None


#: What a table shows for a figure that does not exist (None, NaN): never "None" or "nan".
MISSING = "—"


def _fmt(v: Any, digits: int = 4) -> str:
    if v is None:
        return MISSING
    try:
        f = float(v)
    except (TypeError, ValueError):
        return str(v)
    if f != f:  # NaN
        return MISSING
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
            help=f"auto: {TOLERANCE_HELP} (default 0: the paired test alone).",
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
    imu_cal: Annotated[
        Path | None,
        typer.Option(
            "--imu-cal",
            help="IMU calibration (calibrate-imu's JSON, or a model file holding one) applied "
            "first: raw x unit_to_si -> SI -> scale factor, nonlinear terms and misalignment "
            "removed at each channel's temperature -> deg/h and ug, on which the thermal model "
            "is fitted; the model file holds it and every compensator applies it.",
        ),
    ] = None,
    jobs: JobsOpt = None,
) -> None:
    """Fit a thermal model per channel and write it as a JSON model file.

    With --method auto (the default) each channel gets the model of least held-out error
    among no compensation, the PX4 and ArduPilot fits, cubic-type polynomials in T and the
    paper's regression, the simplest within noise of the best.
    """
    # deferred: the library loads numpy, pandas and numba; `rinscal --help` must not
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from rinscal.calibration.workflow import fit as fit_log
    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.errors import RinscalError

    if method not in _METHODS:
        raise fail(f"--method must be one of {', '.join(_METHODS)}, got {method!r}")
    lo_hi = _floats(temp_range, "--temp-range")
    if lo_hi is None or len(lo_hi) != 2 or not lo_hi[0] < lo_hi[1]:
        raise fail(f"--temp-range must be LO,HI in °C with LO < HI, got {temp_range!r}")
    fams = None if candidates is None else tuple(v.strip() for v in candidates.split(","))
    if fams is not None and method != "auto":
        raise fail("--candidates applies to --method auto only")
    options = read_options(
        map_file=map_file, col=col, time_col=time_col, time_unit=time_unit, sep=sep,
        temp_col=temp_col, relative_time=relative_time, instance=instance,
    )  # fmt: skip
    inputs = [log] + ([map_file] if map_file is not None else [])
    inputs += [imu_cal] if imu_cal is not None else []
    refuse_inputs(out, inputs)
    if out.suffix.lower() != ".json":  # else a log-named model would be read as a log later
        raise fail(f"{out}: a model file is JSON; give --out a name ending in .json")
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
            mapping, meta = _mapping_meta(log, options)
            meta.update(_static_options(latitude, heading, static_ref))

            def step(done: float, total: float) -> None:
                if math.isnan(total):  # reading: done counts the runs read
                    progress.update(task, description=f"features of run {done:.0f}")
                else:
                    progress.update(task, completed=done, total=total, description="fitting")

            result = fit_log(
                log,
                method,
                meta=meta,
                mapping=mapping,
                orders=_ints(orders, "--orders"),
                hidden=hidden,
                edges=_floats(edges, "--edges"),
                window_s=window,
                causal=causal,
                gradient=False if no_gradient else None,
                temp_range=(lo_hi[0], lo_hi[1]),
                tolerance=tolerance,
                candidates=fams,
                seed=seed,
                max_samples=max_samples,
                progress=step,
                imu_calibration=imu_cal,
                n_jobs=jobs,
            )
            result.save(out)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for text in result.warnings:
        err_console.print(styled("warning:", "yellow", f" {text}"), highlight=False)
    auto = method == "auto"
    title = (
        f"auto model of {log.name}: RMS of 60 s means of the residual about each scored "
        "part's mean (train and held-out alike; channel's unit)"
        if auto
        else f"{method} model of {log.name}: training RMS per sample about each run's mean "
        "(Eq. 16; channel's unit)"
    )
    table = Table(title=title)
    cols = ["channel", "model", "samples", "masked", "T range [°C]"]
    cols += ["train RMS", "held-out RMS", "none held-out"] if auto else ["RMS/sample"]
    for name in cols:
        left = name in ("channel", "model", "T range [°C]")
        table.add_column(name, justify="left" if left else "right")
    for r in result.table.to_dict("records"):
        row = [
            f"{r['channel']} ({r['unit'] or '?'})",
            r["model"],
            f"{r['samples']:,}",
            f"{r['masked']:,}",
            f"{r['t_min_c']:.2f} .. {r['t_max_c']:.2f}",
        ]
        if auto:
            row += [_fmt(r.get(k)) for k in ("train_rms", "heldout_rms", "none_heldout_rms")]
        else:
            row.append(_fmt(r["rms_train"]))
        table.add_row(*row)
    print_table(console, table)
    if imu_cal is not None:
        console.print(
            f"IMU calibration {imu_cal.name} applied first (scale factor, nonlinear terms and "
            "misalignment at each channel's temperature); the thermal model is in deg/h and ug, "
            "and the model file holds both",
            highlight=False,
            soft_wrap=True,
        )
    console.print(f"{result.note} wrote {out}", highlight=False, soft_wrap=True)


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
            help=f"{TOLERANCE_HELP} (auto: default 0, on top of the paired test; "
            "regression/neural: the smallest setting, default 0.02).",
        ),
    ] = None,
    candidates: Annotated[
        str | None,
        typer.Option("--candidates", help="auto: candidate families (as fit --candidates)."),
    ] = None,
    settings: Annotated[
        str | None,
        typer.Option(
            "--settings",
            help="regression/neural: orders or neuron counts to try, e.g. 1,2,3,4.",
        ),
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

    if method == "auto" and settings is not None:
        # deferred: loaded when the command runs, so that `rinscal --help` starts fast
        from rinscal.cli._app import fail

        raise fail(
            "--settings applies to --method regression or neural (orders or neuron counts); "
            "auto tries every candidate family: choose them with --candidates"
        )
    options = read_options(
        map_file=map_file, col=col, time_col=time_col, time_unit=time_unit, sep=sep,
        temp_col=temp_col, relative_time=relative_time, instance=instance,
    )  # fmt: skip
    if method == "auto":
        _select_auto(
            log,
            tolerance,
            candidates,
            window,
            seed,
            as_json,
            options,
        )
        return
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from rinscal.calibration.selection.rule import SETTINGS_TOLERANCE

    tolerance = SETTINGS_TOLERANCE if tolerance is None else tolerance

    from rinscal.calibration.selection.heldout import (
        DEFAULT_SETTINGS,
        select_model,
        select_regression_runs,
    )
    from rinscal.calibration.thermal.features import DerivativeConfig, MissingGradientWarning
    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.errors import RinscalError
    from rinscal.io.streaming import by_runs
    from rinscal.io.tables import read_log_source
    from rinscal.schema import unit_factors

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
            mapping, meta = _mapping_meta(log, options)

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
                        seed=seed,
                        estimator_params=params,
                        progress=lambda done, total: progress.update(
                            task, completed=done, total=total, description=f"{done:.0f} fits"
                        ),
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
        title=f"{method} selection on {log.name}: RMS per sample (Eq. 16) about each run's "
        f"mean, train and held-out alike (not the 60 s means of select --method auto); "
        f"train: the fit on all {len(res.runs)} runs; held-out: leave-one-run-out"
    )
    table.add_column("channel")
    table.add_column(what, justify="right")
    table.add_column("train RMS/sample", justify="right")
    table.add_column("held-out RMS/sample", justify="right")
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
    tolerance: float | None,
    candidates: str | None,
    window: float,
    seed: int,
    as_json: bool,
    options: ReadOptions,
) -> None:
    """``select --method auto``: every candidate's held-out RMS, the choice and the fallback
    (:func:`rinscal.calibration.selection.heldout.select_model`, printed)."""

    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.table import Table

    from rinscal.calibration.selection.heldout import select_model
    from rinscal.calibration.thermal.features import DerivativeConfig
    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.errors import RinscalError

    fams = None if candidates is None else tuple(v.strip() for v in candidates.split(","))
    try:
        with err_console.status("selecting (held-out fits of every candidate)"):
            df, meta = _read(log, options)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                res = select_model(
                    df,
                    "auto",
                    tolerance=tolerance,
                    derivative=DerivativeConfig(window),
                    seed=seed,
                    meta=meta,
                    candidates=fams,
                    source=str(log),
                )
    except RinscalError as exc:
        raise fail(str(exc)) from None
    for w in caught:
        if issubclass(w.category, UserWarning):
            err_console.print(styled("warning:", "yellow", f" {w.message}"), highlight=False)
    if as_json:
        typer.echo(json.dumps({"log": log.name, **res.to_dict()}, indent=1))
        return
    tolerance = res.tolerance
    for c, sel in res.channels.items():
        table = Table(
            title=f"{c} ({sel['unit'] or '?'}): RMS of 60 s means of the residual about "
            f"each scored part's mean (held-out, per part and train alike), "
            f"{sel.get('scheme')}, {len(sel.get('folds', []))} scored parts "
            f"({', '.join(sel.get('folds', []))})"
        )
        for name in ("candidate", "params", "held-out RMS", "per part", "train RMS", ""):
            table.add_column(
                name, justify="left" if name in ("candidate", "per part", "") else "right"
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
        "held-out RMS: each part predicted by the fit without its fold (per part: each part's "
        "own); train RMS: the fit on all the data, over the same rows and 60 s blocks; "
        f"{MISSING}: not fitted (per part: or no sample of the part inside the other folds' "
        "temperatures; train: a network is not refitted on all the data while screening).",
        highlight=False,
        soft_wrap=True,
    )
    console.print(
        "chosen: among the models a paired t-test (90 %, log ratios over the folds) cannot "
        "tell from the best held-out error"
        f"{f' or within {tolerance:.1%} of its held-out RMS' if tolerance else ''}: none, then "
        "ArduPilot's fit, then PX4's, then the fewest thermal parameters; "
        "fallback: the same among models of T alone, used outside the training domain "
        "(compensate --policy fallback)",
        highlight=False,
        soft_wrap=True,
    )


def _mapping_meta(log: Path, options: ReadOptions) -> tuple[Any, dict[str, Any]]:
    """How to read ``log`` (a column mapping, flight-log options or None) and its metadata."""
    # deferred: the io layer loads pandas; `rinscal --help` must not
    from rinscal.io.foreign import foreign_mapping, foreign_meta

    mapping = foreign_mapping(log, options)
    return mapping, foreign_meta(log, mapping)

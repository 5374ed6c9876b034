"""CLI command: navigate (a single-axis RINS scenario with thermal compensation)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from rinscal.cli._app import app
from rinscal.cli._options import AlignLengthOpt, AlignStartOpt, PolicyOpt, is_same_file
from rinscal.thermal.presets import DEFAULT_PRESET, PRESETS

#: The plant ``rinscal navigate`` runs unless ``--imu`` names another (as simulate and
#: reproduce: the paper's own IMU).
DEFAULT_IMU = DEFAULT_PRESET

_OUTPUTS = (
    "errors.csv",
    "truth.csv",
    "summary.json",
    "position_error.png",
    "trajectory.png",
    "temperatures.png",
)


@app.command("navigate")
def navigate(
    scenario: Annotated[
        str,
        typer.Option(
            "--scenario", "-s", help="quasi-static, swing, vehicle or ramp (paper Section 5.2)."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder (created if needed).")],
    model: Annotated[
        list[Path] | None,
        typer.Option(
            "--model", "-m", help="Thermal model file (JSON) to compensate with; repeatable."
        ),
    ] = None,
    hours: Annotated[
        float | None,
        typer.Option(
            min=0.01,
            max=72.0,
            # rinscal.nav.scenario.DEFAULT_HOURS (a test holds them equal; importing it here
            # would cost every command 3 s of start-up)
            help="Run length [h], 0.01-72 (vehicle: driving time). Default per scenario: "
            "quasi-static 4 h, swing 2 h, vehicle 1.9 h, ramp 4.5 h.",
        ),
    ] = None,
    rate: Annotated[
        float, typer.Option("--rate", min=1.0, max=2000.0, help="IMU rate [Hz], 1-2000.")
    ] = 100.0,
    seed: Annotated[
        int, typer.Option(min=0, help="Seed of the sensor noise and turn-on offsets (≥ 0).")
    ] = 0,
    imu: Annotated[
        str | None,
        typer.Option(
            "--imu",
            help=f"The simulated IMU: a preset ({', '.join(PRESETS)}) or an IMU TOML file. "
            f"Default {DEFAULT_IMU}.",
        ),
    ] = None,
    imu_config: Annotated[
        Path | None,
        typer.Option("--imu-config", hidden=True, help="Old name of --imu (a TOML file)."),
    ] = None,
    rotation: Annotated[
        str, typer.Option(help="Turntable: four-position, continuous or none.")
    ] = "four-position",
    align_s: AlignLengthOpt = 600.0,
    align_start_s: AlignStartOpt = 0.0,
    oracle: Annotated[
        bool, typer.Option("--oracle/--no-oracle", help="Also navigate with the true thermal bias.")
    ] = True,
    policy: PolicyOpt = "clamp",
) -> None:
    """Navigate a single-axis RINS through a cold start and report its position error.

    Writes errors.csv (position error per variant over time), truth.csv, summary.json and
    the figures position_error.png, trajectory.png and temperatures.png into --out, and
    prints per variant the maximum position error and the heading, pitch and roll error
    the alignment handed over.
    """
    import json
    import math

    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from rinscal import units
    from rinscal.calibration.modelfile import POLICIES
    from rinscal.cli._app import console, fail
    from rinscal.errors import RinscalError

    if imu is not None and imu_config is not None:
        raise fail("give the IMU once: --imu (--imu-config is its old name)")
    imu_spec = str(imu_config) if imu_config is not None else (imu or DEFAULT_IMU)
    imu_file = None if imu_spec in PRESETS else Path(imu_spec)
    if imu_file is not None and imu_file.suffix.lower() != ".toml" and not imu_file.exists():
        raise fail(f"--imu {imu_spec!r} is neither a preset ({', '.join(PRESETS)}) nor a TOML file")
    models = list(model or [])
    inputs = [*models, *([imu_file] if imu_file is not None else [])]
    for src in inputs:
        if not src.is_file():
            raise fail(f"{src}: file not found")
    out_paths = [out / name for name in _OUTPUTS]
    for dst in out_paths:
        for src in inputs:
            if is_same_file(dst, src):
                raise fail(f"{dst}: refusing to overwrite the input {src}; choose another --out")
    if out.exists() and not out.is_dir():
        raise fail(f"{out}: exists and is not a folder")
    if not (math.isfinite(rate) and rate > 0):
        raise fail(f"--rate must be > 0 Hz, got {rate}")
    if not (math.isfinite(align_s) and align_s > 0):
        raise fail(f"--align-s must be > 0 s, got {align_s}")
    if not (math.isfinite(align_start_s) and align_start_s >= 0):
        raise fail(f"--align-start-s must be >= 0 s, got {align_start_s}")
    if policy not in POLICIES:
        raise fail(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")

    try:
        from rinscal.nav.rotation import schedule_from_name
        from rinscal.nav.scenario import (
            ThermalPlant,
            align_for,
            model_compensator,
            oracle_compensator,
            preset,
            run_scenario,
            temperature_frame,
        )
        from rinscal.thermal.plant import load_imu

        plant_cfg = load_imu(imu_spec)
        align = align_for(plant_cfg, total_s=align_s, start_s=align_start_s)
        cfg = preset(
            scenario, hours=hours, rate_hz=rate, align=align, schedule=schedule_from_name(rotation)
        )
        assert cfg.chamber is not None
        plant = ThermalPlant.for_scenario(plant_cfg, cfg, seed=seed)
        comps: dict[str, object] = {"none": None}
        if oracle:
            comps["true"] = oracle_compensator(plant)
        for path in models:
            name = path.stem
            while name in comps:
                name += "_"
            comps[name] = model_compensator(str(path), plant, policy=policy)

        out.mkdir(parents=True, exist_ok=True)  # before the run: an unusable --out fails at once
        with Progress(
            TextColumn("[progress.description]{task.description}"),
            BarColumn(),
            TextColumn("{task.completed:,.0f}/{task.total:,.0f} s"),
            TimeRemainingColumn(),
            console=console,
            transient=True,
        ) as progress:
            task = progress.add_task(f"navigating {scenario}", total=cfg.duration_s)

            def tick(done: float, total: float) -> None:
                progress.update(task, completed=done)

            result = run_scenario(cfg, plant, comps, progress=tick)  # type: ignore[arg-type]
    except RinscalError as exc:
        raise fail(str(exc)) from None

    import pandas as pd

    from rinscal.io import atomic_path
    from rinscal.nav.plots import plot_position_error, plot_temperatures, plot_trajectory

    out.mkdir(parents=True, exist_ok=True)
    frames = []
    for name, df in result.errors.items():
        d = df.copy()
        d.insert(0, "variant", name)
        frames.append(d)
    errors = pd.concat(frames, ignore_index=True)
    summary = result.summary()
    summary["seed"] = seed
    summary["imu"] = plant_cfg.name
    summary["imu_spec"] = imu_spec
    summary["models"] = {p.stem: str(p) for p in models}
    summary["chamber"] = {
        "times_s": list(cfg.chamber.times_s),
        "temps_c": list(cfg.chamber.temps_c),
    }

    with atomic_path(out / "errors.csv") as tmp:
        errors.to_csv(tmp, index=False, float_format="%.10g")
    with atomic_path(out / "truth.csv") as tmp:
        result.truth.to_csv(tmp, index=False, float_format="%.10g")
    with atomic_path(out / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2, allow_nan=False, default=float) + "\n")
    figures = {
        "position_error.png": plot_position_error(result),
        "trajectory.png": plot_trajectory(result),
        "temperatures.png": plot_temperatures(temperature_frame(plant)),
    }
    for fname, fig in figures.items():
        with atomic_path(out / fname) as tmp:
            fig.savefig(tmp, format="png", dpi=110)

    console.print(
        f"navigation from {cfg.nav_start_s:g} s after power-on "
        f"(alignment from {cfg.align_start_s:g} s, {align_s:g} s long)",
        highlight=False,
        soft_wrap=True,
    )
    for name, v in summary["variants"].items():
        extra = ""
        if "improvement_vs_none_pct" in v:
            pct = v["improvement_vs_none_pct"]
            extra = f"  ({abs(pct):.1f} % {'less' if pct >= 0 else 'more'} than uncompensated)"
        att = v["attitude_error_at_nav_start"]
        console.print(
            f"{name:>14}: max position error {v['max_error_m']:10.1f} m = "
            f"{v['max_error_m'] / units.NMI_TO_M:7.3f} nmi{extra}; at navigation start "
            f'heading {att["heading_arcsec"]:+.1f}", pitch {att["pitch_arcsec"]:+.1f}", '
            f'roll {att["roll_arcsec"]:+.1f}" (arcsec)',
            highlight=False,
            soft_wrap=True,
        )
    console.print(f"wrote {', '.join(_OUTPUTS)} to {out}", highlight=False, soft_wrap=True)


__all__ = ["navigate"]

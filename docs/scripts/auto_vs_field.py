"""The table of docs/calibration.md "auto against the field's own fits": every figure measured.

Run from the repository root (one core)::

    python docs/scripts/auto_vs_field.py

Real log: the MEMS thermal cycle of ``tests/data/real`` cut into legs; every method is
fitted on the first cooling and the heating leg and evaluated on the last cooling leg (RMS of
the compensated output about the leg's mean, noise included; no truth). Simulated: each
preset's soak protocol (7 × 3 h at 10 Hz, seed 1) trains, the ``repeat`` (seed 2) and
``ramp`` (seed 3) protocols are held out; the entry is the RMS of (modelled − true) thermal
bias about each run's mean. Policy ``clamp`` everywhere. ``auto`` passes when it is no worse
than no compensation and within 5 % of (or better than) the better of ``px4`` and
``ardupilot``.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from rinscal.experiments.paper.calibration import heldout_table, real_log_table
from rinscal.sim.config import load_imu
from rinscal.sim.protocols import simulate_protocol

METHODS = ("px4", "ardupilot", "poly-t", "auto")


def _verdict(row: pd.Series) -> str:
    field = min(row["px4"], row["ardupilot"])
    ok_none = row["auto"] <= row["none"] * (1 + 1e-9)
    ok_field = row["auto"] <= 1.05 * field
    if ok_none and ok_field:
        return "yes"
    why = []
    if not ok_none:
        why.append(f"{row['auto'] / row['none']:.2f}× none")
    if not ok_field:
        why.append(f"{row['auto'] / field:.2f}× field")
    return "**no**: " + ", ".join(why)


def _markdown(frame: pd.DataFrame, index: list[str]) -> str:
    cols = [*index, "none", "px4", "ardupilot", "poly-t", "auto", "auto's model", "passes"]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for _, r in frame.iterrows():
        cells = [str(r[c]) for c in index]
        cells += [f"{r[m]:.3g}" for m in ("none", "px4", "ardupilot", "poly-t", "auto")]
        cells += [str(r["choice"]), _verdict(r)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def real_table(path: Path) -> str:
    table, models = real_log_table(path, methods=METHODS)
    wide = table.pivot_table(index="channel", columns="method", values="rms_after", sort=False)
    wide["none"] = table.groupby("channel", sort=False)["rms_before"].first()
    wide = wide.reset_index()
    auto = models["auto"]
    wide["choice"] = [auto.models[c].selection["chosen"] for c in wide["channel"]]
    unit = {"gyro": "mrad/s", "accel": "mm/s²"}
    for m in ("none", *METHODS):
        wide[m] = wide[m] * 1e3
    wide["channel"] = [f"{c} [{unit[c.split('_')[0]]}]" for c in wide["channel"]]
    return _markdown(wide, ["channel"])


def simulated_table(preset: str) -> str:
    cfg = load_imu(preset)
    logs = {
        name: simulate_protocol(name, rate_hz=10.0, seed=seed, config=cfg)
        for name, seed in (("soak", 1), ("repeat", 2), ("ramp", 3))
    }
    train, _, meta = logs["soak"]
    tests = [logs["repeat"][0], logs["ramp"][0]]
    truth = [logs["repeat"][1], logs["ramp"][1]]
    from rinscal.experiments.paper.calibration import fit_all

    models = fit_all(train, meta, METHODS)
    tab = heldout_table(train, tests, truth, meta, models=models, methods=METHODS)
    wide = tab.pivot_table(index=["run", "channel"], columns="method", values="rms", sort=False)
    wide = wide.rename(columns={"uncompensated": "none"}).reset_index()
    wide["choice"] = [models["auto"].models[c].selection["chosen"] for c in wide["channel"]]
    units = {c: models["auto"].models[c].unit for c in models["auto"].channels}
    wide["channel"] = [f"{c} [{units[c]}]" for c in wide["channel"]]
    return _markdown(wide, ["run", "channel"])


def noise_only(seeds: tuple[int, ...] = (11, 12, 13)) -> str:
    """Presets with every thermal sensitivity zeroed: how often ``auto`` fits noise, at what cost.

    Each preset's soak protocol (seed s) trains, its ``repeat`` (seed s + 100) tests; the
    true thermal bias is zero, so a model's held-out error is its own output about the run
    mean.
    """
    import dataclasses

    from rinscal.calibration.thermal.model import ThermalModel
    from rinscal.sim.polynomial import ChannelThermal

    lines = [
        "| preset | channels | with a model | largest added error, gyro / accel |",
        "|---|---|---|---|",
    ]
    for preset in ("paper", "navigation_grade"):
        cfg = load_imu(preset)
        flat = ChannelThermal(
            b0=0.0,
            t=(0.0,),
            rate=(0.0,),
            grad=(0.0,),
            shupe=0.0,
            scale_factor_ppm_per_c=0.0,
            misalignment_arcsec_per_c=(0.0, 0.0, 0.0),
        )
        off = {f.name: False for f in dataclasses.fields(cfg.effects)}
        cfg = dataclasses.replace(
            cfg,
            thermal=(flat,) * len(cfg.thermal),
            effects=dataclasses.replace(cfg.effects, **off),
        )
        n, picked, worst = 0, [], {"gyro": 0.0, "accel": 0.0}
        for seed in seeds:
            train, _, meta = simulate_protocol("soak", rate_hz=10.0, seed=seed, config=cfg)
            test, truth, _ = simulate_protocol("repeat", rate_hz=10.0, seed=seed + 100, config=cfg)
            model = ThermalModel(method="auto").fit(train, meta).to_file()
            tab = heldout_table(train, test, truth, meta, models={"auto": model}, methods=["auto"])
            tab = tab[tab["method"] == "auto"]
            for c, m in model.models.items():
                n += 1
                if m.selection["chosen"] != "none":
                    picked.append(f"{c} {m.selection['chosen']}")
                    kind = c.split("_")[0]
                    rms = float(tab.loc[tab["channel"] == c, "rms"].max())
                    worst[kind] = max(worst[kind], rms)
        g, a = model.models["gyro_x"].unit, model.models["accel_x"].unit
        lines.append(
            f"| {preset} | {n} | {len(picked)}: {', '.join(picked) or '-'} | "
            f"{worst['gyro']:.2g} {g} / {worst['accel']:.2g} {a} |"
        )
    return "\n".join(lines)


def main() -> None:
    warnings.simplefilter("ignore")
    root = Path(__file__).resolve().parents[2]
    real = root / "tests" / "data" / "real" / "tofupilot_imu_thermal_cycle.tsv"
    if len(sys.argv) > 1:
        real = Path(sys.argv[1])
    print("### Real MEMS log: legs 1-2 train, leg 3 tests\n")
    print(real_table(real))
    for preset in ("paper", "navigation_grade"):
        print(f"\n### Simulated `{preset}`: soak trains, repeat and ramp test\n")
        print(simulated_table(preset))
    print("\n### Noise only: every thermal sensitivity zeroed\n")
    print(noise_only())
    np.seterr(all="ignore")


if __name__ == "__main__":
    main()

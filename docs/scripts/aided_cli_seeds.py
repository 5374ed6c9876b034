"""Aiding and in-motion alignment through ``rinscal navigate --log`` (docs/navigation.md,
"Aided navigation"), over track-noise seeds:

    PYTHONPATH=src python docs/scripts/aided_cli_seeds.py --seeds 10

The vehicle scenario at 5 Hz (60 s parked, then driving; the paper's IMU on its turntable),
a 1 Hz track with 1.5 m white noise per coordinate; per seed: the heading error after a
300 s in-motion alignment of the drive alone (from 61 s), and with ``--aiding gnss`` the
position error RMS per coordinate and the maximum horizontal error [m] (against the log's
own noise-free reference) after the zero-velocity alignment and after the in-motion one.
Prints the mean, a 95 % interval (Student t) and the range of each.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats
from typer.testing import CliRunner

from rinscal import earth
from rinscal.cli import app

SD_M = 1.5


def _run(*args: object) -> str:
    res = CliRunner().invoke(app, [str(a) for a in args])
    if res.exit_code:
        raise SystemExit(res.output)
    return res.output


def _track(df: pd.DataFrame, seed: int, out: Path) -> None:
    lat = np.deg2rad(df["ref_lat_deg"].to_numpy())
    h = df["ref_h_m"].to_numpy()
    rn, re = earth.principal_radii(lat)
    n = np.random.default_rng(seed).normal(0.0, SD_M, (lat.size, 3))
    pd.DataFrame(
        {
            "time_s": df["time_s"].to_numpy(),
            "ref_lat_deg": np.rad2deg(lat + n[:, 1] / (rn + h)),
            "ref_lon_deg": df["ref_lon_deg"].to_numpy()
            + np.rad2deg(n[:, 0] / ((re + h) * np.cos(lat))),
            "ref_h_m": h + n[:, 2],
        }
    ).to_csv(out, index=False)


def _horizontal(folder: Path) -> tuple[float, float]:
    e = pd.read_csv(folder / "errors.csv")
    h = e.loc[e["variant"] == "none", "horizontal_m"].to_numpy()
    return math.sqrt(float(np.mean(h**2)) / 2), float(h.max())


def _say(name: str, x: list[float]) -> None:
    a = np.asarray(x)
    half = stats.t.ppf(0.975, a.size - 1) * a.std(ddof=1) / math.sqrt(a.size)
    print(f"{name}: {a.mean():.3g} ± {half:.2g} (95 %, n={a.size}), {a.min():.3g}-{a.max():.3g}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    n_seeds = ap.parse_args().seeds
    d = Path(tempfile.mkdtemp(prefix="aided-cli-"))
    rec = d / "veh.parquet"
    _run("navigate", "--scenario", "vehicle", "--hours", "0.12", "--rate", "5", "--align-s",
         "60", "--no-oracle", "--out", d / "sim", "--record", rec)  # fmt: skip
    full = pd.read_parquet(rec)
    full[full["time_s"] > 61.0].to_parquet(d / "drive.parquet", index=False)
    (d / "drive.parquet.meta.json").write_text(Path(f"{rec}.meta.json").read_text())
    heading, zv, im = [], [], []
    for seed in range(n_seeds):
        _track(full.iloc[::5], seed, d / "track.csv")
        common = ["--track", d / "track.csv", "--gnss-sd", SD_M]
        _run("navigate", "--log", d / "drive.parquet", *common, "--align-s", "300",
             "--out", d / "im")  # fmt: skip
        s = json.loads((d / "im" / "summary.json").read_text())
        heading.append(abs(s["variants"]["none"]["attitude_error_at_nav_start"]["heading_arcsec"]))
        _run("navigate", "--log", rec, *common, "--align-start-s", "0", "--align-s", "60",
             "--aiding", "gnss", "--out", d / "zv")  # fmt: skip
        zv.append(_horizontal(d / "zv"))
        _run("navigate", "--log", d / "drive.parquet", *common, "--align-s", "300",
             "--aiding", "gnss", "--out", d / "ima")  # fmt: skip
        im.append(_horizontal(d / "ima"))
    _say("|heading error| after 300 s in motion [deg]", [h / 3600 for h in heading])
    _say("aided after zero velocity: RMS per coordinate [m]", [a for a, _ in zv])
    _say("aided after zero velocity: max horizontal [m]", [b for _, b in zv])
    _say("aided after in motion: RMS per coordinate [m]", [a for a, _ in im])
    _say("aided after in motion: max horizontal [m]", [b for _, b in im])


if __name__ == "__main__":
    main()

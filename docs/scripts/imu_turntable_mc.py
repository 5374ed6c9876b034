"""Monte Carlo over the turntable's errors (issue 25): what a ±5′ two-axis table allows the
multi-position calibration of the `paper` IMU to recover.

For each seed, the default calibration (19 positions, rate tests at ±10/50/200 °/s about each
axis, 5 set points) is simulated twice from the same seed: on an ideal table and with Table
2's errors (each position's axes off by a uniform draw in ±5′, each rate off by a draw in
±10 ppm); both are fitted with ``calibrate_imu`` and joined with the truth. Writes, beside
this script's results folder, ``worst.csv`` (per seed, table and kind of parameter: the
largest error over the set points and axes) and ``summary.csv`` (median and 95th percentile
over the seeds), and prints the summary as Markdown.

    python docs/scripts/imu_turntable_mc.py [SEEDS]     # default 20 seeds, ~2.5 min
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from rinscal.calibration.imu.workflow import calibrate_imu
from rinscal.sim.config import ImuConfig
from rinscal.sim.multiposition import simulate_multiposition

OUT = Path(__file__).resolve().parents[1] / "results" / "imu-turntable-mc"


def worst_errors(seed: int, turntable_error: bool) -> pd.Series:
    """Largest |estimate − truth| per kind of parameter over set points and axes."""
    log, truth, meta = simulate_multiposition(
        ImuConfig.paper(), seed=seed, turntable_error=turntable_error
    )
    res = calibrate_imu(log, meta)
    j = truth.merge(res.estimates, on=["temperature_c", "parameter"], suffixes=("_t", "_e"))
    err = (j["value_e"] - j["value_t"]).abs()
    kind = j["parameter"].str.rsplit("_", n=1).str[0] + " [" + j["unit_t"] + "]"
    out = err.groupby(kind).max()
    out["warnings"] = len(res.warnings)
    return out


def main(seeds: int = 20) -> pd.DataFrame:
    rows = []
    for seed in range(seeds):
        for te in (False, True):
            w = worst_errors(1000 + seed, te)
            rows.append({"seed": seed, "table": "±5′, ±10 ppm" if te else "ideal", **w})
    worst = pd.DataFrame(rows)
    OUT.mkdir(parents=True, exist_ok=True)
    worst.to_csv(OUT / "worst.csv", index=False)
    kinds = [c for c in worst.columns if c not in ("seed", "table")]
    summary = (
        worst.groupby("table")[kinds].quantile([0.5, 0.95]).rename_axis(["table", "quantile"]).T
    )
    summary.to_csv(OUT / "summary.csv")
    return summary


if __name__ == "__main__":
    print(main(int(sys.argv[1]) if len(sys.argv) > 1 else 20).round(4).to_string())

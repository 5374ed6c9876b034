"""Benchmark a study on Dask (issue: Monte Carlo studies).

Runs the quick ``paper`` study for ``--units`` units on a local cluster of 1 and then 2
worker processes, each into a fresh folder, and prints per run:

* wall time of the whole run (cluster start, tasks, every result written) and tasks/s;
* the scaling efficiency, tasks/s on 2 workers over twice tasks/s on 1 (target >= 0.8);
* Dask's overhead per task from its own task stream: on each worker, the idle gap between
  one task's end and the next one's start (scheduling, transfer, deserialisation), against
  the mean task run time (target < 5 %);
* the peak resident memory of a worker process.

The numba cache is warmed by one task before anything is timed, so that compilation is not
counted (the first study on a fresh install compiles once; later ones load the cache).

    python benchmarks/bench_study.py [--units 4]
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import tempfile
import time
from pathlib import Path

TARGET_EFFICIENCY = 0.8
TARGET_OVERHEAD = 0.05


def _ok(good: bool) -> str:
    return "OK" if good else "MISSED"


def one_run(units: int, workers: int) -> dict[str, float]:
    from distributed import get_task_stream

    from rinscal.cluster import dask_client
    from rinscal.experiments.study.runner import StudyStore, run_study
    from rinscal.experiments.study.spec import load_spec

    spec = load_spec("paper", quick=True, units_override=units)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        with dask_client(workers) as client, get_task_stream(client) as ts:
            run = run_study(spec, StudyStore(Path(tmp) / "s"), client=client)
        wall = time.perf_counter() - t0
    by_worker: dict[str, list[tuple[float, float]]] = {}
    for rec in ts.data:
        for ss in rec["startstops"]:
            if ss["action"] == "compute":
                by_worker.setdefault(rec["worker"], []).append((ss["start"], ss["stop"]))
    gaps, runs = [], []
    for spans in by_worker.values():
        spans.sort()
        runs += [b - a for a, b in spans]
        gaps += [s2[0] - s1[1] for s1, s2 in itertools.pairwise(spans)]
    return {
        "tasks": run.computed,
        "failed": run.failed,
        "wall_s": wall,
        "tasks_per_s": run.computed / wall,
        "mean_task_s": statistics.fmean(runs),
        "mean_gap_s": statistics.fmean(gaps) if gaps else 0.0,
        "peak_mb": run.peak_mb,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--units", type=int, default=4)
    args = ap.parse_args()
    one_run(1, 1)  # warm the numba cache (and the imports) with a one-unit study
    res = {w: one_run(args.units, w) for w in (1, 2)}
    for w, r in res.items():
        gap_ok = r["mean_gap_s"] < TARGET_OVERHEAD * r["mean_task_s"]
        print(
            f"{w} worker(s): {r['tasks']} tasks ({r['failed']} failed) in {r['wall_s']:.1f} s = "
            f"{r['tasks_per_s']:.3f} tasks/s; mean task {r['mean_task_s']:.2f} s, mean idle gap "
            f"between tasks {1000 * r['mean_gap_s']:.1f} ms "
            f"({100 * r['mean_gap_s'] / r['mean_task_s']:.2f} % of a task, target < "
            f"{100 * TARGET_OVERHEAD:.0f} %: {_ok(gap_ok)}); "
            f"peak worker memory {r['peak_mb']:.0f} MiB"
        )
    eff = res[2]["tasks_per_s"] / (2 * res[1]["tasks_per_s"])
    print(
        f"scaling efficiency 1 -> 2 workers: {eff:.2f} (target >= {TARGET_EFFICIENCY}: "
        f"{_ok(eff >= TARGET_EFFICIENCY)})"
    )


if __name__ == "__main__":
    main()

"""Benchmark: simulate 7 soak runs x 3 h at 100 Hz (7.56 M samples x 6 channels), write Parquet.

Target (issue: foundation): under 10 s wall time and under 2 GB peak memory on one core.

Runs the real command, ``rinscal simulate soak --rate 100 --out DIR/soak.parquet``, in a
child process pinned to one core, several times; prints the median and the range of the
wall time and the peak resident memory of the child, and appends them to
``benchmarks/results.csv`` as the row ``simulate-soak`` (:mod:`record`; ``--results FILE``
writes elsewhere).

    python benchmarks/bench_simulate.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

import record

TARGET_S = 10.0
TARGET_RSS_GB = 2.0


ARGS = ["simulate", "soak", "--rate", "100", "--hours", "3", "--out", "OUT/soak.parquet"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--results", type=Path, default=record.RESULTS, help="results file")
    args = parser.parse_args()
    record.read_rows(args.results)  # refuse a bad file before the timing
    pin = [min(os.sched_getaffinity(0))]
    before = record.load()
    with tempfile.TemporaryDirectory() as folder:
        cmd = [sys.executable, "-c", "from rinscal.cli import main; main()"]
        cmd += [a.replace("OUT", folder) for a in ARGS]
        paired = record.run_pairs(
            cmd, None, lambda argv: record.run_command(argv, pin=pin), runs=args.repeat, warmup=0
        )
        size = sum(os.path.getsize(os.path.join(folder, f)) for f in os.listdir(folder))
    walls = [r.wall_s for r in paired.command]
    rss = max(r.rss_mib for r in paired.command) / 1024
    row = record.paired_row(
        "simulate-soak",
        "rinscal " + " ".join(ARGS),
        "",
        paired,
        load_before=before,
        load_after=record.load(),
        pinned=record.pinned_text(pin),
        note="benchmarks/bench_simulate.py",
    )
    record.append_rows([row], args.results)
    med = statistics.median(walls)
    print("simulate soak: 7 runs x 3 h x 100 Hz = 7,560,000 samples, Parquet log + truth")
    spread = f"(min {min(walls):.2f}, max {max(walls):.2f}, n={len(walls)})"
    verdict = "OK" if med < TARGET_S else "MISSED"
    print(f"wall time  median {med:.2f} s {spread}  target < {TARGET_S:.0f} s  {verdict}")
    print(f"peak RSS   {rss:.2f} GB  target < {TARGET_RSS_GB:.0f} GB  "
          f"{'OK' if rss < TARGET_RSS_GB else 'MISSED'}")  # fmt: skip
    print(f"files      {size / 1e6:.0f} MB written")
    print(f"throughput {7_560_000 / med / 1e6:.2f} M samples/s")


if __name__ == "__main__":
    main()

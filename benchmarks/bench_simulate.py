"""Benchmark: simulate 7 soak runs x 3 h at 100 Hz (7.56 M samples x 6 channels), write Parquet.

Target (issue: foundation): under 10 s wall time and under 2 GB peak memory on one core.

Runs the real command, ``rinscal simulate soak --rate 100 --out DIR/soak.parquet``, in a
child process pinned to one core, several times; prints the median and the range of the
wall time and the peak resident memory of the child.

    python benchmarks/bench_simulate.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

TARGET_S = 10.0
TARGET_RSS_GB = 2.0


def one_run(folder: str) -> tuple[float, float]:
    """Wall time [s] and peak RSS [GB] of one simulate command."""
    code = (
        "import os, sys; os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}); "
        "from rinscal.cli import main; sys.argv = ['rinscal'] + sys.argv[1:]; main()"
    )
    cmd = [sys.executable, "-c", code, "simulate", "soak", "--rate", "100", "--hours", "3"]
    cmd += ["--out", os.path.join(folder, "soak.parquet")]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    # ru_maxrss of children is the largest child so far [kB on Linux]
    rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024**2
    return wall, rss


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    walls, rss = [], 0.0
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(args.repeat):
            w, r = one_run(folder)
            walls.append(w)
            rss = max(rss, r)
        size = sum(os.path.getsize(os.path.join(folder, f)) for f in os.listdir(folder))
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

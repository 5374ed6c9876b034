"""Whole-command memory and time of ``fit`` (method ``auto``, the default) against
``fit --method regression`` on the same log (issue 21, item 14).

Run pinned to one core, the log outside git::

    rinscal simulate soak --rate 100 --out /tmp/soak100.parquet
    taskset -c 0 python benchmarks/bench_fit_auto.py /tmp/soak100.parquet [--repeat 3]
        [--reference auto_before.json]

Each command runs as its own process under ``/usr/bin/time -v`` (its peak resident memory
and wall time), the two in turn, ``--repeat`` times; medians are printed, with the ratio of
the times pair by pair. ``--reference`` compares the chosen and fallback model of every
channel with a model file written by another version (e.g. before a change).

Targets: ``auto`` under 1.5 GB on the 100 Hz soak log (7 runs x 3 h, 7.56 M samples), under
2 GB at 400 Hz (30.2 M), in at most 1.5 times the time of ``fit --method regression``.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path


def measured(cmd: list[str]) -> tuple[float, float]:
    """Wall time [s] and peak resident memory [MiB] of one run of ``cmd``."""
    res = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True, check=False)
    if res.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{res.stderr[-2000:]}")
    wall = re.search(r"Elapsed \(wall clock\) time.*: (?:(\d+):)?(\d+):([\d.]+)", res.stderr)
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", res.stderr)
    if wall is None or rss is None:
        sys.exit("could not read /usr/bin/time -v output")
    h, m, s = wall.groups()
    return int(h or 0) * 3600 + int(m) * 60 + float(s), int(rss.group(1)) / 1024


def choices(path: Path) -> dict[str, tuple[str, str]]:
    """Chosen and fallback candidate of each channel of an ``auto`` model file."""
    doc = json.loads(path.read_text())
    out = {}
    for c, cm in doc["payload"]["channel_models"].items():
        out[c] = (cm["selection"]["chosen"], cm["selection"]["fallback"])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log", type=Path)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--reference", type=Path, help="an auto model file to compare choices")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        auto_out, reg_out = Path(tmp) / "auto.json", Path(tmp) / "reg.json"
        commands = {
            "auto": ["rinscal", "fit", str(args.log), "--out", str(auto_out)],
            "regression": [
                "rinscal", "fit", str(args.log), "--method", "regression", "--out", str(reg_out)
            ],
        }  # fmt: skip
        runs: dict[str, list[tuple[float, float]]] = {k: [] for k in commands}
        for _ in range(args.repeat):
            for name, cmd in commands.items():
                runs[name].append(measured(cmd))
        for name, vals in runs.items():
            walls, peaks = zip(*vals, strict=True)
            print(
                f"{name:>10}: wall {statistics.median(walls):.1f} s median "
                f"({min(walls):.1f}-{max(walls):.1f}), peak {statistics.median(peaks):.0f} MiB "
                f"({min(peaks):.0f}-{max(peaks):.0f})"
            )
        ratio = [a[0] / b[0] for a, b in zip(runs["auto"], runs["regression"], strict=True)]
        print(f"auto / regression wall: {statistics.median(ratio):.2f} median")
        if args.reference is not None:
            ref, got = choices(args.reference), choices(auto_out)
            same = [c for c in ref if ref[c] == got.get(c)]
            print(f"choices equal to the reference on {len(same)} of {len(ref)} channels")
            for c in ref:
                if ref[c] != got.get(c):
                    print(f"  {c}: reference {ref[c]}, now {got.get(c)}")


if __name__ == "__main__":
    main()

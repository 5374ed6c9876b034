"""Whole-command memory and time of ``fit`` (method ``auto``, the default) against
``fit --method regression`` on the same log (issue 21, item 14).

Run pinned to one core, the log outside git::

    rinscal simulate soak --rate 100 --out /tmp/soak100.parquet
    taskset -c 0 python benchmarks/bench_fit_auto.py /tmp/soak100.parquet [--repeat 3]
        [--reference auto_before.json]

Each command runs as its own process (:func:`record.run_command`: its wall time, CPU time
and peak resident memory), the two in turn, ``--repeat`` times; medians are printed, with the
ratio of the times pair by pair, and appended to ``benchmarks/results.csv`` as the row
``fit-auto-vs-regression`` (``--results FILE`` writes elsewhere). ``--reference`` compares
the chosen and fallback model of every channel with a model file written by another version
(e.g. before a change).

Targets: ``auto`` under 1.5 GB on the 100 Hz soak log (7 runs x 3 h, 7.56 M samples), under
2 GB at 400 Hz (30.2 M), in at most 1.5 times the time of ``fit --method regression``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

import record


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
    ap.add_argument("--results", type=Path, default=record.RESULTS, help="results file")
    args = ap.parse_args()
    try:
        record.read_rows(args.results)  # refuse a bad file before the timing
    except record.RecordError as e:
        sys.exit(f"error: {e}")
    with tempfile.TemporaryDirectory() as tmp:
        auto_out, reg_out = Path(tmp) / "auto.json", Path(tmp) / "reg.json"
        commands = {
            "auto": ["rinscal", "fit", str(args.log), "--out", str(auto_out)],
            "regression": [
                "rinscal", "fit", str(args.log), "--method", "regression", "--out", str(reg_out)
            ],
        }  # fmt: skip
        before = record.load()
        try:
            paired = record.run_pairs(
                commands["auto"], commands["regression"], record.run_command,
                runs=args.repeat, warmup=0,
            )  # fmt: skip
        except record.RecordError as e:
            sys.exit(f"error: {e}")
        after = record.load()
        for name, runs in (("auto", paired.command), ("regression", paired.yardstick or ())):
            walls, peaks = [r.wall_s for r in runs], [r.rss_mib for r in runs]
            print(
                f"{name:>10}: wall {statistics.median(walls):.1f} s median "
                f"({min(walls):.1f}-{max(walls):.1f}), peak {statistics.median(peaks):.0f} MiB "
                f"({min(peaks):.0f}-{max(peaks):.0f})"
            )
        print(f"auto / regression wall: {statistics.median(paired.ratios()):.2f} median")
        log = Path(args.log).name
        row = record.paired_row(
            "fit-auto-vs-regression",
            f"rinscal fit {log} --out OUT/auto.json",
            f"rinscal fit {log} --method regression --out OUT/reg.json",
            paired,
            load_before=before,
            load_after=after,
            note=f"benchmarks/bench_fit_auto.py, rinscal on PATH, {log} "
            f"{Path(args.log).stat().st_size} B",
        )
        record.append_rows([row], args.results)
        if args.reference is not None:
            ref, got = choices(args.reference), choices(auto_out)
            same = [c for c in ref if ref[c] == got.get(c)]
            print(f"choices equal to the reference on {len(same)} of {len(ref)} channels")
            for c in ref:
                if ref[c] != got.get(c):
                    print(f"  {c}: reference {ref[c]}, now {got.get(c)}")


if __name__ == "__main__":
    main()

"""Pin what the commands write, and compare two pins: a refactor's "behaviour unchanged".

Issue 37 rebuilds the compensators, the navigation loop and the API; it must leave every
result the same. This script runs one chain of whole commands into a folder::

    python benchmarks/pin_outputs.py run DIR [--quick-reproduction]

(a 2 h soak at 1 Hz simulated, ``fit`` on it with the default method, ``compensate`` and
``evaluate`` with that model, a 30 min quasi-static scenario navigated with the model and
recorded, the recording navigated back with ``navigate --log``, and with
``--quick-reproduction`` also ``rinscal reproduce --quick --seed 0``), and compares two such
folders::

    python benchmarks/pin_outputs.py compare BEFORE AFTER [--rtol 1e-12]

file by file: JSON numbers and strings, and every column of every table (Parquet, CSV), to
a relative tolerance (an absolute one of ``rtol`` for values near 0). Keys that say when or
where a file was made (timestamps, elapsed times, paths, versions) are left out of the
comparison; the command lines and their exit codes are compared. Exit status 1 names every
difference.

Run ``run`` on the code before the change (e.g. a ``git worktree`` at the base commit, with
``PYTHONPATH`` pointing at its ``src``) and after, then ``compare``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

#: JSON keys that say when, where or how fast a file was made, not what it holds.
VOLATILE = {
    "elapsed_s",
    "wall_s",
    "created",
    "created_utc",
    "written",
    "date",
    "time_utc",
    "version",
    "rinscal_version",
    "python",
    "platform",
    "host",
    "path",
    "paths",
    "out",
    "command",
    "cwd",
    "peak_mib",
    "duration_s_wall",
    "timings_s",
}


#: The console script, run by this interpreter (so that ``PYTHONPATH`` picks the code).
ENTRY = "import sys; from rinscal.cli import main; sys.argv[0] = 'rinscal'; main()"


def chain(d: Path, quick_reproduction: bool) -> list[list[str]]:
    """The commands, each writing under ``d``."""
    soak, model = d / "soak.parquet", d / "model.json"
    run = d / "run.parquet"
    cmds = [
        ["simulate", "soak", "--hours", "2", "--rate", "1", "--seed", "0", "--out", str(soak)],
        ["fit", str(soak), "--out", str(model)],
        ["compensate", str(soak), "--model", str(model), "--out", str(d / "comp.parquet")],
        ["evaluate", str(soak), "--model", str(model)],
        [
            "navigate", "--scenario", "quasi-static", "--hours", "0.5", "--seed", "0",
            "--model", str(model), "--out", str(d / "nav"), "--record", str(run),
        ],
        ["navigate", "--log", str(run), "--model", str(model), "--out", str(d / "navlog")],
    ]  # fmt: skip
    if quick_reproduction:
        cmds.append(["reproduce", "--quick", "--seed", "0", "--out", str(d / "quick")])
    return cmds


def run(d: Path, quick_reproduction: bool) -> int:
    """Run the chain into ``d`` (created); write ``commands.json`` with each exit code and
    the console text with the folder's name replaced by ``DIR``."""
    d.mkdir(parents=True, exist_ok=True)
    log = []
    env = dict(os.environ, COLUMNS="120", NO_COLOR="1")
    for cmd in chain(d, quick_reproduction):
        p = subprocess.run(
            [sys.executable, "-c", ENTRY, *cmd], capture_output=True, text=True, env=env
        )
        text = (p.stdout + p.stderr).replace(str(d), "DIR")
        log.append({"args": [a.replace(str(d), "DIR") for a in cmd], "rc": p.returncode})
        (d / f"console_{len(log)}.txt").write_text(text)
        print(f"rc {p.returncode}: rinscal {' '.join(cmd)}", flush=True)
        if p.returncode != 0:
            print(text[-2000:], file=sys.stderr)
    (d / "commands.json").write_text(json.dumps(log, indent=1) + "\n")
    return max(e["rc"] for e in log)


def _close(a: float, b: float, rtol: float) -> bool:
    if math.isnan(a) and math.isnan(b):
        return True
    return abs(a - b) <= rtol * max(abs(a), abs(b), 1.0)


def compare_json(
    a: Any, b: Any, where: str, rtol: float, out: list[str], roots: tuple[str, str] = ("", "")
) -> None:
    """Append to ``out`` every difference between two parsed JSON values (strings compared
    with each folder's own path, ``roots``, read as ``DIR``)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k in VOLATILE:
                continue
            if k not in a or k not in b:
                out.append(f"{where}.{k}: only in {'after' if k not in a else 'before'}")
                continue
            compare_json(a[k], b[k], f"{where}.{k}", rtol, out, roots)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{where}: length {len(a)} vs {len(b)}")
            return
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            compare_json(x, y, f"{where}[{i}]", rtol, out, roots)
    elif isinstance(a, str) and isinstance(b, str):
        ra = a.replace(roots[0], "DIR") if roots[0] else a
        if ra != (b.replace(roots[1], "DIR") if roots[1] else b):
            out.append(f"{where}: {a!r} vs {b!r}")
    elif isinstance(a, bool | str | None) or isinstance(b, bool | str | None):
        if a != b:
            out.append(f"{where}: {a!r} vs {b!r}")
    elif not _close(float(a), float(b), rtol):
        out.append(f"{where}: {a!r} vs {b!r}")


def compare_table(a: pd.DataFrame, b: pd.DataFrame, where: str, rtol: float, out: list[str]):
    """Append every difference between two tables (columns, order, values)."""
    if list(a.columns) != list(b.columns) or len(a) != len(b):
        out.append(
            f"{where}: columns/rows {list(a.columns)}×{len(a)} vs {list(b.columns)}×{len(b)}"
        )
        return
    for c in a.columns:
        x, y = a[c].to_numpy(), b[c].to_numpy()
        if np.issubdtype(x.dtype, np.number) and np.issubdtype(y.dtype, np.number):
            x, y = x.astype(float), y.astype(float)
            bad = ~(
                (np.isnan(x) & np.isnan(y))
                | (np.abs(x - y) <= rtol * np.maximum(np.maximum(np.abs(x), np.abs(y)), 1.0))
            )
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                n = int(bad.sum())
                out.append(f"{where}[{c}]: {n} rows differ, first row {i}: {x[i]!r} vs {y[i]!r}")
        elif not a[c].reset_index(drop=True).equals(b[c].reset_index(drop=True)):
            out.append(f"{where}[{c}]: text differs")


def compare(before: Path, after: Path, rtol: float) -> list[str]:
    """Every difference between two folders written by :func:`run`."""
    out: list[str] = []
    files = sorted({p.relative_to(before) for p in before.rglob("*") if p.is_file()})
    files_after = {p.relative_to(after) for p in after.rglob("*") if p.is_file()}
    for rel in sorted(files_after - set(files)):
        out.append(f"{rel}: only after")
    for rel in files:
        a, b = before / rel, after / rel
        if not b.exists():
            out.append(f"{rel}: only before")
            continue
        suffix = rel.suffix.lower()
        if suffix == ".json":
            ja, jb = json.loads(a.read_text()), json.loads(b.read_text())
            compare_json(ja, jb, str(rel), rtol, out, (str(before), str(after)))
        elif suffix == ".parquet":
            compare_table(pd.read_parquet(a), pd.read_parquet(b), str(rel), rtol, out)
        elif suffix == ".csv":
            compare_table(pd.read_csv(a), pd.read_csv(b), str(rel), rtol, out)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    r = sub.add_parser("run", help="run the chain into DIR")
    r.add_argument("dir", type=Path)
    r.add_argument("--quick-reproduction", action="store_true")
    c = sub.add_parser("compare", help="compare two folders")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    c.add_argument("--rtol", type=float, default=1e-12)
    args = ap.parse_args(argv)
    if args.what == "run":
        return run(args.dir, args.quick_reproduction)
    diffs = compare(args.before, args.after, args.rtol)
    for line in diffs:
        print(line)
    print(f"{len(diffs)} differences (rtol {args.rtol:g})")
    return 1 if diffs else 0


if __name__ == "__main__":
    raise SystemExit(main())

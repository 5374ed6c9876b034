"""Time the whole commands of issue 39 and append their figures to ``benchmarks/results.csv``.

Run from anywhere (this checkout's ``src`` is put first on the children's path)::

    python benchmarks/run.py [NAME ...] [--runs 5] [--pin CPU] [--data DIR]
    python benchmarks/run.py --list

Each benchmark runs its command as a process, one warm-up run and then ``--runs`` timed
runs, in turn with its yardstick (``A B A B ...``; :mod:`record`):

* ``fit-regression``, ``fit-auto``, ``compensate``: the soak log of 7 runs x 3 h x 100 Hz
  (7.56 M samples, Parquet), paired with pandas reading the same file (the read floor);
* ``navigate-log``: ``navigate --log`` of an 8 h x 200 Hz recording with three variants
  (none and two models), paired with the same command on one core's worth of threads
  (``--jobs 1``) where ``navigate`` has that option, unpaired where it has not;
* ``reproduce-quick``: ``rinscal reproduce --quick`` (the warm-up run fills numba's cache),
  unpaired.

The input files are made once by this checkout's commands and kept in ``--data`` (default
``$RINSCAL_BENCH_DATA`` or ``~/.cache/rinscal-bench``, outside the repository); every timed
run writes into a fresh temporary folder. One row per benchmark is appended to the results
file; ``python benchmarks/perf_table.py`` then renders the README's table from it. The
machine's load average is part of each figure: run on a quiet machine, or say it was not.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import record

ROOT = record.ROOT
PY = sys.executable
RINSCAL = (PY, "-c", "from rinscal.cli import main; main()")
READ = (PY, "-c", "import sys, pandas; pandas.read_parquet(sys.argv[1])")
READ_TEXT = 'python -c "import sys, pandas; pandas.read_parquet(sys.argv[1])"'


@dataclass(frozen=True)
class Bench:
    """A benchmark: its command and yardstick as argument lists after ``rinscal`` / the
    yardstick's program, with ``{data}`` for the data folder and ``{out}`` for a fresh
    folder per run; ``needs``: the data files it reads."""

    name: str
    words: str
    args: tuple[str, ...]
    yardstick: tuple[str, ...] | None  # ("read", FILE) or rinscal arguments
    needs: tuple[str, ...]


SOAK = "{data}/soak100.parquet"
NAV = ("navigate", "--log", "{data}/run8h.parquet", "--model", "{data}/reg.json", "--model",
       "{data}/polyt.json", "--out", "{out}/nav")  # fmt: skip

BENCHES: dict[str, Bench] = {
    b.name: b
    for b in (
        Bench(
            "fit-regression",
            "fit --method regression, soak 7 x 3 h x 100 Hz (7.56 M samples), Parquet",
            ("fit", SOAK, "--method", "regression", "--out", "{out}/reg.json"),
            ("read", SOAK),
            ("soak100.parquet",),
        ),
        Bench(
            "fit-auto",
            "fit (method auto, the default), the same log",
            ("fit", SOAK, "--out", "{out}/auto.json"),
            ("read", SOAK),
            ("soak100.parquet",),
        ),
        Bench(
            "compensate",
            "compensate with the log's auto model, the same log, Parquet out",
            ("compensate", SOAK, "-m", "{data}/auto.json", "--out", "{out}/comp.parquet"),
            ("read", SOAK),
            ("soak100.parquet", "auto.json"),
        ),
        Bench(
            "navigate-log",
            "navigate --log, 8 h x 200 Hz recording (5.76 M rows), 3 variants",
            NAV,
            (*NAV, "--jobs", "1"),
            ("run8h.parquet", "reg.json", "polyt.json"),
        ),
        Bench(
            "reproduce-quick",
            "reproduce --quick, paper preset, warm numba cache",
            ("reproduce", "--quick", "--seed", "0", "--imu", "paper", "--out", "{out}/q"),
            None,
            (),
        ),
    )
}

#: How each data file is made: rinscal arguments, into a staging folder ``{stage}``.
MAKE: dict[str, tuple[str, ...]] = {
    "soak100.parquet": ("simulate", "soak", "--rate", "100", "--hours", "3", "--seed", "0",
                        "--imu", "paper", "--out", "{stage}/soak100.parquet"),
    "auto.json": ("fit", SOAK, "--out", "{stage}/auto.json"),
    "reg.json": ("fit", SOAK, "--method", "regression", "--out", "{stage}/reg.json"),
    "polyt.json": ("fit", SOAK, "--method", "poly-t", "--out", "{stage}/polyt.json"),
    "run8h.parquet": ("navigate", "--scenario", "quasi-static", "--hours", "8", "--rate", "200",
                      "--imu", "paper", "--no-oracle", "--out", "{stage}/sim8h",
                      "--record", "{stage}/run8h.parquet"),
}  # fmt: skip
#: What a data file needs made first.
MAKE_NEEDS = {"auto.json": ("soak100.parquet",), "reg.json": ("soak100.parquet",),
              "polyt.json": ("soak100.parquet",)}  # fmt: skip


def child_env() -> dict[str, str]:
    """The environment of every child: this checkout's ``src`` first on the path."""
    path = os.environ.get("PYTHONPATH", "")
    return {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT / "src"), path) if p)}


def default_data() -> Path:
    env = os.environ.get("RINSCAL_BENCH_DATA")
    return Path(env) if env else Path.home() / ".cache" / "rinscal-bench"


def make_data(name: str, data: Path) -> None:
    """Make the data file ``name`` in ``data`` unless it is there (and what it needs first);
    made in a staging folder and moved in, so that a broken run leaves no half file."""
    if (data / name).exists():
        return
    for need in MAKE_NEEDS.get(name, ()):
        make_data(need, data)
    data.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".stage-", dir=data))
    try:
        args = [a.format(data=data, stage=stage) for a in MAKE[name]]
        print(f"making {data / name}: rinscal {' '.join(args)}", file=sys.stderr, flush=True)
        done = subprocess.run([*RINSCAL, *args], env=child_env(), capture_output=True, text=True)
        if done.returncode != 0:
            raise record.RecordError(
                f"making {name} failed (exit {done.returncode}):\n{done.stderr[-3000:]}"
            )
        for p in stage.iterdir():
            if p.is_file():
                os.replace(p, data / p.name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def has_jobs(command: str) -> bool:
    """Whether ``rinscal COMMAND --help`` (this checkout) lists a ``--jobs`` option."""
    done = subprocess.run(
        [*RINSCAL, command, "--help"],
        env={**child_env(), "COLUMNS": "200", "TERM": "dumb"},
        capture_output=True,
        text=True,
        check=True,
    )
    return jobs_in_help(done.stdout)


def jobs_in_help(text: str) -> bool:
    """Whether a ``--help`` text lists ``--jobs`` as an option."""
    return re.search(r"(?:^|[\s│,])--jobs\b", text) is not None


def argv_of(args: Sequence[str], data: Path) -> list[str]:
    """A benchmark's arguments as a command of this interpreter, ``{out}`` left in."""
    if args[0] == "read":
        return [*READ, *(a.replace("{data}", str(data)) for a in args[1:])]
    return [*RINSCAL, *(a.replace("{data}", str(data)) for a in args)]


def text_of(args: Sequence[str]) -> str:
    """The command as the record states it: ``DATA`` and ``OUT`` for the folders."""
    words = [a.replace("{data}", "DATA").replace("{out}", "OUT") for a in args]
    if words[0] == "read":
        return f"{READ_TEXT} {' '.join(words[1:])}"
    return "rinscal " + " ".join(words)


def fresh_out_runner(pin: Sequence[int] | None) -> record.Runner:
    """A runner that puts a fresh temporary folder for ``{out}`` in each run."""
    env = child_env()

    def run(argv: Sequence[str]) -> record.Run:
        with tempfile.TemporaryDirectory(prefix="rinscal-bench-") as out:
            cmd = [a.replace("{out}", out) for a in argv]
            return record.run_command(cmd, env=env, cwd=out, pin=pin)

    return run


def run_bench(
    bench: Bench,
    data: Path,
    *,
    runs: int,
    warmup: int,
    pin: Sequence[int] | None,
    results: Path,
    runner: record.Runner | None = None,
) -> dict[str, str]:
    """Make ``bench``'s data, time it against its yardstick, append the row; the row."""
    for need in bench.needs:
        make_data(need, data)
    yardstick = bench.yardstick
    note = ""
    if bench.name == "navigate-log" and not has_jobs("navigate"):
        yardstick, note = None, "unpaired: navigate has no --jobs in this version"
    sizes = [f"{n} {(data / n).stat().st_size} B" for n in bench.needs if n.endswith(".parquet")]
    if sizes:
        note = "; ".join([*([note] if note else []), "input " + ", ".join(sizes)])
    cmd = argv_of(bench.args, data)
    ys = None if yardstick is None else argv_of(yardstick, data)
    print(f"{bench.name}: {text_of(bench.args)}", file=sys.stderr, flush=True)
    before = record.load()
    paired = record.run_pairs(cmd, ys, runner or fresh_out_runner(pin), runs=runs, warmup=warmup)
    row = record.paired_row(
        bench.name,
        text_of(bench.args),
        "" if yardstick is None else text_of(yardstick),
        paired,
        load_before=before,
        load_after=record.load(),
        pinned=record.pinned_text(pin),
        note=note,
    )
    record.append_rows([row], results)
    return row


def summary(row: dict[str, str]) -> str:
    s = (
        f"{row['benchmark']}: wall {float(row['wall_median_s']):.2f} s median "
        f"({float(row['wall_min_s']):.2f}-{float(row['wall_max_s']):.2f}, n={row['runs']}), "
        f"cpu {float(row['cpu_median_s']):.2f} s, peak {float(row['rss_median_mib']):.0f} MiB"
    )
    if row["ratio_median"]:
        s += (
            f"; yardstick {float(row['yardstick_wall_median_s']):.2f} s, ratio "
            f"{float(row['ratio_median']):.2f} ({float(row['ratio_min']):.2f}-"
            f"{float(row['ratio_max']):.2f})"
        )
    return s + f"; load {row['load_before']} -> {row['load_after']}, pinned {row['pinned']}"


def parse_pin(text: str | None) -> list[int] | None:
    if text is None:
        return None
    try:
        return sorted({int(c) for c in text.split(",")})
    except ValueError:
        raise record.RecordError(f"--pin {text!r}: give CPU numbers, e.g. 0 or 0,1") from None


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", metavar="NAME", help=f"of {', '.join(BENCHES)} (all)")
    ap.add_argument("--runs", type=int, default=5, help="timed runs of each side (5)")
    ap.add_argument("--warmup", type=int, default=1, help="untimed runs of each side first (1)")
    ap.add_argument("--pin", metavar="CPU", help="pin every child to these CPUs, e.g. 0 or 0,1")
    ap.add_argument("--data", type=Path, default=None, help="data folder (outside the repo)")
    ap.add_argument("--results", type=Path, default=record.RESULTS, help="results file")
    ap.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    args = ap.parse_args(argv)
    if args.list:
        for b in BENCHES.values():
            print(f"{b.name:16} {b.words}\n{'':16} {text_of(b.args)}")
        return 0
    unknown = [n for n in args.names if n not in BENCHES]
    if unknown:
        print(f"unknown benchmark {', '.join(unknown)}; known: {', '.join(BENCHES)}",
              file=sys.stderr)  # fmt: skip
        return 2
    try:
        pin = parse_pin(args.pin)
        record.read_rows(args.results)  # refuse a bad file before minutes of timing
        data = (args.data or default_data()).expanduser().resolve()
        for name in args.names or list(BENCHES):
            row = run_bench(
                BENCHES[name],
                data,
                runs=args.runs,
                warmup=args.warmup,
                pin=pin,
                results=args.results,
            )
            print(summary(row), flush=True)
    except record.RecordError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

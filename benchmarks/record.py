"""The benchmark record: time whole commands as processes and append the figures to a
committed results file, ``benchmarks/results.csv``, so that the next slow-down shows.

Public tools only: each run is a child process (:mod:`subprocess`) reaped with
:func:`os.wait4`, whose resource usage gives the child's user + system CPU time and peak
resident memory (its own and that of the processes it waited for); the wall time is
:func:`time.perf_counter` around the process. A command is paired with a *yardstick* (e.g.
pandas reading the command's input: the read floor), run in turn ``A B A B ...`` after one
warm-up of each, and the ratio is taken pair by pair (so a machine that slows down for a
while slows both sides of the pairs it touches), then summarised by its median and range.

One row per figure: benchmark name, command, commit (``git rev-parse HEAD``, ``-dirty`` when
tracked files differ from it), date (UTC), machine (CPU model, cores, memory), 1-minute load
average before and after and the largest read before, between and after the runs (empty in
the first rows, taken before it was read), pinned cores, runs, wall median/min/max, CPU
median, peak RSS median, the yardstick's median and the paired ratio's median/min/max.
In-process kernel timings of the ``bench_*.py`` scripts go in the same file through
:func:`kernel_row` (no yardstick, CPU time of the process).

The file is only ever appended to: the old content is copied verbatim into a temporary file
beside it, the new rows written after it, and the temporary file moved over the old one with
:func:`os.replace` (atomic on POSIX and Windows), under an exclusive lock on the folder where
the platform has one. A file whose header or rows are not the record's is refused with the
file, line and column named, and left as it was.

Nothing here asserts a time: the record is for people and review, not for the test suite.
"""

from __future__ import annotations

import contextlib
import csv
import io
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().with_name("results.csv")

#: The columns of the results file, in order (its header line).
COLUMNS: tuple[str, ...] = (
    "benchmark",
    "kind",
    "command",
    "yardstick",
    "commit",
    "date_utc",
    "cpu_model",
    "cores",
    "mem_gib",
    "python",
    "load_before",
    "load_after",
    "load_max",
    "pinned",
    "runs",
    "wall_median_s",
    "wall_min_s",
    "wall_max_s",
    "cpu_median_s",
    "rss_median_mib",
    "yardstick_wall_median_s",
    "yardstick_cpu_median_s",
    "yardstick_rss_median_mib",
    "ratio_median",
    "ratio_min",
    "ratio_max",
    "note",
)
#: Columns that hold a number in every row (the others may be empty or text).
NUMERIC = ("cores", "mem_gib", "load_before", "load_after", "runs", "wall_median_s",
           "wall_min_s", "wall_max_s")  # fmt: skip
#: Columns that hold a number or nothing.
OPTIONAL_NUMERIC = (
    "load_max",
    "cpu_median_s",
    "rss_median_mib",
    "yardstick_wall_median_s",
    "yardstick_cpu_median_s",
    "yardstick_rss_median_mib",
    "ratio_median",
    "ratio_min",
    "ratio_max",
)
KINDS = ("command", "kernel")


class RecordError(Exception):
    """A results file that is not the record, a failed command, or a bad argument."""


# ----------------------------------------------------------------------------- one process


@dataclass(frozen=True)
class Run:
    """One process: wall time [s], user + system CPU time [s], peak resident memory [MiB]."""

    wall_s: float
    cpu_s: float
    rss_mib: float


Clock = Callable[[], float]
Runner = Callable[[Sequence[str]], Run]


def _maxrss_mib(ru_maxrss: int) -> float:
    """``ru_maxrss`` in MiB: kibibytes on Linux, bytes on macOS."""
    return ru_maxrss / 1024**2 if sys.platform == "darwin" else ru_maxrss / 1024


def run_command(
    argv: Sequence[str],
    *,
    env: Mapping[str, str] | None = None,
    cwd: str | Path | None = None,
    pin: Sequence[int] | None = None,
    clock: Clock = time.perf_counter,
) -> Run:
    """Run ``argv`` once as a child process (pinned to the CPUs ``pin`` if given) and measure it.

    Its output goes to a temporary file; a non-zero exit raises :class:`RecordError` with the
    command, the exit status and the output's last lines. ``clock`` reads the wall time
    (seconds, monotonic); a test may inject its own. The peak memory is the child's as Linux
    counts it, which includes the memory of this process when it started the child (``exec``
    keeps the old image's high-water mark): measure from a small process (``run.py`` is).
    """
    if not argv:
        raise RecordError("an empty command")
    preexec = None
    if pin is not None:
        cpus = set(pin)
        if not hasattr(os, "sched_setaffinity"):
            raise RecordError("--pin: this platform cannot pin a process to a CPU")
        allowed = os.sched_getaffinity(0)
        if not cpus or not cpus <= allowed:
            raise RecordError(f"--pin {sorted(cpus)}: this process may run on {sorted(allowed)}")

        def preexec() -> None:
            os.sched_setaffinity(0, cpus)

    with tempfile.TemporaryFile() as out:
        t0 = clock()
        proc = subprocess.Popen(
            list(argv),
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
            env=None if env is None else dict(env),
            cwd=cwd,
            preexec_fn=preexec,
        )
        _, status, usage = os.wait4(proc.pid, 0)
        wall = clock() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        if proc.returncode != 0:
            out.seek(0)
            tail = out.read().decode("utf-8", "replace")[-3000:]
            raise RecordError(
                f"{' '.join(argv)} failed (exit status {proc.returncode}); its output ends:\n{tail}"
            )
    return Run(wall, usage.ru_utime + usage.ru_stime, _maxrss_mib(usage.ru_maxrss))


# ----------------------------------------------------------------------------- pairs


@dataclass(frozen=True)
class Paired:
    """The timed runs of a command and of its yardstick (None: unpaired), in the order run:
    ``command[i]`` and ``yardstick[i]`` are the i-th pair; ``loads``: the 1-minute load
    average read after each run (warm-ups included)."""

    command: tuple[Run, ...]
    yardstick: tuple[Run, ...] | None
    loads: tuple[float, ...] = ()

    def ratios(self) -> list[float]:
        """Command wall over yardstick wall, pair by pair (empty when unpaired)."""
        if self.yardstick is None:
            return []
        return [a.wall_s / b.wall_s for a, b in zip(self.command, self.yardstick, strict=True)]


def run_pairs(
    command: Sequence[str],
    yardstick: Sequence[str] | None,
    runner: Runner,
    *,
    runs: int,
    warmup: int = 1,
    load_reader: Callable[[], float] | None = None,
) -> Paired:
    """``warmup`` untimed runs of each, then ``runs`` pairs ``A B A B ...`` (A the command,
    B the yardstick; A alone when there is no yardstick), each through ``runner``; the load
    (``load_reader``, default :func:`load`) is read after each run."""
    if runs < 1:
        raise RecordError(f"runs={runs}: give at least one run")
    if warmup < 0:
        raise RecordError(f"warmup={warmup}: give zero or more warm-up runs")
    read_load = load_reader or load
    loads: list[float] = []

    def one(argv: Sequence[str]) -> Run:
        r = runner(argv)
        loads.append(read_load())
        return r

    for _ in range(warmup):
        one(command)
        if yardstick is not None:
            one(yardstick)
    a: list[Run] = []
    b: list[Run] = []
    for _ in range(runs):
        a.append(one(command))
        if yardstick is not None:
            b.append(one(yardstick))
    return Paired(tuple(a), None if yardstick is None else tuple(b), tuple(loads))


# ----------------------------------------------------------------------------- context


def machine() -> dict[str, str]:
    """CPU model, logical cores of the machine, memory [GiB], Python version."""
    cpu = platform.processor() or platform.machine() or "unknown CPU"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    try:
        mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 1024**3
    except (AttributeError, ValueError, OSError):
        mem = float("nan")
    return {
        "cpu_model": cpu,
        "cores": str(os.cpu_count() or 0),
        "mem_gib": f"{mem:.1f}",
        "python": platform.python_version(),
    }


def commit(root: Path = ROOT, results: Path = RESULTS) -> str:
    """``git rev-parse HEAD`` of ``root``, with ``-dirty`` when a tracked file other than the
    results file differs from it; ``unknown`` outside a git checkout."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True
        ).stdout.strip()
        spec = [".", f":(exclude){results.resolve().relative_to(root.resolve()).as_posix()}"]
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    except ValueError:  # the results file lies outside the checkout
        spec = ["."]
    status = subprocess.run(
        ["git", "status", "--porcelain", "--untracked-files=no", "--", *spec],
        cwd=root,
        capture_output=True,
        text=True,
        check=False,
    ).stdout
    return head + ("-dirty" if status.strip() else "")


def load() -> float:
    """The 1-minute load average (NaN where the platform has none)."""
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):
        return float("nan")


def pinned_text(pin: Sequence[int] | None) -> str:
    """``none`` or the CPUs as ``0`` / ``0,1``."""
    return "none" if pin is None else ",".join(str(c) for c in sorted(set(pin)))


def _utc_now() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


# ----------------------------------------------------------------------------- rows


def _f(x: float | None, digits: int) -> str:
    return "" if x is None else f"{x:.{digits}f}"


def _context(
    load_before: float, load_after: float, pinned: str, loads: Sequence[float] = ()
) -> dict[str, str]:
    readings = [x for x in (load_before, *loads, load_after) if x == x]  # NaN: not read
    return {
        "commit": commit(),
        "date_utc": _utc_now(),
        **machine(),
        "load_before": _f(load_before, 2),
        "load_after": _f(load_after, 2),
        "load_max": _f(max(readings), 2) if readings else "",
        "pinned": pinned,
    }


def paired_row(
    name: str,
    command: str,
    yardstick: str,
    paired: Paired,
    *,
    load_before: float,
    load_after: float,
    pinned: str = "none",
    note: str = "",
) -> dict[str, str]:
    """The results row of a whole command: medians and range of its runs, its yardstick's
    medians and the pairwise ratio's median and range (empty when unpaired)."""
    walls = [r.wall_s for r in paired.command]
    row = {
        "benchmark": name,
        "kind": "command",
        "command": command,
        "yardstick": yardstick if paired.yardstick is not None else "",
        **_context(load_before, load_after, pinned, paired.loads),
        "runs": str(len(walls)),
        "wall_median_s": _f(statistics.median(walls), 3),
        "wall_min_s": _f(min(walls), 3),
        "wall_max_s": _f(max(walls), 3),
        "cpu_median_s": _f(statistics.median(r.cpu_s for r in paired.command), 3),
        "rss_median_mib": _f(statistics.median(r.rss_mib for r in paired.command), 1),
        "note": note,
    }
    if paired.yardstick is not None:
        ratios = paired.ratios()
        y = paired.yardstick
        row |= {
            "yardstick_wall_median_s": _f(statistics.median(r.wall_s for r in y), 3),
            "yardstick_cpu_median_s": _f(statistics.median(r.cpu_s for r in y), 3),
            "yardstick_rss_median_mib": _f(statistics.median(r.rss_mib for r in y), 1),
            "ratio_median": _f(statistics.median(ratios), 3),
            "ratio_min": _f(min(ratios), 3),
            "ratio_max": _f(max(ratios), 3),
        }
    return {c: row.get(c, "") for c in COLUMNS}


def kernel_row(
    name: str,
    command: str,
    walls: Sequence[float],
    *,
    cpus: Sequence[float] | None = None,
    rss_mib: float | None = None,
    load_before: float,
    load_after: float,
    note: str = "",
) -> dict[str, str]:
    """The results row of a timing taken inside a benchmark script (``walls`` [s], one per
    repetition; ``cpus`` the process CPU time of each [s]; ``rss_mib`` the process's peak so
    far). The pinned CPUs are this process's affinity when it is narrower than the machine."""
    if not walls:
        raise RecordError(f"{name}: no timings to record")
    try:
        allowed = sorted(os.sched_getaffinity(0))
        pinned = "none" if len(allowed) >= (os.cpu_count() or 0) else pinned_text(allowed)
    except AttributeError:  # pragma: no cover - macOS, Windows
        pinned = "none"
    row = {
        "benchmark": name,
        "kind": "kernel",
        "command": command,
        **_context(load_before, load_after, pinned),
        "runs": str(len(walls)),
        "wall_median_s": _f(statistics.median(walls), 4),
        "wall_min_s": _f(min(walls), 4),
        "wall_max_s": _f(max(walls), 4),
        "cpu_median_s": _f(statistics.median(cpus) if cpus else None, 4),
        "rss_median_mib": _f(rss_mib, 1),
        "note": note,
    }
    return {c: row.get(c, "") for c in COLUMNS}


def process_rss_mib() -> float:
    """Peak resident memory of this process so far [MiB]."""
    import resource

    return _maxrss_mib(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


# ----------------------------------------------------------------------------- the file


def _check_row(row: Mapping[str, str], where: str) -> None:
    for c in (*NUMERIC, *OPTIONAL_NUMERIC):
        v = row.get(c, "")
        if v == "" and c in OPTIONAL_NUMERIC:
            continue
        try:
            float(v)
        except ValueError:
            raise RecordError(f"{where}: column {c!r} holds {v!r}, not a number") from None
    if row.get("kind") not in KINDS:
        raise RecordError(f"{where}: column 'kind' holds {row.get('kind')!r}, not one of {KINDS}")
    if not row.get("benchmark"):
        raise RecordError(f"{where}: column 'benchmark' is empty")


def parse(text: str, where: str) -> list[dict[str, str]]:
    """The rows of a results file's ``text`` (``where`` names it in errors); refuses a header
    or a row that is not the record's."""
    lines = list(csv.reader(io.StringIO(text, newline="")))
    if not lines:
        return []
    if tuple(lines[0]) != COLUMNS:
        raise RecordError(
            f"{where}: line 1 is not the results header (expected the columns "
            f"{', '.join(COLUMNS)}; got {', '.join(lines[0])[:200]}); "
            "not a benchmark record, left as it is"
        )
    rows = []
    for n, fields in enumerate(lines[1:], start=2):
        if len(fields) != len(COLUMNS):
            raise RecordError(
                f"{where}: line {n} has {len(fields)} fields, the header {len(COLUMNS)}"
            )
        row = dict(zip(COLUMNS, fields, strict=True))
        _check_row(row, f"{where}: line {n}")
        rows.append(row)
    return rows


def read_rows(path: Path = RESULTS) -> list[dict[str, str]]:
    """Every row of the results file at ``path``, oldest first (none if it does not exist)."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return []
    return parse(text, str(path))


def _csv_text(rows: Sequence[Mapping[str, str]], header: bool) -> str:
    buf = io.StringIO(newline="")
    w = csv.writer(buf, lineterminator="\n")
    if header:
        w.writerow(COLUMNS)
    for row in rows:
        extra = set(row) - set(COLUMNS)
        if extra:
            raise RecordError(f"a row with columns the record has not: {sorted(extra)}")
        w.writerow([row.get(c, "") for c in COLUMNS])
    return buf.getvalue()


@contextlib.contextmanager
def _folder_lock(folder: Path) -> Iterator[None]:
    """An exclusive lock on ``folder`` (so that two benchmarks appending at once both keep
    their rows); nothing where the platform has no ``flock``."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    fd = os.open(folder, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def append_rows(rows: Sequence[Mapping[str, str]], path: Path = RESULTS) -> None:
    """Append ``rows`` to the results file at ``path`` (created with its header if absent).

    The earlier content is kept byte for byte: it is checked (a file that is not the record is
    refused, :class:`RecordError`, and left alone), copied into a temporary file in the same
    folder with the new rows after it, flushed to disk and moved over ``path`` with
    :func:`os.replace`; a failure before the move leaves ``path`` as it was.
    """
    for n, row in enumerate(rows):
        _check_row({c: row.get(c, "") for c in COLUMNS}, f"new row {n + 1}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with _folder_lock(path.parent):
        try:
            old = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            old = ""
        parse(old, str(path))
        if old and not old.endswith("\n"):
            old += "\n"
        text = old + _csv_text(rows, header=not old)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        try:
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
                f.write(text)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise


def latest(rows: Sequence[Mapping[str, str]]) -> dict[str, dict[str, str]]:
    """The last row of each benchmark (the file is in the order written), in the order each
    benchmark first appears."""
    out: dict[str, dict[str, str]] = {}
    for row in rows:
        out[row["benchmark"]] = dict(row)
    first = list(dict.fromkeys(r["benchmark"] for r in rows))
    return {name: out[name] for name in first}


# ----------------------------------------------------------------------------- helpers


@contextlib.contextmanager
def kernel_timer(
    name: str,
    command: str,
    *,
    results: Path | None = RESULTS,
    note: str = "",
) -> Iterator[list[tuple[float, float]]]:
    """Collect in-process timings and append them as one kernel row on exit.

    Usage::

        with kernel_timer("regression fit", "python benchmarks/bench_calibration.py") as t:
            for _ in range(3):
                with lap(t):
                    work()

    ``results=None`` records nothing. The load is read before the first and after the last.
    """
    laps: list[tuple[float, float]] = []
    before = load()
    yield laps
    if results is None or not laps:
        return
    append_rows(
        [
            kernel_row(
                name,
                command,
                [w for w, _ in laps],
                cpus=[c for _, c in laps],
                rss_mib=process_rss_mib(),
                load_before=before,
                load_after=load(),
                note=note,
            )
        ],
        results,
    )


@contextlib.contextmanager
def lap(laps: list[tuple[float, float]]) -> Iterator[None]:
    """Time the block: append (wall [s], process CPU [s]) to ``laps``."""
    w0, c0 = time.perf_counter(), time.process_time()
    yield
    laps.append((time.perf_counter() - w0, time.process_time() - c0))


def script_command(argv: Sequence[str]) -> str:
    """A benchmark script's command line as the record states it: ``python`` and the script
    relative to the repository, file arguments by their name only (no machine's paths)."""
    parts = ["python"]
    for i, a in enumerate(argv):
        p = Path(a)
        if i == 0:
            with contextlib.suppress(ValueError):
                a = p.resolve().relative_to(ROOT).as_posix()
        elif os.sep in a or "/" in a:
            a = p.name
        parts.append(a)
    return " ".join(parts)

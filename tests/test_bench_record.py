"""The benchmark record (benchmarks/record.py, run.py, perf_table.py): how figures are taken
and kept, not how fast anything is. No wall-clock assertion: timings here are injected, or
only their structure is checked; the README's block is compared with the committed file."""

from __future__ import annotations

import csv
import importlib.util
import io
import itertools
import os
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"


def _load(name: str, file: str) -> ModuleType:
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, BENCH / file)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


record = _load("record", "record.py")
perf_table = _load("perf_table", "perf_table.py")
bench_run = _load("bench_run", "run.py")
PY = sys.executable


def fake_runs(walls: list[float]) -> tuple:
    return tuple(record.Run(w, 0.5 * w, 100.0 + w) for w in walls)


def a_row(name: str = "b", walls: tuple[float, ...] = (2.0, 4.0, 9.0), note: str = "") -> dict:
    paired = record.Paired(fake_runs(list(walls)), fake_runs([1.0, 8.0, 3.0][: len(walls)]))
    return record.paired_row(
        name, "rinscal fit X", "read X", paired, load_before=0.5, load_after=1.25, note=note
    )


# ----------------------------------------------------------------------------- pairs


def test_pairs_run_in_turn_after_a_warm_up_and_the_ratio_is_taken_pair_by_pair() -> None:
    calls: list[str] = []
    walls = {"A": iter([99.0, 2.0, 4.0, 9.0]), "B": iter([99.0, 1.0, 8.0, 3.0])}

    def runner(argv):
        calls.append(argv[0])
        w = next(walls[argv[0]])
        return record.Run(w, w / 2, 10 * w)

    loads = iter([0.1, 0.2, 0.3, 7.5, 0.5, 0.6, 0.7, 0.8])
    paired = record.run_pairs(
        ["A"], ["B"], runner, runs=3, warmup=1, load_reader=lambda: next(loads)
    )
    assert calls == ["A", "B", "A", "B", "A", "B", "A", "B"]
    # the warm-up (99 s) is not among the timed runs
    assert [r.wall_s for r in paired.command] == [2.0, 4.0, 9.0]
    assert paired.ratios() == [2.0, 0.5, 3.0]
    row = record.paired_row("b", "A", "B", paired, load_before=0.5, load_after=1.25)
    # pair by pair: median of (2, 0.5, 3) = 2, not median(A) / median(B) = 4 / 3
    assert (row["ratio_median"], row["ratio_min"], row["ratio_max"]) == ("2.000", "0.500", "3.000")
    assert (row["wall_median_s"], row["wall_min_s"], row["wall_max_s"]) == (
        "4.000",
        "2.000",
        "9.000",
    )
    assert row["yardstick_wall_median_s"] == "3.000" and row["cpu_median_s"] == "2.000"
    assert row["rss_median_mib"] == "40.0" and row["yardstick_rss_median_mib"] == "30.0"
    assert (row["runs"], row["load_before"], row["load_after"]) == ("3", "0.50", "1.25")
    assert row["load_max"] == "7.50"  # read after each run, the warm-ups too
    assert row["kind"] == "command" and row["pinned"] == "none"


def test_an_unpaired_command_runs_alone_and_has_no_ratio() -> None:
    calls: list[str] = []

    def runner(argv):
        calls.append(argv[0])
        return record.Run(1.0, 1.0, 1.0)

    paired = record.run_pairs(["A"], None, runner, runs=2, warmup=1)
    assert calls == ["A", "A", "A"] and paired.yardstick is None and paired.ratios() == []
    row = record.paired_row("b", "A", "B", paired, load_before=0.0, load_after=0.0)
    assert row["yardstick"] == row["ratio_median"] == row["yardstick_wall_median_s"] == ""
    with pytest.raises(record.RecordError, match="runs=0"):
        record.run_pairs(["A"], None, runner, runs=0)


def test_a_real_process_with_an_injected_clock() -> None:
    """``python -c ...`` as a child: the wall time is the injected clock's, the peak memory
    is the child's own (it holds 200 MiB).

    Linux counts into a child's peak the memory of the process that started it, at the
    moment it started it (``exec`` keeps the old image's high-water mark), so the peak is
    measured from a small process, as ``benchmarks/run.py`` is, not from this test's
    (which holds a gigabyte after the whole suite)."""
    ticks = itertools.count(start=10.0, step=0.25)
    run = record.run_command(
        [PY, "-c", "b = bytearray(200 * 2**20); sum(range(10**6))"], clock=lambda: next(ticks)
    )
    assert run.wall_s == 0.25
    small = subprocess.run(
        [PY, "-c", "import sys, record; r = record.run_command(sys.argv[1:]); print(r.rss_mib)",
         PY, "-c", "b = bytearray(200 * 2**20); sum(range(10**6))"],
        capture_output=True, text=True, check=True, cwd=ROOT / "benchmarks",
    )  # fmt: skip
    assert 200 <= float(small.stdout) < 300
    assert run.cpu_s > 0
    with pytest.raises(record.RecordError, match=r"exit status 3.*\n.*boom"):
        record.run_command([PY, "-c", "import sys; print('boom'); sys.exit(3)"])


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no CPU affinity here")
def test_pinning_sets_the_childs_cpus(tmp_path: Path) -> None:
    cpu = max(os.sched_getaffinity(0))
    out = tmp_path / "cpus"
    code = "import os, sys; open(sys.argv[1], 'w').write(repr(sorted(os.sched_getaffinity(0))))"
    record.run_command([PY, "-c", code, str(out)], pin=[cpu])
    assert out.read_text() == repr([cpu])
    with pytest.raises(record.RecordError, match="--pin"):
        record.run_command([PY, "-c", "pass"], pin=[10_000])


# ----------------------------------------------------------------------------- the file


def test_rows_are_appended_and_the_earlier_ones_kept_byte_for_byte(tmp_path: Path) -> None:
    path = tmp_path / "results.csv"
    record.append_rows([a_row("one")], path)
    first = path.read_bytes()
    assert first.decode().splitlines()[0] == ",".join(record.COLUMNS)
    record.append_rows([a_row("two"), a_row("three", note='a "quoted", note')], path)
    assert path.read_bytes().startswith(first)
    rows = record.read_rows(path)
    assert [r["benchmark"] for r in rows] == ["one", "two", "three"]
    assert rows[2]["note"] == 'a "quoted", note' and rows[0] == a_row("one") | {
        k: rows[0][k] for k in ("commit", "date_utc")
    }
    assert len(path.read_text().splitlines()) == 4  # one header
    # a file whose last line lost its newline still gets whole rows after it
    path.write_bytes(path.read_bytes().rstrip(b"\n"))
    record.append_rows([a_row("four")], path)
    assert [r["benchmark"] for r in record.read_rows(path)] == ["one", "two", "three", "four"]


def test_the_write_is_atomic(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "results.csv"
    record.append_rows([a_row("one")], path)
    before = path.read_bytes()
    moves: list[tuple[str, str]] = []
    real_replace = os.replace

    def spy(src, dst):
        moves.append((str(src), str(dst)))
        real_replace(src, dst)

    monkeypatch.setattr(record.os, "replace", spy)
    record.append_rows([a_row("two")], path)
    [(src, dst)] = moves
    assert Path(src).parent == tmp_path and dst == str(path) and not Path(src).exists()

    def broken(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(record.os, "replace", broken)
    after_two = path.read_bytes()
    assert after_two.startswith(before)
    with pytest.raises(OSError, match="disk full"):
        record.append_rows([a_row("three")], path)
    assert path.read_bytes() == after_two  # untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.csv"]  # no temporary left


def _text(rows: list[list[str]]) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    return buf.getvalue()


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("time,value\n1,2\n", r"line 1 is not the results header"),
        ("", None),  # an empty file is a new record
        (_text([list(record.COLUMNS), ["b", "command"]]), r"line 2 has 2 fields, the header 27"),
        ("WALL", r"line 2: column 'wall_median_s' holds 'slow', not a number"),
        ("KIND", r"line 2: column 'kind' holds 'bench'"),
    ],
)
def test_a_file_that_is_not_the_record_is_refused_and_left_alone(
    tmp_path: Path, content: str, message: str | None
) -> None:
    path = tmp_path / "results.csv"
    good = a_row()
    if content in ("WALL", "KIND"):
        bad = good | ({"wall_median_s": "slow"} if content == "WALL" else {"kind": "bench"})
        content = _text([list(record.COLUMNS), [bad[c] for c in record.COLUMNS]])
    path.write_text(content, encoding="utf-8")
    if message is None:
        record.append_rows([good], path)
        assert len(record.read_rows(path)) == 1
        return
    with pytest.raises(record.RecordError, match=f"{path}: {message}"):
        record.append_rows([good], path)
    assert path.read_text(encoding="utf-8") == content
    with pytest.raises(record.RecordError, match=message):
        record.read_rows(path)


def test_a_bad_new_row_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "results.csv"
    with pytest.raises(record.RecordError, match="new row 1: column 'runs'"):
        record.append_rows([a_row() | {"runs": ""}], path)
    with pytest.raises(record.RecordError, match="columns the record has not"):
        record.append_rows([a_row() | {"speed": "fast"}], path)
    assert not path.exists()


def test_latest_is_the_last_row_of_each_benchmark() -> None:
    rows = [a_row("x", note="1"), a_row("y", note="2"), a_row("x", note="3")]
    last = record.latest(rows)
    assert list(last) == ["x", "y"] and last["x"]["note"] == "3" and last["y"]["note"] == "2"


def test_commit_is_head_and_dirty_when_a_tracked_file_differs(tmp_path: Path) -> None:
    def git(*args: str) -> str:
        return subprocess.run(
            ["git", "-c", "user.name=t", "-c", "user.email=t@t", *args],
            cwd=tmp_path, capture_output=True, text=True, check=True,
        ).stdout.strip()  # fmt: skip

    git("init", "-q")
    (tmp_path / "a.py").write_text("x = 1\n")
    results = tmp_path / "results.csv"
    results.write_text("")
    git("add", ".")
    git("commit", "-q", "-m", "one")
    head = git("rev-parse", "HEAD")
    assert record.commit(tmp_path, results) == head
    results.write_text("a row\n")  # the record itself does not make the tree dirty
    (tmp_path / "new.py").write_text("")  # nor an untracked file
    assert record.commit(tmp_path, results) == head
    (tmp_path / "a.py").write_text("x = 2\n")
    assert record.commit(tmp_path, results) == f"{head}-dirty"
    assert record.commit(tmp_path / "nowhere", results) == "unknown"


def test_kernel_rows_from_a_script(tmp_path: Path) -> None:
    path = tmp_path / "results.csv"
    with record.kernel_timer("k", "python benchmarks/bench_x.py", results=path, note="n") as laps:
        for _ in range(3):
            with record.lap(laps):
                pass
    [row] = record.read_rows(path)
    assert (row["benchmark"], row["kind"], row["runs"], row["note"]) == ("k", "kernel", "3", "n")
    assert row["ratio_median"] == "" and float(row["rss_median_mib"]) > 0
    with pytest.raises(ZeroDivisionError), record.kernel_timer("k", "c", results=path) as laps:
        with record.lap(laps):
            pass
        raise ZeroDivisionError  # a failed benchmark records nothing
    with record.kernel_timer("k", "c", results=None) as laps, record.lap(laps):
        pass
    assert len(record.read_rows(path)) == 1
    cmd = record.script_command([str(BENCH / "bench_navlog.py"), "--read", "/tmp/x/nav8h.parquet"])
    assert cmd == "python benchmarks/bench_navlog.py --read nav8h.parquet"


# ----------------------------------------------------------------------------- the driver


def test_the_driver_times_against_the_yardstick_and_appends(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    data = tmp_path / "data"
    data.mkdir()
    for name in ("soak100.parquet", "run8h.parquet", "reg.json", "polyt.json"):
        (data / name).write_bytes(b"1234")
    seen: list[list[str]] = []

    def runner(argv):
        seen.append(list(argv))
        return record.Run(2.0 if "fit" in argv else 1.0, 1.0, 50.0)

    results = tmp_path / "results.csv"
    row = bench_run.run_bench(
        bench_run.BENCHES["fit-regression"], data, runs=2, warmup=1, pin=None,
        results=results, runner=runner,
    )  # fmt: skip
    assert len(seen) == 6
    soak = str(data / "soak100.parquet")
    assert seen[0] == [*bench_run.RINSCAL, "fit", soak, "--method", "regression", "--out",
                       "{out}/reg.json"]  # fmt: skip
    assert seen[1][-1] == str(data / "soak100.parquet") and "pandas" in seen[1][2]
    assert (
        row["command"] == "rinscal fit DATA/soak100.parquet --method regression --out OUT/reg.json"
    )
    assert row["yardstick"].endswith('pandas.read_parquet(sys.argv[1])" DATA/soak100.parquet')
    assert row["ratio_median"] == "2.000" and "soak100.parquet 4 B" in row["note"]
    for has in (False, True):
        monkeypatch.setattr(bench_run, "has_jobs", lambda command, has=has: has)
        seen.clear()
        row = bench_run.run_bench(
            bench_run.BENCHES["navigate-log"], data, runs=1, warmup=0, pin=None,
            results=results, runner=runner,
        )  # fmt: skip
        assert len(seen) == (2 if has else 1)
        assert row["yardstick"].endswith("--jobs 1") == has
        assert ("unpaired" in row["note"]) != has
    assert [r["benchmark"] for r in record.read_rows(results)] == ["fit-regression"] + [
        "navigate-log"
    ] * 2


def test_jobs_is_found_in_a_help_text() -> None:
    assert bench_run.jobs_in_help("│ --jobs  -j  INTEGER  threads │")
    assert bench_run.jobs_in_help("  --jobs <int>   Threads.")
    assert not bench_run.jobs_in_help("  --workers <int>  processes (not --jobsite)")
    assert not bench_run.jobs_in_help("  --no-oracle")


def test_the_driver_refuses_an_unknown_name_and_a_bad_pin(capsys) -> None:
    assert bench_run.main(["nothing"]) == 2
    assert "unknown benchmark nothing" in capsys.readouterr().err
    with pytest.raises(record.RecordError, match="--pin 'x'"):
        bench_run.parse_pin("x")
    assert bench_run.parse_pin("1,0,1") == [0, 1]


# ----------------------------------------------------------------------------- the README


def test_readme_block_is_rendered_from_the_committed_record() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert perf_table.BEGIN in readme and perf_table.END in readme
    i = readme.index(perf_table.BEGIN)
    block = readme[i : readme.index(perf_table.END) + len(perf_table.END)]
    assert block == perf_table.render_block(record.read_rows(record.RESULTS)), (
        "README.md's benchmark record block differs from benchmarks/results.csv: "
        "run python benchmarks/perf_table.py"
    )


def test_committed_record_has_the_whole_commands_paired_with_the_read_floor() -> None:
    last = record.latest(record.read_rows(record.RESULTS))
    for name in ("fit-regression", "fit-auto", "compensate"):
        row = last[name]
        assert row["yardstick"].startswith('python -c "import sys, pandas; pandas.read_parquet')
        assert 0 < float(row["ratio_min"]) <= float(row["ratio_median"]) <= float(row["ratio_max"])
        assert int(row["runs"]) >= 3 and row["commit"] != "unknown"


def test_the_table_says_the_rows_figures(tmp_path: Path, capsys) -> None:
    rows = [
        a_row("fit-x", walls=(20.0, 30.0, 40.0)),
        record.kernel_row("k", "python b.py", [0.5], load_before=1.0, load_after=2.0),
        a_row("fit-x", walls=(21.0, 22.0, 23.5), note="a | b"),
    ]
    block = perf_table.render_block(rows)
    assert block.count("| fit-x |") == 1  # the latest row only
    assert "| **22.0** (21.0–23.5) |" in block and "a \\| b" in block
    assert "| **7.83** (2.75–21.00) |" in block  # 21 / 1, 22 / 8, 23.5 / 3 pair by pair
    assert "| k | `python b.py` | **0.500** (0.500–0.500) |" in block
    assert "| 3.0 (y1) |" in block and "Yardsticks: (y1) `read X`\n" in block
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n{perf_table.BEGIN}\nold\n{perf_table.END}\nafter\n")
    results = tmp_path / "results.csv"
    record.append_rows(rows, results)
    args = ["--readme", str(readme), "--results", str(results)]
    assert perf_table.main([*args, "--check"]) == 1
    assert "differs from" in capsys.readouterr().err
    assert perf_table.main(args) == 0
    assert perf_table.main([*args, "--check"]) == 0
    assert readme.read_text().endswith(f"{perf_table.END}\nafter\n")
    assert perf_table.main(["--results", str(results), "--history", "fit-x"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and "wall 30.0 s (20.0-40.0, 3 runs)" in lines[0]
    assert "ratio 7.83 (2.75-21.00) to 3.0 s" in lines[1]
    assert perf_table.main(["--results", str(results), "--history", "nothing"]) == 1
    readme.write_text("no markers\n")
    assert perf_table.main(args) == 2
    assert "the markers" in capsys.readouterr().err

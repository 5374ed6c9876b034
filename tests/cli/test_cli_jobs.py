"""Issue 39: one name for "how many cores" on every command that spreads work (``--jobs``,
``-j``; the API's ``n_jobs=``), ``--workers``/``workers=`` still taken on the Dask commands
as its other name, two different numbers refused; calibrate-field's starts estimated side by
side give the same model file as one after the other."""

from __future__ import annotations

from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

import rinscal
from rinscal.cli import app
from rinscal.errors import ConfigError

runner = CliRunner()

#: The commands that spread work, and how: threads in the process or Dask worker processes.
THREADS = (("navigate",), ("calibrate-field",))
WORKERS = (("reproduce",), ("study",), ("fleet", "fit"))


def _options(*path: str) -> dict:
    cmd = typer.main.get_command(app)
    for p in path:
        cmd = cmd.commands[p]  # type: ignore[attr-defined]
    return {o: p for p in cmd.params if p.param_type_name == "option" for o in p.opts}


@pytest.mark.parametrize("path", THREADS + WORKERS)
def test_every_command_that_spreads_work_documents_jobs(path) -> None:  # type: ignore[no-untyped-def]
    o = _options(*path)
    jobs = o["--jobs"]
    assert o["-j"] is jobs and not jobs.hidden and jobs.default is None
    assert "default: every core" in jobs.help and "does not depend on it" in jobs.help
    if path in WORKERS:  # the old name: taken, not shown
        assert o["--workers"] is o["-w"] and o["--workers"].hidden
        assert "--workers" in jobs.help
    else:
        assert "--workers" not in o


@pytest.mark.parametrize(
    "cmd",
    [
        ["reproduce", "--quick"],
        ["study", "paper", "--quick"],
        ["fleet", "fit", "no-such.csv"],
    ],
)
def test_jobs_and_workers_that_differ_are_refused_before_any_work(cmd, tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "out"
    res = runner.invoke(app, [*cmd, "--out", str(out), "--jobs", "2", "--workers", "3"])
    assert res.exit_code == 2, res.output
    text = " ".join(res.output.split())
    assert "--jobs 2 and --workers 3" in text and "old name of --jobs" in text
    assert not out.exists()


def test_jobs_with_a_scheduler_is_refused(tmp_path) -> None:  # type: ignore[no-untyped-def]
    res = runner.invoke(app, ["study", "paper", "--quick", "--out", str(tmp_path / "o"),
                              "-j", "2", "--scheduler", "tcp://127.0.0.1:8786"])  # fmt: skip
    assert res.exit_code == 2 and "--jobs and --scheduler exclude each other" in res.output


def test_the_api_takes_n_jobs_and_workers_as_its_other_name(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from rinscal.experiments.paper.run import plan_reproduction

    assert plan_reproduction(quick=True, n_jobs=3).config.jobs == 3
    assert plan_reproduction(quick=True, workers=3).config.jobs == 3
    assert plan_reproduction(quick=True, n_jobs=3, workers=3).config.jobs == 3
    with pytest.raises(ConfigError, match="n_jobs=2 and workers=3"):
        plan_reproduction(quick=True, n_jobs=2, workers=3)
    with pytest.raises(ConfigError, match="n_jobs=2 and workers=3"):
        rinscal.reproduce(tmp_path / "r", quick=True, n_jobs=2, workers=3)
    with pytest.raises(ConfigError, match="n_jobs=2 and workers=1"):
        rinscal.study("paper", tmp_path / "s", quick=True, n_jobs=2, workers=1)
    with pytest.raises(ConfigError, match="n_jobs"):
        rinscal.study("paper", tmp_path / "s", quick=True, n_jobs=0)
    assert not (tmp_path / "r").exists() and not (tmp_path / "s").exists()


@pytest.fixture(scope="module")
def starts(tmp_path_factory) -> list[Path]:  # type: ignore[no-untyped-def]
    """Three parked starts of the paper IMU at 0, 20 and 40 °C, 0.3 h at 10 Hz."""
    d = tmp_path_factory.mktemp("field")
    return rinscal.simulate_field_starts(
        d, runs=3, ambient_c=(0.0, 20.0, 40.0), hours=0.3, rate_hz=10.0, seed=3
    )


def test_calibrate_field_on_threads_writes_the_same_model_as_one(starts, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The starts' bias series estimated on three threads: the model file and the report
    byte for byte those of one thread, and the progress counted to the last start."""
    files = {}
    for jobs in ("1", "3"):
        out = tmp_path / f"m{jobs}.json"
        res = runner.invoke(app, ["calibrate-field", *map(str, starts), "--jobs", jobs,
                                  "--out", str(out)])  # fmt: skip
        assert res.exit_code == 0, res.output
        files[jobs] = (out.read_bytes(), out.with_suffix(".field.json").read_bytes())
    assert files["1"] == files["3"]
    seen: list[tuple[float, float]] = []
    cal = rinscal.calibrate_field(
        [str(p) for p in starts], n_jobs=3, progress=lambda d, t: seen.append((d, t))
    )
    assert sorted(seen) == [(1, 3), (2, 3), (3, 3)]
    assert list(cal.series) == [p.stem for p in starts]  # in the order given
    with pytest.raises(ConfigError, match="n_jobs"):
        rinscal.calibrate_field([str(p) for p in starts], n_jobs=-2)

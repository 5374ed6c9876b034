"""One rule for every output (issue 34, item 4): a command creates the missing folders of the
paths it writes, checks every output before any work, refuses a path through a file or a
folder it cannot write with a message naming it (never a traceback), and leaves no folder it
created behind when it fails."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.io.tables import write_log
from tests._shared import linear_log

runner = CliRunner()


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("inputs")
    log = d / "log.csv"
    write_log(linear_log(n=300, t0=0.0), log)
    model = d / "m.json"
    res = runner.invoke(app, ["fit", str(log), "--method", "poly-t", "--out", str(model)])
    assert res.exit_code == 0, res.output
    return {"log": log, "model": model}


def _invoke(args: list) -> tuple[int, str]:
    res = runner.invoke(app, [str(a) for a in args])
    text = " ".join(res.output.split())
    assert "Traceback" not in text and (
        res.exception is None or isinstance(res.exception, SystemExit)
    ), text
    return res.exit_code, text


def _commands(inputs: dict[str, Path], bad: Path) -> dict[str, list]:
    """Every command that writes, with ``bad`` as the output it is given."""
    log, model = inputs["log"], inputs["model"]
    quick = ["--hours", "0.05", "--rate", "5"]
    return {
        "fit": ["fit", log, "--out", bad / "m.json"],
        "compensate": ["compensate", log, "-m", model, "--out", bad / "c.csv"],
        "evaluate --allan-plot": ["evaluate", log, "-m", model, "--allan-plot", bad / "a.png"],
        "export": ["export", model, "--format", "c", "--out", bad / "m.h"],
        "plot": ["plot", log, "--out", bad / "p.png"],
        "simulate soak": ["simulate", "soak", "--hours", "0.05", "--out", bad / "s.csv"],
        "simulate multiposition": ["simulate", "multiposition", "--out", bad / "mp.csv"],
        "calibrate-imu": ["calibrate-imu", log, "--out", bad / "imu.json"],
        "navigate --out": ["navigate", "-s", "quasi-static", *quick, "--out", bad / "nav"],
        "navigate --record": [
            "navigate",
            "-s",
            "quasi-static",
            *quick,
            "--record",
            bad / "r.parquet",
            "--out",
            bad.parent / "nav",
        ],
        "reproduce": ["reproduce", "--quick", "--out", bad / "repro"],
        "study": ["study", "paper", "--quick", "--units", "1", "--out", bad / "study"],
        "fleet fit": ["fleet", "fit", log, "--out", bad / "fleet", "--workers", "1"],
    }


COMMANDS = list(_commands({"log": Path("l"), "model": Path("m")}, Path("b")))


@pytest.mark.parametrize("name", COMMANDS)
def test_an_output_through_a_file_is_refused_before_any_work(inputs, tmp_path, name) -> None:
    blocker = tmp_path / "afile"
    blocker.write_text("not a folder")
    before = sorted(tmp_path.rglob("*"))
    code, text = _invoke(_commands(inputs, blocker / "sub")[name])
    assert code == 2, text
    assert f"{blocker} is a file, not a folder" in text, text
    assert sorted(tmp_path.rglob("*")) == before  # nothing created, not even --out of navigate


@pytest.mark.parametrize("name", COMMANDS)
def test_a_folder_that_takes_no_files_is_refused(inputs, tmp_path, name) -> None:
    proc = Path("/proc")  # exists, is a folder, and takes no new files, even for root
    if not proc.is_dir():
        pytest.skip("no /proc on this system")
    code, text = _invoke(_commands(inputs, proc)[name])
    assert code == 2, text
    assert "cannot write" in text and "/proc" in text, text
    assert not (tmp_path / "nav").exists()  # navigate --record: its --out was not made


def test_a_folder_without_write_permission_is_refused_before_any_work(
    inputs, tmp_path, monkeypatch
) -> None:
    import tempfile

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied", kwargs.get("dir", "?"))

    monkeypatch.setattr(tempfile, "mkstemp", refuse)  # as a read-only folder answers
    out = tmp_path / "imu.json"
    code, text = _invoke(["calibrate-imu", inputs["log"], "--out", out])
    assert code == 2, text
    assert f"--out {out}: cannot write: Permission denied" in text


@pytest.mark.parametrize(
    "args",
    [
        ["fit", "{log}", "--method", "poly-t", "--out", "{new}/m.json"],
        ["simulate", "soak", "--hours", "0.05", "--rate", "1", "--out", "{new}/s.csv"],
        ["export", "{model}", "--format", "c", "--out", "{new}/m.h"],
        [
            "navigate",
            "-s",
            "quasi-static",
            "--hours",
            "0.05",
            "--align-s",
            "60",
            "--rate",
            "5",
            "--record",
            "{new}/r.csv",
            "--out",
            "{out}",
        ],
    ],
    ids=["fit", "simulate", "export", "navigate --record"],  # --record beside --out
)
def test_a_file_into_a_missing_folder_is_refused_naming_it(inputs, tmp_path, args) -> None:
    """One rule: a file goes into a folder that exists; none is created to hold it."""
    new = tmp_path / "a" / "b"
    subs = {"log": inputs["log"], "model": inputs["model"], "new": new, "out": tmp_path / "nav"}
    code, text = _invoke([a.format(**subs) for a in args])
    assert code == 2, text
    assert "does not exist" in text and str(tmp_path / "a") in text, text
    assert "Traceback" not in text
    assert not (tmp_path / "a").exists()  # nothing created, nothing left behind
    new.mkdir(parents=True)  # the folder made: the same command runs
    code, text = _invoke([a.format(**subs) for a in args])
    assert code == 0, text
    assert any(new.iterdir())


def test_a_folder_output_is_created_with_its_parents(tmp_path) -> None:
    """--out DIR (and a --record file inside it) is created: the folder is the output."""
    out = tmp_path / "runs" / "nav"
    code, text = _invoke(
        ["navigate", "-s", "quasi-static", "--hours", "0.05", "--align-s", "60", "--rate", "5",
         "--record", out / "r.csv", "--out", out]
    )  # fmt: skip
    assert code == 0, text
    assert (out / "summary.json").exists() and (out / "r.csv").exists()


def test_a_failed_command_leaves_no_folder_it_created(tmp_path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,run,gyro_x\n0,a,1\n1,a,2\n", encoding="utf-8")
    out = tmp_path / "new" / "sub" / "nav"
    code, text = _invoke(["navigate", "--log", bad, "--site", "34,108,400", "--out", out])
    assert code == 2 and "Traceback" not in text, text
    assert not (tmp_path / "new").exists()
    (tmp_path / "kept").mkdir()  # a folder that was there stays
    code, _ = _invoke(["navigate", "--log", bad, "--site", "34,108,400", "--out",
                       tmp_path / "kept" / "sub"])  # fmt: skip
    assert code == 2 and (tmp_path / "kept").is_dir() and not (tmp_path / "kept" / "sub").exists()


def test_a_write_that_fails_late_is_a_message_not_a_traceback(tmp_path, monkeypatch) -> None:
    """calibrate-imu: the disk fills after the checks, while the calibration is written."""
    import errno
    import os

    log = tmp_path / "mp.parquet"
    code, text = _invoke(["simulate", "multiposition", "--rate", "2", "--out", log])
    assert code == 0, text
    real_replace = os.replace

    def full(src, dst):
        if str(dst).endswith("imu.json"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", full)
    out = tmp_path / "imu.json"
    code, text = _invoke(["calibrate-imu", log, "--out", out])
    assert code == 2, text
    assert f"{out}: cannot write: No space left on device; the disk is full" in text
    assert not out.exists()


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes into any folder"
)
def test_a_read_only_folder_is_refused(inputs, tmp_path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        code, text = _invoke(["fit", inputs["log"], "--out", ro / "sub" / "m.json"])
        assert code == 2 and "cannot write: Permission denied" in text, text
        assert not (ro / "sub").exists()
    finally:
        ro.chmod(0o755)

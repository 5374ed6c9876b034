"""One source for timings: the README's block, ``--help`` and the console line at the start
of ``rinscal reproduce --quick`` quote ``rinscal/data/timings.json`` (written by
``docs/scripts/timings.py``), and the README states no other wall time of these commands.
Nothing is measured here."""

from __future__ import annotations

import re
from pathlib import Path
from types import ModuleType

import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.cli._timings import format_duration, load_timings, timing, timing_phrase
from rinscal.cli.reproduce import expected_time
from tests._shared import docs_script

ROOT = Path(__file__).resolve().parents[1]
ENV = {"COLUMNS": "80", "TERM": "dumb"}


def _script() -> ModuleType:
    return docs_script("timings")


def _flat(text: str) -> str:
    return re.sub(r"[\s│]+", " ", text)


FAKE = {
    "commands": {
        "quick_reproduction": {
            "command": "rinscal reproduce --quick --seed 0 --imu paper --out DIR",
            "size": "the quick reproduction",
            "wall_s": 111.6,
            "runs_s": [111.6],
            "peak_mib": 612,
            "load": [0.4, 1.6],
            "measured": "2030-01-02T03:04Z",
            "machine": {"cpu": "Test CPU", "cores": 2},
        }
    }
}


def test_durations_and_phrases_from_a_file_built_here() -> None:
    assert format_duration(47.4) == "47 s"
    assert format_duration(111.6) == "1 min 52 s"
    assert format_duration(59.6) == "1 min 0 s"
    assert format_duration(613) == "10 min"
    t = timing("quick_reproduction", FAKE)
    assert t is not None and t.cores == 2 and t.peak_mib == 612 and t.load == (0.4, 1.6)
    assert timing_phrase("quick_reproduction", FAKE) == "1 min 52 s wall on 2 cores"
    assert timing("suite", FAKE) is None
    assert timing_phrase("quick_study", FAKE, sized=True) == "wall time not measured"
    block = _script().render_block(FAKE)
    assert "| 1 min 52 s | 612 MiB | 2 cores, Test CPU; load 0.40–1.60 (2030-01-02T03:04Z) |" in (
        block
    )
    assert "Not measured in this file: the quick paper study at 2 units" in block


def test_shipped_file_holds_the_quick_reproduction() -> None:
    t = timing("quick_reproduction")
    assert t is not None, "run python docs/scripts/timings.py --write"
    assert t.wall_s > 0 and t.cores > 0 and t.load and t.cpu


def test_readme_block_is_the_files() -> None:
    s = _script()
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = s.render_block(load_timings())
    assert block in text


def test_help_quotes_the_file() -> None:
    for cmd, phrase in (
        ("reproduce", timing_phrase("quick_reproduction")),
        ("study", timing_phrase("quick_study", sized=True)),
    ):
        res = CliRunner().invoke(app, [cmd, "--help"], env=ENV)
        assert res.exit_code == 0, res.output
        assert phrase in _flat(res.output), (cmd, phrase)


def test_console_line_of_reproduce_quick_quotes_the_file(monkeypatch, tmp_path) -> None:
    import rinscal.experiments.paper.run as run  # where the reproduction calls the stage

    class Stop(Exception):
        pass

    def stop(*args, **kwargs):
        raise Stop

    monkeypatch.setattr(run, "calibration_stage", stop)
    res = CliRunner().invoke(app, ["reproduce", "--quick", "--out", str(tmp_path / "q")])
    assert isinstance(res.exception, Stop)
    t = timing("quick_reproduction")
    assert t is not None
    line = expected_time(True)
    assert f"expect about {format_duration(t.wall_s)}" in line
    assert line in _flat(res.output)


# A stated wall time: "7 min 44 s", "about two minutes", "50 s wall", "passed in".
CLAIM = re.compile(
    r"\b\d+ min \d+ s\b|about (a|one|two|three|\d+) minutes?\b|\d+ s wall|passed in|"
    r"\bin about \d"
)


@pytest.mark.parametrize("doc", ["README.md", "docs/study.md", "docs/calibration.md"])
def test_no_other_wall_time_of_the_commands_in_the_docs(doc: str) -> None:
    text = (ROOT / doc).read_text(encoding="utf-8")
    s = _script()
    i, j = text.find(s.BEGIN), text.find(s.END)
    if i >= 0:
        text = text[:i] + text[j:]
    # the benchmark records state their own commands and conditions
    text = re.sub(r"\n## Benchmarks\n.*?\n## ", "\n## ", text, flags=re.S)
    text = re.sub(r"\n## Measured \(this project's 2-core machine\)\n.*?(\n## |$)", r"\1",
                  text, flags=re.S)  # fmt: skip
    assert CLAIM.findall(text) == [], [m.group(0) for m in CLAIM.finditer(text)]

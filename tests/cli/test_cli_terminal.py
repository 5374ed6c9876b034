"""What a user reads in an 80-column terminal: nothing lost, nothing cut (issue 11)."""

from __future__ import annotations

import json
import re

import click
import pytest
import typer
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.io import write_log, write_meta
from tests.cli.test_cli_honesty import _log

runner = CliRunner()
ENV = {"COLUMNS": "80", "TERM": "dumb"}
COMMANDS = sorted(typer.main.get_command(app).commands)  # type: ignore[attr-defined]


def _squash(text: str) -> str:
    return re.sub(r"\s+", " ", text)


@pytest.mark.parametrize("name", COMMANDS)
def test_help_keeps_every_unit_and_fits_80_columns(name) -> None:
    res = runner.invoke(app, [name, "--help"], env=ENV)
    assert res.exit_code == 0, res.output
    assert max(len(line) for line in res.output.splitlines()) <= 80
    flat = _squash(res.output)
    command = typer.main.get_command(app).commands[name]  # type: ignore[attr-defined]
    for param in command.params:
        helptext = getattr(param, "help", None) or ""
        for bracket in re.findall(r"\[[^\]]*\]", helptext):  # units such as [h], [s], [Hz]
            assert _squash(bracket) in flat, (name, param.name, bracket)
        if isinstance(param, click.Option) and param.is_flag and not param.secondary_opts:
            # a flag takes no value: no metavar after it
            assert not re.search(re.escape(param.opts[0]) + r" <\w+>", res.output), param.opts


def test_evaluate_table_cuts_no_number_at_80_columns(tmp_path) -> None:
    log = tmp_path / "log.csv"
    write_log(_log(), log)
    write_meta({"units": {"gyro": "deg/h", "accel": "ug"}}, log)
    model = tmp_path / "m.json"
    assert (
        runner.invoke(
            app, ["fit", str(log), "--method", "regression", "--out", str(model)]
        ).exit_code
        == 0
    )
    res = runner.invoke(app, ["evaluate", str(log), "-m", str(model)], env=ENV)
    assert res.exit_code == 0, res.output
    assert "…" not in res.output
    assert max(len(line) for line in res.output.splitlines()) <= 80
    doc = json.loads(runner.invoke(app, ["evaluate", str(log), "-m", str(model), "--json"]).output)
    from rinscal.cli.calibrate import _fmt

    for row in doc["rows"]:  # every RMS printed whole
        for key in ("rms_before", "rms_after"):
            assert _fmt(row[key]) in res.output, (key, _fmt(row[key]))
    for unit in ("(deg/h)", "(ug)", "[unit·√s]", "τ(B)", "[s]"):
        assert unit in _squash(res.output)


def test_config_errors_keep_their_section_names(tmp_path) -> None:
    spec = tmp_path / "bad.toml"
    spec.write_text('[study]\nname = "x"\nbogus = 1\n', encoding="utf-8")
    res = runner.invoke(app, ["study", str(spec), "--out", str(tmp_path / "o")], env=ENV)
    assert res.exit_code == 2, res.output
    assert "missing [calibration]" in _squash(res.output)  # the section name is kept

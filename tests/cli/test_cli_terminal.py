"""What a user reads in an 80-column terminal: nothing lost, nothing cut (issue 11)."""

from __future__ import annotations

import json
import re

import pytest
import typer
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log
from tests._shared import linear_log

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
        if param.param_type_name == "option" and param.is_flag and not param.secondary_opts:
            # a flag takes no value: no metavar after it
            assert not re.search(re.escape(param.opts[0]) + r" <\w+>", res.output), param.opts


def test_evaluate_table_cuts_no_number_at_80_columns(tmp_path) -> None:
    log = tmp_path / "log.csv"
    write_log(linear_log(), log)
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
    # the Allan terms in the reports' units and words (issue 36): N in °/√h for a gyro
    # logged in deg/h, µg/√Hz for an accelerometer in ug, the value converted to it
    from rinscal.calibration.allan_units import NOISE_TERMS_WORDS

    for unit in ("(deg/h)", "(ug)", "[°/√h]", "[µg/√Hz]", "τ(B)", "[s]"):
        assert unit in _squash(res.output)
    assert _squash(NOISE_TERMS_WORDS) in _squash(res.output)
    gyro = next(r for r in doc["allan"] if r["channel"] == "gyro_x" and r["n"] is not None)
    assert _fmt(gyro["n"] / 60.0, 3) in res.output  # deg/h·√s ÷ 60 = °/√h


def test_config_errors_keep_their_section_names(tmp_path) -> None:
    spec = tmp_path / "bad.toml"
    spec.write_text('[study]\nname = "x"\nbogus = 1\n', encoding="utf-8")
    res = runner.invoke(app, ["study", str(spec), "--out", str(tmp_path / "o")], env=ENV)
    assert res.exit_code == 2, res.output
    assert "missing [calibration]" in _squash(res.output)  # the section name is kept


# ------------------------------------------------------------------ issue 21, items 8 and 9

WORKFLOW = [
    "simulate", "calibrate-imu", "fit", "calibrate-field", "select", "evaluate", "compensate",
    "export", "plot",
    "navigate", "reproduce", "study", "fleet",
]  # fmt: skip


def test_top_level_help_lists_whole_summaries_in_workflow_order() -> None:
    res = runner.invoke(app, ["--help"], env=ENV)
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    start = lines.index("Commands:") + 1
    rows = [line.split(None, 1) for line in lines[start:] if line.strip()]
    assert [r[0] for r in rows] == WORKFLOW
    for name, summary in rows:
        # one line each, ending in a full stop, never cut ("...") or stopped at "Eq."
        assert summary.endswith(".") and not summary.endswith("..."), (name, summary)
        assert not summary.endswith("(Eq."), (name, summary)
    assert max(len(line) for line in lines) <= 80
    res = runner.invoke(app, ["fleet", "--help"], env=ENV)
    fit_row = next(line for line in res.output.splitlines() if line.strip().startswith("fit "))
    assert fit_row.rstrip().endswith(".") and not fit_row.rstrip().endswith("...")


def _usage_pieces(args: list[str]) -> str:
    res = runner.invoke(app, [*args, "--help"], env=ENV)
    assert res.exit_code == 0, res.output
    return res.output.splitlines()[0]


@pytest.mark.parametrize(
    ("args", "usage"),
    [
        (["fit"], "Usage: rinscal fit [OPTIONS] LOG"),
        (["compensate"], "Usage: rinscal compensate [OPTIONS] LOG"),
        (["export"], "Usage: rinscal export [OPTIONS] MODEL"),
        (["simulate"], "Usage: rinscal simulate [OPTIONS] PROTOCOL"),
        (["study"], "Usage: rinscal study [OPTIONS] SPEC"),
        (["fleet", "fit"], "Usage: rinscal fleet fit [OPTIONS] LOGS..."),
    ],
)
def test_usage_lines_name_arguments_in_capitals(args, usage) -> None:
    assert _usage_pieces(args) == usage


def test_one_name_per_idea_across_commands() -> None:
    group = typer.main.get_command(app)

    def opts(*path: str) -> dict:
        cmd = group
        for p in path:
            cmd = cmd.commands[p]  # type: ignore[attr-defined]
        return {o: p for p in cmd.params if p.param_type_name == "option" for o in p.opts}

    # cores: one option, one meaning, one default (every core) wherever work fans out, threads
    # or Dask worker processes (--workers: the old name on the latter, hidden)
    for path in (("reproduce",), ("study",), ("fleet", "fit"), ("navigate",), ("calibrate-field",)):
        o = opts(*path)
        assert "--jobs" in o and "-j" in o and o["--jobs"].default is None, path
        assert not o["--jobs"].hidden and "every core" in o["--jobs"].help, path
        assert all(p.hidden for k, p in o.items() if k in ("--workers", "-w")), path
    # --imu is a simulated IMU preset everywhere; the export's IMU is --instance, as the readers
    for path in (("simulate",), ("navigate",), ("reproduce",), ("study",)):
        assert "preset" in opts(*path)["--imu"].help, path
    assert opts("export")["--imu"].hidden and "--instance" in opts("export")
    assert "0-based" in opts("export")["--instance"].help
    # every compensating command offers the same policies
    from rinscal.calibration.modelfile import POLICIES

    for path in (("compensate",), ("evaluate",), ("navigate",)):
        helptext = _squash(opts(*path)["--policy"].help)
        assert all(p in helptext for p in POLICIES), (path, helptext)


def test_navigate_hours_help_names_each_scenario_default() -> None:
    from rinscal.sim.scenario import DEFAULT_HOURS

    res = runner.invoke(app, ["navigate", "--help"], env=ENV)
    flat = _squash(res.output)
    for name, hours in DEFAULT_HOURS.items():
        assert f"{name} {hours:g} h" in flat, (name, hours)


def test_warnings_a_command_raises_are_shown_once_and_it_returns(capfd) -> None:
    """The error boundary shows a command's warnings after it ends (it once replayed them
    into the list it was reading, for ever)."""
    import warnings

    from rinscal.cli._app import guard_os_errors
    from rinscal.errors import LogNoteWarning

    def command() -> int:
        warnings.warn("something odd", RuntimeWarning, stacklevel=1)
        warnings.warn("rows dropped", LogNoteWarning, stacklevel=1)
        warnings.warn("rows dropped", LogNoteWarning, stacklevel=1)
        return 7

    wrapped = guard_os_errors(command)
    assert wrapped is not None
    with pytest.warns(RuntimeWarning, match="something odd") as shown:
        assert wrapped() == 7
    assert len(shown) == 1  # shown once, where Python (here pytest) shows warnings
    assert capfd.readouterr().err.count("note: rows dropped") == 1

"""What the CLI's commands accept and print, tied to the module that says it: the figure
suffixes of ``plot`` (``rinscal.cli.simulate``) and of ``evaluate --allan-plot``
(``rinscal.cli.compensate``) are those their refusals name, and ``calibrate-imu`` prints
each estimate to its sd's two significant digits (``rinscal.cli.imucal``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.cli.compensate import ALLAN_SUFFIXES
from rinscal.cli.imucal import _pm
from rinscal.cli.simulate import _FIGURE_SUFFIXES
from tests._shared import linear_log

runner = CliRunner()


def _refusal(args: list[str]) -> str:
    res = runner.invoke(app, args)
    assert res.exit_code == 2, res.output
    return " ".join(res.output.split())


@pytest.fixture
def log(tmp_path: Path) -> Path:
    path = tmp_path / "log.csv"
    linear_log(n=20, runs=1).to_csv(path, index=False)
    return path


def test_plot_names_exactly_the_suffixes_it_writes(log: Path, tmp_path: Path) -> None:
    msg = _refusal(["plot", str(log), "--out", str(tmp_path / "fig.gif")])
    assert "unknown figure suffix '.gif'" in msg
    assert msg.endswith("use " + ", ".join(_FIGURE_SUFFIXES[:-1]) + f" or {_FIGURE_SUFFIXES[-1]}")
    assert not (tmp_path / "fig.gif").exists()


def test_evaluate_names_exactly_the_allan_plot_suffixes(log: Path, tmp_path: Path) -> None:
    model = tmp_path / "m.json"
    model.write_text("{}")
    bad = tmp_path / "a.jpg"
    msg = _refusal(["evaluate", str(log), "--model", str(model), "--allan-plot", str(bad)])
    assert f"--allan-plot {bad}: unknown figure suffix '.jpg'" in msg
    assert msg.endswith("use " + ", ".join(ALLAN_SUFFIXES[:-1]) + f" or {ALLAN_SUFFIXES[-1]}")


@pytest.mark.parametrize(
    ("value", "sd", "shown"),
    [
        (1.23456, 0.012, "1.235 ± 0.012"),
        (-250.04, 13.0, "-250 ± 13"),
        (0.5, 0.0, "0.5"),  # no sd: six significant digits
        (2.0, float("nan"), "2"),
    ],
)
def test_an_estimate_is_printed_to_its_sds_two_digits(value: float, sd: float, shown: str) -> None:
    assert _pm(value, sd) == shown

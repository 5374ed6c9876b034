"""A turntable recording navigated without its encoder column (issue 34, item 3): the z gyro
shows the table turning while the base stands still, and ``navigate --log`` says that the
heading error is meaningless, naming the missing column and how to map it."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.io.metadata import meta_path


def _invoke(args: list) -> str:
    res = CliRunner().invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return " ".join(res.output.split())


def _record(d: Path, scenario: str, rotation: str) -> Path:
    rec = d / f"{scenario}.parquet"
    _invoke(["navigate", "-s", scenario, "--hours", "0.3", "--rate", "10", "--align-s", "300",
             "--rotation", rotation, "--record", rec, "--out", d / f"{scenario}-sim"])  # fmt: skip
    return rec


def _without_encoder(rec: Path) -> Path:
    dst = rec.with_name(rec.stem + "-noenc.parquet")
    pd.read_parquet(rec).drop(columns=["table_deg"]).to_parquet(dst)
    shutil.copy(meta_path(rec), meta_path(dst))
    return dst


@pytest.fixture(scope="module")
def table(tmp_path_factory) -> Path:
    """A quasi-static four-position recording (the table turns ±135° at 10 °/s)."""
    return _record(tmp_path_factory.mktemp("table"), "quasi-static", "four-position")


def test_a_turntable_without_its_encoder_is_named(table, tmp_path) -> None:
    text = _invoke(["navigate", "--log", _without_encoder(table), "--out", tmp_path / "n"])
    assert "warning: the z gyro (Earth rate removed) turns the IMU" in text
    assert "at a median 10.0 °/s" in text  # the table's rate, as the scenario turns it
    assert "no encoder angle (table_deg)" in text and "heading error" in text
    assert '[columns] ENCODER = "table_deg"' in text and "(--map; table_unit" in text
    rot = json.loads((tmp_path / "n" / "summary.json").read_text())["recording"]["rotation"]
    assert rot["turning_without_encoder"]["turned_deg"] > 135
    # with the encoder, as recorded: no such warning, the table is known
    text = _invoke(["navigate", "--log", table, "--out", tmp_path / "e"])
    assert "turntable (encoder)" in text and "no encoder angle" not in text


def test_a_table_turning_on_and_on_without_its_encoder_is_named(tmp_path) -> None:
    """Continuous rotation: no still second to compare with, one steady rate of 6 °/s."""
    rec = _record(tmp_path, "quasi-static", "continuous")
    text = _invoke(["navigate", "--log", _without_encoder(rec), "--out", tmp_path / "n"])
    assert "no encoder angle (table_deg)" in text and "at a median 6.0 °/s" in text


def test_a_vehicle_that_turns_while_it_drives_is_not_a_turntable(tmp_path) -> None:
    """The z gyro turns, but the horizontal specific force (v ω) says the base moved."""
    rec = _record(tmp_path, "vehicle", "none")
    text = _invoke(["navigate", "--log", _without_encoder(rec), "--out", tmp_path / "n"])
    assert "no encoder angle (table_deg)" not in text
    # the recording with its (still) encoder column: the encoder check no longer crashes
    text = _invoke(["navigate", "--log", rec, "--out", tmp_path / "e"])
    assert "turntable (encoder)" in text

"""A recording in SI rates (rad/s, m/s²) with no units declared (issue 34, item 5): read in
the default deg/h and µg, the message names the mix-up the magnitudes point to ("m/s² read as
µg") and how to declare the units; declared in a mapping, the same file navigates."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal import units
from rinscal.cli import app
from rinscal.io.metadata import meta_path


def _invoke(args: list) -> tuple[int, str]:
    res = CliRunner().invoke(app, [str(a) for a in args])
    return res.exit_code, " ".join(res.output.split())


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("rec")
    rec = d / "run.parquet"
    code, text = _invoke(["navigate", "-s", "quasi-static", "--hours", "0.3", "--rate", "10",
                          "--align-s", "300", "--record", rec, "--out", d / "sim"])  # fmt: skip
    assert code == 0, text
    assert json.loads(meta_path(rec).read_text())["units"] == {"gyro": "deg/h", "accel": "ug"}
    return rec


def _si(rec: Path, dst: Path, gyro: bool = True, accel: bool = True) -> Path:
    """The recording in rad/s and m/s², its metadata without units."""
    df = pd.read_parquet(rec)
    for c in ("gyro_x", "gyro_y", "gyro_z") if gyro else ():
        df[c] *= units.DPH_TO_RPS
    for c in ("accel_x", "accel_y", "accel_z") if accel else ():
        df[c] *= units.UG_TO_MPS2
    df.to_parquet(dst)
    meta = json.loads(meta_path(rec).read_text())
    meta.pop("units")
    meta_path(dst).write_text(json.dumps(meta))
    return dst


def test_an_si_log_read_in_the_default_units_names_the_mixup(recording, tmp_path) -> None:
    log = _si(recording, tmp_path / "si.parquet")
    code, text = _invoke(["navigate", "--log", log, "--out", tmp_path / "n"])
    assert code == 2 and "Traceback" not in text
    assert "wrong accelerometer units" in text and "the columns hold 9.7" in text
    assert "m/s² read as µg?" in text
    assert 'accel = "m/s^2" under [units] in the mapping' in text
    assert '"units": {"accel": "m/s^2"}' in text
    assert "the gyros too" in text and "rad/s read as deg/h?" in text  # both, at once
    assert "from the default units" in text
    assert not (tmp_path / "n").exists()
    # declared as the message says: it navigates
    mapping = tmp_path / "si.toml"
    mapping.write_text('[units]\ngyro = "rad/s"\naccel = "m/s^2"\n')
    code, text = _invoke(["navigate", "--log", log, "--map", mapping, "--out", tmp_path / "n"])
    assert code == 0, text


def test_gyros_in_rad_s_alone_are_named(recording, tmp_path) -> None:
    log = _si(recording, tmp_path / "si_gyro.parquet", accel=False)
    meta = json.loads(meta_path(log).read_text())
    meta["units"] = {"accel": "ug"}  # the accelerometers declared, the gyros left to default
    meta_path(log).write_text(json.dumps(meta))
    code, text = _invoke(["navigate", "--log", log, "--out", tmp_path / "n"])
    assert code == 2, text
    assert "wrong gyro units" in text and "rad/s read as deg/h?" in text
    assert 'gyro = "rad/s" under [units]' in text

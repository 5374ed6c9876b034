"""Issue 34.3: an IMU calibration is not accepted silently. ``imu.json`` is checksummed (an
edited law is refused, naming the file), records the raw units and the unit it was made from
(``fit --imu-cal`` refuses a log in other units, warns of a log without units or of another
unit, and so do the compensators of the model), and ``fit --imu-cal`` says when the log's
temperatures leave the calibration's range."""

from __future__ import annotations

import json
import shutil

import pytest
from typer.testing import CliRunner

import rinscal
from rinscal.calibration.modelfile import payload_sha256
from rinscal.cli.commands import app
from rinscal.io.metadata import read_meta, write_meta
from rinscal.io.tables import read_log, write_log
from rinscal.schema import CHANNELS
from tests.calibration._imu_synth import Design, make_log, paper_like_truth

runner = CliRunner()


def flat(text: str) -> str:
    """The terminal's output on one line (rich wraps long lines)."""
    return " ".join(text.split())


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """A small multi-position log at 10, 25 and 40 °C in pulses (unit "synthetic") and the
    imu.json calibrate-imu makes of it."""
    d = tmp_path_factory.mktemp("imucal")
    log, meta, _ = make_log(
        paper_like_truth(), (10.0, 25.0, 40.0), design=Design(dwell_s=12.0, turns=1), seed=3
    )
    write_log(log, d / "cal.parquet")
    write_meta(meta, d / "cal.parquet")
    r = runner.invoke(
        app,
        ["calibrate-imu", str(d / "cal.parquet"), "--out", str(d / "imu.json"), "--settle", "3"],
    )
    assert r.exit_code == 0, r.output
    return d


@pytest.fixture
def here(calibrated, tmp_path, monkeypatch):
    """A fresh folder holding cal.parquet (+ meta) and imu.json, as the working folder (so
    that messages name short relative paths)."""
    for name in ("cal.parquet", "cal.parquet.meta.json", "imu.json"):
        shutil.copy(calibrated / name, tmp_path / name)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _fit(log: str, imu: str, out: str = "model.json"):
    return runner.invoke(
        app, ["fit", log, "--imu-cal", imu, "--method", "poly-t", "--orders", "1", "-o", out]
    )


def _variant(name: str, *, meta_edit=None, shift_c: float = 0.0) -> str:
    """A copy of cal.parquet as NAME.parquet, its metadata edited, its temperatures shifted."""
    log = read_log("cal.parquet")
    if shift_c:
        for c in [c for c in log.columns if c.startswith("temp_")]:
            log[c] = log[c] + shift_c
    meta = read_meta("cal.parquet")
    if meta_edit is not None:
        meta_edit(meta)
    write_log(log, f"{name}.parquet")
    write_meta(meta, f"{name}.parquet")
    return f"{name}.parquet"


def test_imu_json_is_checksummed_and_an_edited_law_is_refused(here):
    doc = json.loads((here / "imu.json").read_text())
    assert doc["schema"] == "rinscal.imu-calibration-file/2"
    assert doc["sha256"] == payload_sha256({k: v for k, v in doc.items() if k != "sha256"})
    assert _fit("cal.parquet", "imu.json", "first.json").exit_code == 0
    # a scale-factor law edited by hand: refused, naming the file and saying it was edited
    doc["imu_calibration"]["t_coefs"]["gyro_sf_x"][0] += 100.0
    (here / "edited.json").write_text(json.dumps(doc, indent=2))
    r = _fit("cal.parquet", "edited.json")
    assert r.exit_code == 2
    out = flat(r.output)
    assert (
        "edited.json: checksum mismatch" in out
        and "edited or corrupted after it was written" in out
    )
    assert "Traceback" not in r.output and not (here / "model.json").exists()


def test_a_file_written_before_the_checksum_loads_with_a_warning(here):
    doc = json.loads((here / "imu.json").read_text())
    old = {"schema": "rinscal.imu-calibration-file/1", "imu_calibration": doc["imu_calibration"]}
    (here / "old.json").write_text(json.dumps(old))
    r = _fit("cal.parquet", "old.json")
    assert r.exit_code == 0, r.output
    out = flat(r.output)
    assert "warning: old.json: written before imu.json carried a checksum" in out


def test_imu_json_records_the_raw_units_and_the_unit(here):
    doc = json.loads((here / "imu.json").read_text())
    assert doc["input"]["units"] == {c: "pulse" for c in CHANNELS}
    assert doc["input"]["unit_to_si"]["gyro_x"] == pytest.approx(
        read_meta("cal.parquet")["unit_to_si"]["gyro_x"]
    )
    assert doc["unit"] == {"imu": "synthetic"}


def _physical(meta):
    meta["units"] = {"gyro": "deg/h", "accel": "ug"}
    meta.pop("unit_to_si")


def test_fit_refuses_a_log_in_other_units_than_the_calibration(here):
    log = _variant("physical", meta_edit=_physical)
    r = _fit(log, "imu.json")
    assert r.exit_code == 2
    out = flat(r.output)
    assert "physical.parquet: its units differ from the raw units of the IMU calibration" in out
    assert "gyro_x, gyro_y, gyro_z: log in 'deg/h'" in out and "made from 'pulse'" in out
    assert "accel_x, accel_y, accel_z: log in 'ug'" in out and "imu.json" in out
    assert not (here / "model.json").exists()


def test_fit_and_compensate_warn_of_a_log_without_units_or_of_another_unit(here):
    def other_unit(meta):
        meta["imu"] = "another unit"

    def no_units(meta):
        meta.pop("units")

    r = _fit(_variant("other", meta_edit=other_unit), "imu.json")
    assert r.exit_code == 0, r.output
    out = flat(r.output)
    assert "the IMU calibration imu.json was made on another unit than the log's" in out
    assert "imu 'synthetic' (the calibration) vs 'another unit' (the log)" in out
    r = _fit(_variant("bare", meta_edit=no_units), "imu.json", "bare_model.json")
    assert r.exit_code == 0, r.output
    out = flat(r.output)
    assert "bare.parquet: the log declares no unit for gyro_x" in out and "(pulse)" in out
    # the model holds the unit: compensate says the same of a log of another unit
    r = runner.invoke(app, ["compensate", "other.parquet", "-m", "model.json", "-o", "c.csv"])
    assert r.exit_code == 0, r.output
    assert "was made on another unit than the log's" in flat(r.output)
    # and refuses a log in other units than the calibration's raw units
    r = runner.invoke(
        app,
        ["compensate", _variant("phys", meta_edit=_physical), "-m", "model.json", "-o", "p.csv"],
    )
    assert r.exit_code != 0 and "'pulse'" in r.output and "'deg/h'" in r.output


def test_fit_warns_of_temperatures_outside_the_calibrations_range(here):
    lo, hi = json.loads((here / "imu.json").read_text())["imu_calibration"]["t_range_c"]
    assert 10.0 < lo < 11.0 and 40.0 < hi < 41.0
    # every temperature 5 °C up: the 40 °C run (a third of the rows) leaves the range
    log = _variant("warm", shift_c=5.0)
    r = _fit(log, "imu.json")
    assert r.exit_code == 0, r.output
    out = flat(r.output)
    assert "warm.parquet: 33.3 % of the rows" in out
    assert "0.1 °C outside the temperature range of the IMU calibration imu.json" in out
    assert f"imu.json, {lo:.2f} .." in out
    assert f".. {hi:.2f} °C" in out
    assert "temp_gyro_x (gyro_x) 15." in out and "temp_accel_z (accel_z)" in out
    assert "held at their edge values" in out
    # the library says it in FitResult.warnings
    res = rinscal.fit(log, "poly-t", orders=(1,), imu_calibration="imu.json")
    assert any("33.3 % of the rows" in w for w in res.warnings)
    # the calibration's own log (thermometer noise about the set points' means): no warning
    res = rinscal.fit("cal.parquet", "poly-t", orders=(1,), imu_calibration="imu.json")
    assert not any("temperature range" in w for w in res.warnings), res.warnings

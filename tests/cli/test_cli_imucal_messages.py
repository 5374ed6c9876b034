"""Issue 34.5: calibrate-imu's and imu.json's messages point the right way: a bad turntable
value is named with its data row from the file's start and as a plain number, angles in
radians are said to be radians, a dwell shorter than the settle time is said to be that,
and every error of an imu.json names the file."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from rinscal.calibration.modelfile import payload_sha256
from rinscal.cli.commands import app
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log
from tests.calibration._imu_synth import Design, make_log, paper_like_truth

runner = CliRunner()
TABLE = ["table_outer_deg", "table_inner_deg", "table_outer_rate_dps", "table_inner_rate_dps"]


def flat(text: str) -> str:
    """The terminal's output on one line (rich wraps long lines)."""
    return " ".join(text.split())


def _log(design: Design | None = None):
    return make_log(
        paper_like_truth(),
        (10.0, 25.0),
        design=design or Design(dwell_s=12.0, turns=1),
        seed=3,
    )


def _calibrate(tmp_path, monkeypatch, log, meta, name="cal.csv", *args):
    monkeypatch.chdir(tmp_path)
    write_log(log, name, validate=False)
    write_meta(meta, name)
    return runner.invoke(
        app, ["calibrate-imu", name, "--out", "imu.json", "--max-degree", "1", *args]
    )


def test_a_nan_in_a_turntable_column_is_named_with_its_data_row(tmp_path, monkeypatch):
    log, meta, _ = _log()
    second = np.flatnonzero(log["run"].to_numpy() == "cal_+25C")
    row = int(second[5])  # the sixth row of the second run
    log.loc[row, "table_inner_deg"] = np.nan
    r = _calibrate(tmp_path, monkeypatch, log, meta, "cal.csv", "--settle", "3")
    assert r.exit_code == 2
    out = flat(r.output)
    # data row counted from the file's start (line row + 2 of the CSV), a plain value
    assert f"cal.csv: run cal_+25C, column 'table_inner_deg', data row {row + 1}:" in out
    assert "missing value (NaN or empty cell)" in out
    assert "np.float64" not in out and "row 6 " not in out
    lines = (tmp_path / "cal.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert lines[row + 1].split(",")[header.index("table_inner_deg")] in ("", "nan", "NaN")


def test_angles_in_radians_are_said_to_be_radians(tmp_path, monkeypatch):
    log, meta, _ = _log()
    for c in TABLE:
        log[c] = np.radians(log[c])
    r = _calibrate(tmp_path, monkeypatch, log, meta, "cal.parquet", "--settle", "3")
    assert r.exit_code == 2
    out = flat(r.output)
    assert "table_outer_deg and table_inner_deg look like radians" in out
    assert "must be in degrees" in out and "need a rate test" not in out
    assert "1.571" in out  # a position at π/2, as it is in the file


def test_degrees_with_small_whole_angles_are_not_called_radians(tmp_path, monkeypatch):
    log, meta, _ = _log()
    r = _calibrate(tmp_path, monkeypatch, log, meta, "cal.parquet", "--settle", "3")
    assert r.exit_code == 0, r.output
    assert "radians" not in r.output


def test_a_dwell_shorter_than_the_settle_time_is_said_to_be_that(tmp_path, monkeypatch):
    # 3 s at each position, 10 Hz; the rate tests long enough for a settle time of 5 s
    log, meta, _ = _log(Design(dwell_s=3.0, settle_s=5.0, turns=1))
    r = _calibrate(tmp_path, monkeypatch, log, meta, "cal.parquet", "--settle", "5")
    assert r.exit_code == 2
    out = flat(r.output)
    assert "run cal_+10C: no static position is left" in out
    assert "the settle time cut from its start (5 s, --settle)" in out
    assert "the longest stop lasts 3 s" in out
    assert "use a settle time of at most 2 s (--settle)" in out
    assert "dwell at least 6 s at each position" in out and "--dwell" in out
    assert "the design has none" not in out
    # the settle time it names leaves the positions in (10 samples each)
    r = runner.invoke(
        app,
        ["calibrate-imu", "cal.parquet", "--out", "imu.json", "--max-degree", "1",
         "--settle", "2", "--linear"],
    )  # fmt: skip
    assert "no static position is left" not in flat(r.output)


@pytest.fixture
def fitted(tmp_path, monkeypatch):
    """A log and its imu.json in the working folder."""
    log, meta, _ = _log()
    r = _calibrate(tmp_path, monkeypatch, log, meta, "cal.parquet", "--settle", "3")
    assert r.exit_code == 0, r.output
    return json.loads((tmp_path / "imu.json").read_text())


def _edited(doc, edit):
    d = json.loads(json.dumps(doc))
    edit(d)
    d.pop("sha256")
    d["sha256"] = payload_sha256(d)  # as written by rinscal: only the content is wrong
    return d


def _set(path, value):
    def edit(d):
        *head, last = path
        for k in head:
            d = d[k]
        d[last] = value

    return edit


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (_set(("imu_calibration", "t_coefs"), [1.0, 2.0]), "t_coefs must be an object"),
        (_set(("imu_calibration", "t_range_c"), [40.0, 10.0]), "low <= high"),
        (_set(("imu_calibration", "t_range_c"), "10..40"), "t_range_c must be [low, high]"),
        (_set(("imu_calibration", "t_coefs", "gyro_sf_w"), [1.0]), "unknown IMU parameter"),
        (_set(("imu_calibration", "t_coefs", "gyro_sf_x"), ["a"]), "list of numbers"),
        (_set(("imu_calibration", "t0_c"), None), "t0_c must be a number"),
        (_set(("imu_calibration", "units", "gyro_sf_x"), "ppb"), "rinscal's unit is 'ppm'"),
        (lambda d: d["imu_calibration"].pop("t_coefs"), "no t_coefs"),
        (lambda d: d.pop("imu_calibration"), "without its 'imu_calibration' object"),
        (_set(("input",), "pulse"), "input must be an object"),
    ],
)
def test_every_imu_json_error_names_the_file(fitted, tmp_path, edit, says):
    (tmp_path / "bad.json").write_text(json.dumps(_edited(fitted, edit)))
    r = runner.invoke(app, ["fit", "cal.parquet", "--imu-cal", "bad.json", "-o", "m.json"])
    assert r.exit_code == 2, r.output
    out = flat(r.output)
    assert out.startswith("error: bad.json") and says in out, out
    assert "Traceback" not in r.output


def test_a_non_json_or_non_finite_imu_json_names_the_file(fitted, tmp_path):
    text = json.dumps(fitted).replace('"t0_c": ', '"t0_c": NaN, "x": ', 1)
    (tmp_path / "nan.json").write_text(text)
    (tmp_path / "cut.json").write_text(json.dumps(fitted)[:100])
    for name, says in (("nan.json", "non-finite number NaN"), ("cut.json", "not valid JSON")):
        r = runner.invoke(app, ["fit", "cal.parquet", "--imu-cal", name, "-o", "m.json"])
        assert r.exit_code == 2
        out = flat(r.output)
        assert out.startswith(f"error: {name}") and says in out, out

"""One mapping for both kinds of log, one read-options object, errors that name arguments
(issue 37, item 5).

Old mapping files keep loading (``run`` read by the kind of log); a key of the other kind is
refused naming file and key; ``--map`` everywhere, ``--mapping`` an alias with one note line;
a library error names the argument (``site=``), the same error through the CLI the flag.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.errors import ConfigError
from rinscal.io.foreign import ReadOptions, foreign_mapping, foreign_meta, read_foreign_source
from rinscal.io.mapping import ColumnMapping, mapping_from_options, read_mapping
from rinscal.io.navmapping import NavMapping, read_nav_mapping
from rinscal.io.navopen import open_nav_log
from rinscal.io.tables import read_log
from rinscal.nav.recording import navigate_log, parse_site
from rinscal.units import DEG_TO_RAD
from tests.io.test_navlog import RATE, motion, runs_frame, whole

# the two old forms, as the docs of each reader gave them
OLD_CALIBRATION = """
separator = "comma"
time = "t_ms"
time_unit = "ms"
temperature = "T"
run = "cycle"

[columns]
wx = "gyro_x"

[units]
gyro = "deg/s"
"""
OLD_NAVIGATION = """
run = "b"

[units]
gyro = "deg/h"
"""


def _invoke(args: list) -> tuple[int, str, str]:
    res = CliRunner().invoke(app, [str(a) for a in args])
    return res.exit_code, " ".join(res.output.split()), res.stderr


def _calibration_log(path: Path) -> Path:
    """A foreign calibration log: no run column, a ms clock, one temperature, gyro_x in deg/s."""
    n = 5
    df = pd.DataFrame({"t_ms": np.arange(n) * 100, "T": 20.0 + np.arange(n), "wx": 0.5})
    for c in ("gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"):
        df[c] = 1.0
    df.to_csv(path, index=False)
    return path


def test_an_old_calibration_mapping_reads_as_before(tmp_path: Path) -> None:
    (tmp_path / "old.toml").write_text(OLD_CALIBRATION)
    (tmp_path / "new.toml").write_text(OLD_CALIBRATION.replace("run =", "run_name ="))
    old, new = read_mapping(tmp_path / "old.toml"), read_mapping(tmp_path / "new.toml")
    assert old == new and old.run_name == "cycle" and old.select_run is None
    log = _calibration_log(tmp_path / "cal.csv")
    src, meta = read_foreign_source(log, ReadOptions(map_file=tmp_path / "old.toml"))
    df = src.log
    assert set(df["run"]) == {"cycle"}  # the name given to a log without a run column
    np.testing.assert_array_equal(df["time_s"], np.arange(5) * 100 / 1000)  # ms, exactly
    np.testing.assert_array_equal(df["temp_in"], 20.0 + np.arange(5))
    # units: the unit the values are in; a calibration log keeps them (no conversion)
    assert meta["units"]["gyro_x"] == "deg/s" and (df["gyro_x"] == 0.5).all()


def test_an_old_navigation_mapping_reads_as_before(tmp_path: Path) -> None:
    (tmp_path / "old.toml").write_text(OLD_NAVIGATION)
    old = read_nav_mapping(tmp_path / "old.toml")  # the old name, kept for one release
    assert NavMapping is ColumnMapping
    assert old == read_mapping(tmp_path / "old.toml", "navigation")
    assert old.select_run == "b" and old.run_name is None
    m = motion(60)
    runs_frame(m, ["a"] * 20 + ["b"] * 25 + ["c"] * 15).to_csv(tmp_path / "r.csv", index=False)
    s = whole(open_nav_log(tmp_path / "r.csv", old))
    assert s.first_row == 21 and s.n == 25  # run b: data rows 21-45
    np.testing.assert_allclose(s.dtheta, m["dtheta"][20:45], rtol=1e-12)
    # units: the unit the values are in; a recording's rates are converted from it
    df = runs_frame(m, ["b"] * 60)
    df[["gyro_x", "gyro_y", "gyro_z"]] /= 3600.0  # deg/h -> deg/s
    df.to_csv(tmp_path / "dps.csv", index=False)
    dps = whole(open_nav_log(tmp_path / "dps.csv", ColumnMapping(units={"gyro": "deg/s"})))
    np.testing.assert_allclose(dps.dtheta[1:], m["dtheta"][1:], rtol=1e-12)
    assert dps.dtheta[5, 0] == pytest.approx(df["gyro_x"][5] * DEG_TO_RAD / RATE, rel=1e-12)


def test_one_key_one_meaning_and_bad_files_named(tmp_path: Path) -> None:
    nav = tmp_path / "nav.toml"
    nav.write_text('axes = ["y", "x", "-z"]\n[weights]\ngyro = "1 arcsec"\naccel = "1 ug*s"\n')
    with pytest.raises(ConfigError, match=r"nav\.toml: weights, axes: apply to navigation"):
        read_mapping(nav)  # a calibration log has no counts and no axes to turn
    assert read_mapping(nav, "navigation").weights == {"gyro": "1 arcsec", "accel": "1 ug*s"}
    cal = tmp_path / "cal.toml"
    cal.write_text('relative_time = true\ndrop = ["x"]\n')
    with pytest.raises(ConfigError, match=r"cal\.toml: relative_time, drop: apply to calibration"):
        read_mapping(cal, "navigation")
    both = tmp_path / "both.toml"
    both.write_text('run = "a"\nselect_run = "b"\n')
    with pytest.raises(ConfigError, match=r"both\.toml: run and select_run both given"):
        read_mapping(both, "navigation")
    enc = tmp_path / "enc.toml"
    enc.write_text('[columns]\nenc = "table_deg"\n')
    with pytest.raises(ConfigError, match=r"enc\.toml: columns: 'enc' -> 'table_deg'"):
        read_mapping(enc)  # the encoder is a recording's column
    # a mapping built in code is checked where it is read
    with pytest.raises(ConfigError, match="select_run: applies to navigation recordings only"):
        read_log(_calibration_log(tmp_path / "c.csv"), ColumnMapping(select_run="a"))


def test_read_options_one_object_as_the_mapping_functions(tmp_path: Path) -> None:
    log = _calibration_log(tmp_path / "cal.csv")
    (tmp_path / "old.toml").write_text(OLD_CALIBRATION)
    opts = ReadOptions(map_file=tmp_path / "old.toml", col=["T=temp_gyro_x"], run_name="r1")
    got = foreign_mapping(log, opts)
    want = mapping_from_options(
        read_mapping(tmp_path / "old.toml"), columns=["T=temp_gyro_x"], run_name="r1"
    )
    assert got == want and got.run_name == "r1"
    assert foreign_meta(log, got)["units"]["gyro_y"] == "deg/s"
    assert foreign_mapping(log, ReadOptions()) is None  # a canonical log


def test_library_errors_name_arguments_the_cli_flags(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"^site='45,x' is not LAT,LON,HEIGHT"):
        parse_site("45,x")
    log = _calibration_log(tmp_path / "cal.csv")
    with pytest.raises(ConfigError, match=r"instance='1' applies to PX4 \.ulg"):
        foreign_mapping(log, ReadOptions(instance="1"))
    with pytest.raises(ConfigError, match=r"^policy='bogus' is not one of clamp"):
        navigate_log(log, policy="bogus")
    out = tmp_path / "m.json"
    code, text, _ = _invoke(["fit", log, "--instance", "1", "--out", out])
    assert code == 2 and "--instance '1' applies to PX4 .ulg" in text and "instance=" not in text
    rec = tmp_path / "rec.csv"
    runs_frame(motion(20), ["a"] * 20).to_csv(rec, index=False)
    code, text, _ = _invoke(["navigate", "--log", rec, "--site", "45,x", "--out", tmp_path / "n"])
    assert code == 2 and "--site '45,x' is not LAT,LON,HEIGHT" in text and "site=" not in text


def test_map_everywhere_and_mapping_an_alias_with_a_note(tmp_path: Path) -> None:
    rec = tmp_path / "rec.csv"
    runs_frame(motion(20), ["a"] * 20).to_csv(rec, index=False)
    bad = tmp_path / "bad.toml"
    bad.write_text("relative_time = true\n")
    for flag in ("--map", "--mapping"):
        code, text, err = _invoke(["navigate", "--log", rec, flag, bad, "--out", tmp_path / "n"])
        # the file was read (its key refused, named), whichever name gave it
        assert code == 2 and "bad.toml: relative_time: applies to calibration logs" in text
        notes = [line for line in err.splitlines() if "deprecated" in line]
        assert notes == ([] if flag == "--map" else ["note: --mapping is deprecated: use --map "
                                                     "(the same file)"])  # fmt: skip
    log = _calibration_log(tmp_path / "cal.csv")
    nav = tmp_path / "nav.toml"
    nav.write_text('axes = ["y", "x", "-z"]\n')
    for flag in ("--map", "--mapping"):
        code, text, err = _invoke(["plot", log, flag, nav, "--out", tmp_path / "p.png"])
        assert code == 2 and "nav.toml: axes: applies to navigation recordings only" in text
        assert ("--mapping is deprecated" in err) == (flag == "--mapping")

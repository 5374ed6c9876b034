"""Reading and writing calibration logs, column mappings and sidecar metadata (rinscal.io)."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.calibration.modelfile import ThermalModelFile
from rinscal.cli import app
from rinscal.errors import ConfigError, LogError
from rinscal.io.mapping import ColumnMapping, mapping_from_options, read_mapping
from rinscal.io.metadata import meta_path, read_meta, write_meta
from rinscal.io.streaming import InterleavedRunsError, iter_log_source
from rinscal.io.tables import read_log, read_log_source, write_log
from rinscal.schema import CHANNELS
from tests._shared import real_log_path

REPO = Path(__file__).resolve().parents[2]
EXAMPLE_MAPPING = REPO / "examples" / "tofupilot_mapping.toml"


def make_log(n: int = 6, runs: tuple[str, ...] = ("soak_+07C", "soak_+14C")) -> pd.DataFrame:
    rng = np.random.default_rng(7)
    frames = []
    for run in runs:
        t = np.cumsum(rng.uniform(0.005, 0.02, n))
        d: dict[str, object] = {"time_s": t, "run": run}
        for ch in CHANNELS:
            d[ch] = rng.standard_normal(n) * 10.0 ** rng.integers(-3, 4)
        d["temp_in"] = np.round(20.0 + rng.standard_normal(n), 2)
        d["temp_out"] = 18.0 + rng.standard_normal(n)
        d["chamber_temp"] = np.full(n, 7.0)
        frames.append(pd.DataFrame(d))
    df = pd.concat(frames, ignore_index=True)
    df.loc[3, "gyro_y"] = np.nan  # a dropped sample
    return df


def assert_same_log(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert list(a.columns) == list(b.columns)
    assert a["run"].tolist() == b["run"].tolist()
    for col in a.columns:
        if col != "run":
            x, y = a[col].to_numpy(np.float64), b[col].to_numpy(np.float64)
            # bit for bit, NaN where NaN
            assert np.array_equal(x.view(np.int64), y.view(np.int64)), col


# ------------------------------------------------------------------ round trips


@pytest.mark.parametrize("suffix", [".csv", ".tsv", ".parquet"])
def test_write_read_round_trip_is_lossless(tmp_path, suffix):
    df = make_log()
    path = tmp_path / f"log{suffix}"
    write_log(df, path)
    back = read_log(path)
    assert_same_log(df, back)
    assert np.isnan(back.loc[3, "gyro_y"])
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary left behind


def test_csv_parquet_tsv_chain_is_lossless(tmp_path):
    df = make_log()
    write_log(df, tmp_path / "a.csv")
    write_log(read_log(tmp_path / "a.csv"), tmp_path / "b.parquet")
    write_log(read_log(tmp_path / "b.parquet"), tmp_path / "c.tsv")
    assert_same_log(df, read_log(tmp_path / "c.tsv"))
    assert "\t" in (tmp_path / "c.tsv").read_text().splitlines()[0]


def test_run_names_that_look_like_numbers_stay_text(tmp_path):
    df = make_log(runs=("007", "1e3"))
    write_log(df, tmp_path / "r.csv")
    assert read_log(tmp_path / "r.csv")["run"].unique().tolist() == ["007", "1e3"]


@pytest.mark.parametrize("suffix", [".csv", ".tsv"])
def test_run_names_that_look_missing_stay_text(tmp_path, suffix):
    # pandas reads "NA", "None", "nan", "null" as missing by default (found by the
    # round-trip property test); in the run column they are names, only an empty cell is not
    names = ("NA", "None", "nan", "null", "N/A")
    df = make_log(runs=names)
    path = tmp_path / f"r{suffix}"
    write_log(df, path)
    back = read_log(path)
    assert back["run"].unique().tolist() == list(names)
    assert_same_log(df, back)  # the dropout in gyro_y is still NaN
    # an empty run cell is still refused, with its row
    sep = "\t" if suffix == ".tsv" else ","
    lines = path.read_text().splitlines()
    cells = lines[2].split(sep)
    assert cells[1] == "NA"
    cells[1] = ""
    lines[2] = sep.join(cells)
    bad = write_text(tmp_path, f"e{suffix}", "\n".join(lines) + "\n")
    with pytest.raises(LogError, match=r"'run', data row 2: empty run name"):
        read_log(bad)


def test_an_empty_string_run_name_is_refused_before_writing(tmp_path):
    df = make_log()
    df.loc[4, "run"] = ""
    with pytest.raises(LogError, match=r"data row 5: empty run name"):
        write_log(df, tmp_path / "x.csv")
    assert not (tmp_path / "x.csv").exists()


def test_explicit_format_overrides_suffix(tmp_path):
    df = make_log()
    write_log(df, tmp_path / "log.dat", fmt="tsv")
    assert_same_log(df, read_log(tmp_path / "log.dat", fmt="tsv"))


def test_unknown_suffix_is_refused(tmp_path):
    with pytest.raises(LogError, match=r"log\.xlsx: unknown log file suffix '\.xlsx'"):
        write_log(make_log(), tmp_path / "log.xlsx")
    (tmp_path / "log.xlsx").write_text("x")
    with pytest.raises(LogError, match="unknown log file suffix"):
        read_log(tmp_path / "log.xlsx")
    assert not (tmp_path / "log.xlsx").read_text() == ""


def test_write_is_atomic_and_refuses_invalid_logs(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("keep me\n")
    bad = make_log()
    bad.loc[2, "time_s"] = bad.loc[1, "time_s"]
    with pytest.raises(LogError, match="not strictly increasing"):
        write_log(bad, path)
    assert path.read_text() == "keep me\n"  # the old file is intact
    assert [p.name for p in tmp_path.iterdir()] == ["log.csv"]


def test_missing_file_and_folder(tmp_path):
    with pytest.raises(LogError, match=r"nope\.csv: no such file"):
        read_log(tmp_path / "nope.csv")
    with pytest.raises(LogError, match="does not exist"):
        write_log(make_log(), tmp_path / "no" / "log.csv")


# ------------------------------------------------------------------ bad files


def write_text(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def valid_csv(tmp_path: Path) -> str:
    write_log(make_log(n=4), tmp_path / "good.csv")
    return (tmp_path / "good.csv").read_text()


def test_file_missing_a_column(tmp_path):
    df = make_log().drop(columns=["accel_y"])
    df.to_csv(tmp_path / "m.csv", index=False)
    with pytest.raises(LogError) as info:
        read_log(tmp_path / "m.csv")
    msg = str(info.value)
    assert "m.csv" in msg and "missing required column(s) 'accel_y'" in msg
    assert "columns found: 'time_s', 'run'" in msg


def test_file_with_non_numeric_value(tmp_path):
    lines = valid_csv(tmp_path).splitlines()
    cells = lines[3].split(",")  # data row 3
    cells[5] = "oops"  # accel_x
    lines[3] = ",".join(cells)
    p = write_text(tmp_path, "n.csv", "\n".join(lines) + "\n")
    with pytest.raises(LogError) as info:
        read_log(p)
    msg = str(info.value)
    assert "n.csv" in msg and "'accel_x'" in msg and "data row 3" in msg and "'oops'" in msg


@pytest.mark.parametrize(("column", "cell"), [("time_s", ""), ("temp_in", "inf")])
def test_file_with_nan_or_inf_in_time_or_temperature(tmp_path, column, cell):
    lines = valid_csv(tmp_path).splitlines()
    j = lines[0].split(",").index(column)
    cells = lines[5].split(",")
    cells[j] = cell
    lines[5] = ",".join(cells)
    p = write_text(tmp_path, "f.csv", "\n".join(lines) + "\n")
    with pytest.raises(LogError) as info:
        read_log(p)
    msg = str(info.value)
    assert "f.csv" in msg and f"'{column}'" in msg and "data row 5" in msg


def test_empty_sensor_cell_is_a_kept_nan(tmp_path):
    lines = valid_csv(tmp_path).splitlines()
    cells = lines[2].split(",")
    cells[2] = ""  # gyro_x of data row 2
    lines[2] = ",".join(cells)
    df = read_log(write_text(tmp_path, "d.csv", "\n".join(lines) + "\n"))
    assert np.isnan(df["gyro_x"].iloc[1]) and df["gyro_x"].isna().sum() == 1
    assert len(df) == 8


def test_file_with_time_going_back(tmp_path):
    df = make_log()
    df.loc[9, "time_s"] = df.loc[8, "time_s"] - 1e-3  # second run, its 4th sample
    df.to_csv(tmp_path / "t.csv", index=False)
    with pytest.raises(LogError) as info:
        read_log(tmp_path / "t.csv")
    msg = str(info.value)
    assert "t.csv" in msg and "data row 10" in msg and "not strictly increasing" in msg
    assert "'soak_+14C'" in msg


def test_file_with_a_one_sample_run(tmp_path):
    text = valid_csv(tmp_path)
    last = text.splitlines()[-1].split(",")
    last[1] = "stray"
    p = write_text(tmp_path, "s.csv", text + ",".join(last) + "\n")
    with pytest.raises(LogError, match=r"s\.csv: column 'run', data row 9: run 'stray' has 1"):
        read_log(p)


def test_empty_file_and_header_only(tmp_path):
    with pytest.raises(LogError, match=r"e\.csv: empty file"):
        read_log(write_text(tmp_path, "e.csv", ""))
    with pytest.raises(LogError, match=r"ws\.tsv: empty file"):
        read_log(write_text(tmp_path, "ws.tsv", "\n\n  \n"))
    header = valid_csv(tmp_path).splitlines()[0]
    with pytest.raises(LogError, match=r"h\.csv: no data rows"):
        read_log(write_text(tmp_path, "h.csv", header + "\n"))
    (tmp_path / "e.parquet").write_bytes(b"")
    with pytest.raises(LogError, match=r"e\.parquet: not a Parquet file"):
        read_log(tmp_path / "e.parquet")


def test_binary_junk_is_not_a_table(tmp_path):
    junk = np.random.default_rng(3).integers(0, 256, 4096, dtype=np.uint8).tobytes()
    (tmp_path / "j.csv").write_bytes(junk)
    with pytest.raises(LogError, match=r"j\.csv: (binary data|not a UTF-8 text table)"):
        read_log(tmp_path / "j.csv")
    (tmp_path / "j.parquet").write_bytes(junk)
    with pytest.raises(LogError, match=r"j\.parquet: not a Parquet file"):
        read_log(tmp_path / "j.parquet")
    (tmp_path / "k.parquet").write_bytes(b"PAR1" + junk + b"PAR1")
    with pytest.raises(LogError, match=r"k\.parquet: unreadable Parquet file"):
        read_log(tmp_path / "k.parquet")


def test_parquet_file_named_csv_is_binary(tmp_path):
    write_log(make_log(), tmp_path / "p.parquet")
    os.replace(tmp_path / "p.parquet", tmp_path / "p.csv")
    with pytest.raises(LogError, match=r"p\.csv: binary data, not a text table"):
        read_log(tmp_path / "p.csv")


def test_json_file_is_not_a_table(tmp_path):
    p = write_text(tmp_path, "model.csv", json.dumps({"time_s": [0, 1], "run": ["a", "a"]}))
    with pytest.raises(LogError, match=r"model\.csv: looks like JSON, not a table"):
        read_log(p)


def test_single_column_is_not_a_table_and_hints_the_separator(tmp_path):
    p = write_text(tmp_path, "one.csv", "value\n1\n2\n3\n")
    with pytest.raises(LogError, match=r"one\.csv: not a table: only one column 'value'"):
        read_log(p)
    tsv_as_csv = valid_csv(tmp_path).replace(",", "\t")
    with pytest.raises(LogError, match=r"header contains a tab: set the separator"):
        read_log(write_text(tmp_path, "tabs.csv", tsv_as_csv))
    df = read_log(write_text(tmp_path, "tabs2.csv", tsv_as_csv), ColumnMapping(separator="auto"))
    assert len(df) == 8


def test_ragged_rows_are_not_a_table(tmp_path):
    text = valid_csv(tmp_path) + "1,2,3,4,5,6,7,8,9,10,11,12,13,14\n"
    with pytest.raises(LogError, match=r"r\.csv: not a well-formed table"):
        read_log(write_text(tmp_path, "r.csv", text))


# ------------------------------------------------------------------ mappings

FOREIGN = (
    "ts_ms;unit;wx;wy;wz;ax;ay;az;T;status\n"
    "1000000;A;1;2;3;4;5;6;20.5;0\n"
    "1000010;A;1;2;3;4;5;6;20.6;0\n"
    "1000030;A;1;2;3;4;5;6;20.7;1\n"
    "5000;B;1;2;3;4;5;6;30.0;0\n"
    "5500;B;1;2;3;4;5;6;30.1;0\n"
)


def foreign_mapping(**kw) -> ColumnMapping:
    cols = {"unit": "run", "wx": "gyro_x", "wy": "gyro_y", "wz": "gyro_z"}
    cols |= {"ax": "accel_x", "ay": "accel_y", "az": "accel_z"}
    base = {
        "columns": cols,
        "time": "ts_ms",
        "time_unit": "ms",
        "temperature": "T",
        "separator": "semicolon",
        "drop": ("status",),
    }
    return ColumnMapping(**(base | kw))


def test_mapping_renames_converts_time_per_run_and_scales(tmp_path):
    p = write_text(tmp_path, "foreign.txt.csv", FOREIGN)
    m = foreign_mapping(scale={"accel_z": 1e-3}, relative_time=True)
    df = read_log(p, m)
    assert df["run"].tolist() == ["A", "A", "A", "B", "B"]
    np.testing.assert_allclose(df["time_s"], [0.0, 0.010, 0.030, 0.0, 0.5], rtol=0, atol=1e-15)
    # without relative_time (the default) the time is as given, converted to seconds
    as_given = read_log(p, foreign_mapping())
    np.testing.assert_allclose(as_given["time_s"], [1000.0, 1000.01, 1000.03, 5.0, 5.5], rtol=0)
    assert df["temp_in"].tolist() == [20.5, 20.6, 20.7, 30.0, 30.1]
    np.testing.assert_allclose(df["accel_z"], 6e-3)
    assert "status" not in df.columns and "T" not in df.columns


def test_absolute_microsecond_time_is_exact(tmp_path):
    t_us = np.array([256551281491968, 256551281997598, 256551282503295])
    text = "t;a;b;c;d;e;f;temp\n" + "".join(f"{t};1;2;3;4;5;6;20\n" for t in t_us)
    cols = dict(zip("abcdef", CHANNELS, strict=True))
    m = ColumnMapping(
        columns=cols,
        time="t",
        time_unit="us",
        temperature="temp",
        separator=";",
        relative_time=True,
    )
    df = read_log(write_text(tmp_path, "abs.csv", text), m)
    # differences taken in integers: exact to the microsecond despite 2.6e14 offsets
    assert df["time_s"].tolist() == [0.0, 0.50563, 1.011327]
    assert df["run"].unique().tolist() == ["abs"]  # no run column: the file stem


def test_mapping_names_missing_foreign_columns_and_bad_values_with_foreign_names(tmp_path):
    p = write_text(tmp_path, "foreign.csv", FOREIGN)
    with pytest.raises(LogError, match=r"foreign\.csv: column\(s\) 'Tin' named in the mapping"):
        read_log(p, foreign_mapping(temperature="Tin"))
    bad = FOREIGN.replace("1000010;A;1;2;3;4;5;6;20.6", "1000010;A;1;2;3;4;5;x;20.6")
    with pytest.raises(LogError, match=r"column 'accel_z' \(from 'az'\), data row 2"):
        read_log(write_text(tmp_path, "bad.csv", bad), foreign_mapping())
    back = FOREIGN.replace("1000030", "1000005")
    with pytest.raises(LogError, match=r"'time_s' \(from 'ts_ms'\), data row 3: time not strictly"):
        read_log(write_text(tmp_path, "back.csv", back), foreign_mapping())


def test_mapping_validation_names_the_key(tmp_path):
    with pytest.raises(ConfigError, match="'gyro_q' is not a canonical column"):
        ColumnMapping(columns={"wx": "gyro_q"})
    with pytest.raises(ConfigError, match="time_unit: 'ns'"):
        ColumnMapping(time_unit="ns")
    with pytest.raises(ConfigError, match="separator: 'pipe'"):
        ColumnMapping(separator="pipe")
    with pytest.raises(ConfigError, match="scale: 'mag_x' is not a channel"):
        ColumnMapping(scale={"mag_x": 2.0})
    with pytest.raises(ConfigError, match=r"units\.gyro_z: unit 'furlong/fortnight' is not one"):
        ColumnMapping(units={"gyro_z": "furlong/fortnight"})
    with pytest.raises(ConfigError, match=r"units\.accel: unit 'rad/s' is not one"):
        ColumnMapping(units={"accel": "rad/s"})
    with pytest.raises(ConfigError, match="several foreign columns map to temp_in"):
        ColumnMapping(columns={"T1": "temp_in"}, temperature="T2")
    toml = tmp_path / "m.toml"
    toml.write_text('time = "t"\ntime_units = "us"\n')
    with pytest.raises(ConfigError, match=r"m\.toml: unknown key\(s\) time_units"):
        read_mapping(toml)
    toml.write_text("time = [\n")
    with pytest.raises(ConfigError, match=r"m\.toml: not a valid TOML"):
        read_mapping(toml)
    with pytest.raises(ConfigError, match="mapping file not found"):
        read_mapping(tmp_path / "none.toml")


def test_mapping_from_cli_options_overrides_a_file(tmp_path):
    assert mapping_from_options() is None
    base = read_mapping(EXAMPLE_MAPPING)
    m = mapping_from_options(base, time_unit="ms", columns=["wx=gyro_x"], scale=["gyro_x=2"])
    assert m.time_unit == "ms" and m.columns["wx"] == "gyro_x" and m.scale == {"gyro_x": 2.0}
    assert m.columns["imu.acc.z"] == "accel_z" and m.temperature == "imu.temperature"
    assert "imu.gyro.x" not in m.columns  # --col wx=gyro_x replaced the file's gyro_x entry
    with pytest.raises(ConfigError, match="columns='wx' is not of the form"):
        mapping_from_options(columns=["wx"])
    with pytest.raises(ConfigError, match="scale='gyro_x=two': 'two' is not a number"):
        mapping_from_options(scale=["gyro_x=two"])


# ------------------------------------------------------------------ the commands, as met

runner = CliRunner()


def cli(*args: object):
    return runner.invoke(app, [str(a) for a in args])


def warmup_runs(n: int = 300) -> list[pd.DataFrame]:
    """Three warm-ups from 5, 25 and 45 °C whose outputs follow a known cubic in T [°C]."""
    rng = np.random.default_rng(5)
    runs = []
    for k, start in enumerate((5.0, 25.0, 45.0)):
        t = np.arange(n) * 2.0
        temp = start + 15.0 * (1.0 - np.exp(-t / 300.0))
        d: dict[str, object] = {"time_s": t, "run": f"warm_{k}"}
        for j, ch in enumerate(CHANNELS):
            d_t = (temp - 30.0) / 10.0
            d[ch] = (1.0 + j) * (d_t + 0.1 * d_t**3) + 1e-3 * rng.standard_normal(n)
        d["temp_in"] = temp + 0.01 * rng.standard_normal(n)
        runs.append(pd.DataFrame(d))
    return runs


@pytest.fixture(scope="module")
def model_file(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("model")
    write_log(pd.concat(warmup_runs(), ignore_index=True), folder / "warm.csv")
    res = cli("fit", folder / "warm.csv", "--out", folder / "m.json", "--method", "poly-t",
              "--static-ref", "mean")  # fmt: skip
    assert res.exit_code == 0, res.output
    return folder / "m.json"


def one_line(res) -> str:
    return " ".join(res.output.split())


@pytest.mark.parametrize("suffix", [".csv", ".tsv", ".parquet"])
def test_a_log_with_a_header_and_no_rows_says_so_run_by_run_too(tmp_path, suffix):
    path = tmp_path / f"h{suffix}"
    write_log(make_log().iloc[:0], path, validate=False)
    for read in (
        read_log,
        lambda p: list(iter_log_source(p)),
        lambda p: list(iter_log_source(p, piece_rows=1)),
    ):
        with pytest.raises(LogError, match=rf"h\{suffix}: no data rows \(only a header\)"):
            read(path)


def test_every_command_refuses_a_header_only_csv_in_one_line(tmp_path, model_file):
    path = tmp_path / "h.csv"
    write_log(make_log().iloc[:0], path, validate=False)
    out = tmp_path / "out"
    out.mkdir()
    commands = {
        "fit": ["--out", out / "m.json", "--method", "poly-t", "--static-ref", "mean"],
        "select": ["--method", "regression"],
        "evaluate": ["--model", model_file],
        "compensate": ["--model", model_file, "--out", out / "c.csv"],
        "plot": ["--out", out / "h.png"],
    }
    for command, options in commands.items():
        res = cli(command, path, *options)
        assert res.exit_code == 2, (command, res.output, res.exception)
        assert f"error: {path}: no data rows (only a header)" in one_line(res), command
        assert "Traceback" not in res.output
    assert list(out.iterdir()) == []  # nothing written


def assert_same_figures(got: object, want: object, where: str = "") -> None:
    """Two JSON documents alike: the same keys and text, numbers to 1e-9 (sums in another order)."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and got.keys() == want.keys(), where
        for k in want:
            assert_same_figures(got[k], want[k], f"{where}/{k}")
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), where
        for k, (g, w) in enumerate(zip(got, want, strict=True)):
            assert_same_figures(g, w, f"{where}/{k}")
    elif isinstance(want, float):
        assert got == pytest.approx(want, rel=1e-9, abs=1e-12, nan_ok=True), where
    else:
        assert got == want, where


def interleaved(runs: list[pd.DataFrame]) -> pd.DataFrame:
    """The first two runs' rows alternating (each run in its own order), then the third."""
    a, b, c = runs
    mixed = pd.concat([a, b], ignore_index=True)
    order = np.argsort(np.r_[np.arange(len(a)) * 2, np.arange(len(b)) * 2 + 1], kind="stable")
    return pd.concat([mixed.iloc[order], c], ignore_index=True)


@pytest.mark.parametrize("piece_rows", [1, 7, 1 << 18])
def test_run_by_run_reading_tells_interleaved_runs_from_a_short_run(tmp_path, piece_rows):
    runs = [r.iloc[:20] for r in warmup_runs()]
    mixed = tmp_path / "mixed.csv"
    write_log(interleaved(runs), mixed)
    with pytest.raises(InterleavedRunsError, match=r"mixed\.csv: data row 3: .*read whole"):
        list(iter_log_source(mixed, piece_rows=piece_rows))
    short = tmp_path / "short.csv"  # a one-sample run that no other run interrupts
    write_log(pd.concat([runs[0], runs[1].iloc[:1], runs[2]]), short, validate=False)
    with pytest.raises(LogError, match=r"data row 21: run 'warm_1' has 1 sample\(s\)") as info:
        list(iter_log_source(short, piece_rows=piece_rows))
    assert not isinstance(info.value, InterleavedRunsError)


def test_interleaved_runs_are_read_whole_by_every_command(tmp_path, model_file):
    runs = warmup_runs()
    whole, mixed = tmp_path / "whole.csv", tmp_path / "mixed.csv"
    write_log(pd.concat(runs, ignore_index=True), whole)
    mixed_log = interleaved(runs)
    assert mixed_log["run"].tolist()[:4] == ["warm_0", "warm_1", "warm_0", "warm_1"]
    write_log(mixed_log, mixed)
    # fit: the model of the interleaved log is the model of the same runs stacked
    temp = np.linspace(5.0, 60.0, 23)
    predictions = []
    for path in (whole, mixed):
        out = tmp_path / f"{path.stem}.json"
        res = cli("fit", path, "--out", out, "--method", "poly-t", "--static-ref", "mean")
        assert res.exit_code == 0, res.output
        predictions.append(ThermalModelFile.load(out).predict(temp, np.zeros_like(temp)))
    np.testing.assert_allclose(predictions[1], predictions[0], rtol=1e-9, atol=1e-12)
    # select (run by run: regression) and evaluate: the same figures
    for args in (["select", "--method", "regression", "--json"],
                 ["evaluate", "--model", model_file, "--json"]):  # fmt: skip
        docs = []
        for path in (whole, mixed):
            res = cli(args[0], path, *args[1:])
            assert res.exit_code == 0, res.output
            doc = json.loads(res.stdout)
            doc.pop("log", None)
            # evaluate's Allan table is ordered by channel when it gets the log whole, by run
            # when it gets it run by run: the same rows, compared in one order
            doc.get("allan", []).sort(key=lambda r: (r["run"], r["channel"], r["output"]))
            docs.append(doc)
        assert_same_figures(docs[1], docs[0])
    # compensate: every row where the file had it, values as for the stacked runs
    outs = {}
    for path in (whole, mixed):
        outs[path] = tmp_path / f"{path.stem}_comp.csv"
        res = cli("compensate", path, "--model", model_file, "--out", outs[path])
        assert res.exit_code == 0, res.output
    got, want = read_log_source(outs[mixed]).raw, read_log_source(outs[whole]).raw
    assert got["run"].tolist() == mixed_log["run"].tolist()
    np.testing.assert_array_equal(got["time_s"], mixed_log["time_s"])
    key = ["run", "time_s"]
    want = got[key].merge(want, on=key, how="left", validate="one_to_one")
    for c in CHANNELS:
        np.testing.assert_allclose(got[c], want[c], rtol=1e-12, atol=0)
        assert not np.allclose(got[c], mixed_log[c])  # compensated, not copied


# ------------------------------------------------------------------ the real log


def test_the_real_logs_are_the_published_files_with_their_licences():
    # kept in the repository (tests/data/real) so that a fresh clone tests on real data
    folder = real_log_path().parent
    published = {
        real_log_path(): "9e715f32362f76783678862bbfa60ce2d6b668dafb9fc104d69aaafcb2f301d0",
        folder / "ulog" / "px4_cubeorange_sample_log_small.ulg": (
            "68d1020f688109f027dba08d2950247cc0ae34aaefdcf37e4a7d60838f3e1aa3"
        ),
    }
    for path, sha256 in published.items():
        assert hashlib.sha256(path.read_bytes()).hexdigest() == sha256, path
        assert path.stat().st_size < 5_000_000  # the repository's limit per tracked file
    assert "MIT License" in (folder / "LICENSE.tofupilot-examples.txt").read_text()
    assert "PX4" in (folder / "ulog" / "LICENSE.pyulog.md").read_text()
    readme = (folder / "README.md").read_text()
    assert all(sha256 in readme for sha256 in published.values())


def test_real_thermal_cycle_log_loads_through_the_example_mapping():
    path = real_log_path()
    mapping = read_mapping(EXAMPLE_MAPPING)
    df = read_log(path, mapping)
    assert len(df) == 8400
    assert df["run"].nunique() == 1
    t = df["time_s"].to_numpy()
    assert t[0] == 0.0
    # about 2 Hz over 70.7 min: seconds, not µs
    assert 0.45 < np.median(np.diff(t)) < 0.55
    assert t[-1] / 60.0 == pytest.approx(70.75, abs=0.05)
    assert df["temp_in"].iloc[0] == pytest.approx(51.615, abs=1e-3)
    assert df["temp_in"].min() == pytest.approx(-17.5, abs=0.2)
    assert df["temp_in"].max() == pytest.approx(73.9, abs=0.2)
    # a static unit: gravity on z, in m/s²
    assert np.median(df["accel_z"]) == pytest.approx(-9.6, abs=0.2)
    assert "imu.status" not in df.columns
    assert mapping.unit_of("gyro_y") == "rad/s" and mapping.unit_of("accel_x") == "m/s^2"


# ------------------------------------------------------------------ metadata


def test_meta_round_trip_and_absence(tmp_path):
    log = tmp_path / "soak.parquet"
    assert read_meta(log) is None
    meta = {
        "units": {ch: ("deg/h" if ch.startswith("gyro") else "ug") for ch in CHANNELS},
        "latitude_deg": np.float64(45.75),
        "seed": np.int64(3),
        "pulse_scale": np.array([1.0, 2.0]),
    }
    written = write_meta(meta, log)
    assert written == meta_path(log) == tmp_path / "soak.parquet.meta.json"
    back = read_meta(log)
    assert back["units"]["accel_x"] == "ug" and back["latitude_deg"] == 45.75
    assert back["seed"] == 3 and back["pulse_scale"] == [1.0, 2.0]
    written.write_text("[1, 2]")
    with pytest.raises(
        LogError, match=r"soak\.parquet\.meta\.json: metadata must be a JSON object"
    ):
        read_meta(log)
    written.write_text("{bad")
    with pytest.raises(LogError, match="not valid JSON metadata"):
        read_meta(log)


def test_the_run_by_run_reader_holds_no_run_the_caller_has_dropped(tmp_path, monkeypatch):
    """Reading run k + 1 while the reader still held run k cost a whole run of memory (90 MB
    on a 100 Hz soak); when the next run is built, every run the caller dropped is gone."""
    import gc
    import weakref

    import rinscal.io.streaming as rio

    frames = []
    for k in range(4):
        n = 300 + 50 * k
        frames.append(
            pd.DataFrame(
                {
                    "time_s": np.arange(1, n + 1, dtype=float),
                    "run": f"r{k}",
                    **{c: np.full(n, float(k)) for c in CHANNELS},
                    "temp_in": np.linspace(10.0, 20.0, n),
                }
            )
        )
    path = tmp_path / "runs.parquet"
    write_log(pd.concat(frames, ignore_index=True), path)
    built: list[weakref.ref] = []
    real = rio._source

    def watched(*args, **kwargs):
        gc.collect()
        alive = [i for i, r in enumerate(built) if r() is not None]
        assert not alive, f"runs {alive} are still held while the next run is built"
        src = real(*args, **kwargs)
        built.append(weakref.ref(src.log))
        return src

    monkeypatch.setattr(rio, "_source", watched)
    seen = 0
    for src in rio.iter_log_source(path, piece_rows=128):
        assert src.log["gyro_x"].iloc[0] == float(seen)
        seen += 1
        del src  # the caller is done with the run
    assert seen == 4

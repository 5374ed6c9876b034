"""Every input gets a clear answer, every output keeps what it was given (issue 11).

Each test states the input a user gives and asserts the bytes or the message they get.
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.io.tables import read_log, write_log
from rinscal.schema import CHANNELS
from tests._shared import linear_log

runner = CliRunner()


@pytest.fixture(scope="module")
def model_file(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("model")
    log = d / "train.csv"
    write_log(linear_log(), log)
    out = d / "m.json"
    res = runner.invoke(app, ["fit", str(log), "--method", "poly-t", "--out", str(out)])
    assert res.exit_code == 0, res.output
    return out


def _invoke(args: list) -> tuple[int, str]:
    res = runner.invoke(app, [str(a) for a in args])
    return res.exit_code, res.output


# ------------------------------------------------------------------ time as given


def test_mapping_options_leave_time_as_given_unless_asked(tmp_path, model_file) -> None:
    from rinscal.io.foreign import ReadOptions, read_foreign_source

    src = tmp_path / "in.csv"
    linear_log().to_csv(src, sep=";", index=False)
    # a mapping option (the separator) no longer shifts time: it was 0.0 here before
    df = read_foreign_source(src, ReadOptions(sep="semicolon"))[0].log
    assert df.groupby("run")["time_s"].first().tolist() == [1.0, 1.0]
    df = read_foreign_source(src, ReadOptions(sep="semicolon", relative_time=True))[0].log
    assert df.groupby("run")["time_s"].first().tolist() == [0.0, 0.0]
    # compensate writes the file's own time column back, and its separator
    for extra in ([], ["--relative-time"]):
        out = tmp_path / f"out{len(extra)}.csv"
        code, text = _invoke(
            ["compensate", src, "--sep", "semicolon", *extra, "-m", model_file, "--out", out]
        )
        assert code == 0, text
        back = pd.read_csv(out, sep=";")
        assert back["time_s"].tolist() == linear_log()["time_s"].tolist()


def test_relative_time_is_in_help() -> None:
    code, text = _invoke(["compensate", "--help"])
    assert code == 0 and "--relative-time" in text and "off unless given" in text


# ------------------------------------------------------------------ columns kept


def test_extra_text_columns_come_back_byte_for_byte(tmp_path, model_file) -> None:
    log = linear_log(n=50)
    log["note"] = ["NA", "null", "n/a", "", " padded ", "NaN", "None", "-nan", "1.50", "x"] * 10
    src = tmp_path / "in.csv"
    log.to_csv(src, index=False, lineterminator="\n")
    out = tmp_path / "out.csv"
    code, text = _invoke(["compensate", src, "-m", model_file, "--out", out])
    assert code == 0, text
    with open(src, newline="") as fa, open(out, newline="") as fb:
        a, b = list(csv.DictReader(fa)), list(csv.DictReader(fb))
    assert [r["note"] for r in a] == [r["note"] for r in b]  # the text itself, not NaN
    assert list(b[0]) == [*log.columns, "out_of_range"]  # same columns, same order
    # the canonical reader keeps them as text too
    assert read_log(src)["note"].tolist() == log["note"].tolist()


def test_a_foreign_log_keeps_its_own_columns(tmp_path) -> None:
    log = linear_log(n=200)
    foreign = pd.DataFrame(
        {
            "timestamp": (log["time_s"] * 1e6).astype(np.int64),
            "imu.status": ["OK", "NA"] * 200,
            "T": log["temp_in"],
            **{f"imu.{c}": log[c] for c in CHANNELS},
        }
    )
    foreign = foreign.iloc[:200]  # one run
    src = tmp_path / "foreign.tsv"
    foreign.to_csv(src, sep="\t", index=False, lineterminator="\n")
    opts = ["--time-col", "timestamp", "--time-unit", "us", "--temp-col", "T"]
    for c in CHANNELS:
        opts += ["--col", f"imu.{c}={c}"]
    model = tmp_path / "m.json"
    code, text = _invoke(["fit", src, "--method", "poly-t", "--out", model, *opts])
    assert code == 0, text
    out = tmp_path / "out.tsv"
    code, text = _invoke(["compensate", src, "-m", model, "--out", out, *opts])
    assert code == 0, text
    back = pd.read_csv(out, sep="\t", dtype={"imu.status": str}, keep_default_na=False)
    assert list(back.columns) == [*foreign.columns, "out_of_range"]
    assert back["timestamp"].tolist() == foreign["timestamp"].tolist()  # µs, as given
    assert back["imu.status"].tolist() == foreign["imu.status"].tolist()
    assert not np.allclose(back["imu.gyro_x"], foreign["imu.gyro_x"])  # compensated


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.lists(
        st.text(
            alphabet=st.characters(
                blacklist_categories=("Cs",), blacklist_characters="\ufeff\r\x00"
            ),
            max_size=12,
        ),
        min_size=3,
        max_size=3,
    )
)
def test_csv_round_trip_of_any_extra_text_is_exact(tmp_path, model_file, texts) -> None:
    log = linear_log(n=30, runs=1)
    log["extra"] = (texts * 10)[:30]
    src = tmp_path / "h.csv"
    src.write_text(log.to_csv(index=False, lineterminator="\n"), encoding="utf-8")
    out = tmp_path / "h_out.csv"
    out.unlink(missing_ok=True)
    code, text = _invoke(["compensate", src, "-m", model_file, "--out", out])
    assert code == 0, text
    a = list(csv.DictReader(io.StringIO(src.read_text(encoding="utf-8"), newline="")))
    b = list(csv.DictReader(io.StringIO(out.read_text(encoding="utf-8"), newline="")))
    assert [r["extra"] for r in a] == [r["extra"] for r in b]


# ------------------------------------------------------------------ static reference


def _foreign(tmp_path: Path) -> tuple[Path, list[str]]:
    """A foreign one-run log whose accelerometer z reads −9.8 m/s² plus a thermal drift."""
    log = linear_log(n=300, runs=1)
    log["accel_z"] = -9.8 + 0.002 * (log["temp_in"] - 25.0)
    src = tmp_path / "foreign.csv"
    log.rename(columns={c: f"imu_{c}" for c in CHANNELS}).to_csv(src, index=False)
    opts = [x for c in CHANNELS for x in ("--col", f"imu_{c}={c}")]
    return src, opts


def test_a_foreign_log_keeps_gravity_when_told_how(tmp_path) -> None:
    src, opts = _foreign(tmp_path)
    for extra, expect_z in (([], 0.0), (["--static-ref", "mean"], None)):
        model = tmp_path / f"m{len(extra)}.json"
        code, text = _invoke(["fit", src, "--method", "poly-t", "--out", model, *opts, *extra])
        assert code == 0, text
        out = tmp_path / f"out{len(extra)}.csv"
        code, text = _invoke(["compensate", src, "-m", model, "--out", out, *opts])
        assert code == 0, text
        z = pd.read_csv(out)["imu_accel_z"]
        if expect_z is None:  # the static level kept: the training mean, about −9.8
            assert abs(z.mean() - (-9.8)) < 0.01 and z.std() < 1e-3
            assert "training mean (fit --static-ref mean)" in text
        else:  # no reference: gravity goes with the thermal bias, and the user is told
            assert abs(z.mean()) < 1e-6
            assert "no static reference" in text and "--latitude/--heading" in text


def test_static_ref_values_and_site_are_checked(tmp_path) -> None:
    src, opts = _foreign(tmp_path)
    model = tmp_path / "m.json"
    code, text = _invoke(
        ["fit", src, "--out", model, *opts, "--method", "poly-t", "--static-ref", "accel_q=1"]
    )
    assert code == 2 and "--static-ref: 'accel_q=1' is not CHANNEL=VALUE" in text
    code, text = _invoke(["fit", src, "--out", model, *opts, "--latitude", "45"])
    assert code == 2 and "--latitude and --heading go together" in text
    code, text = _invoke(
        ["fit", src, "--out", model, *opts, "--method", "poly-t", "--static-ref", "accel_z=-9.8"]
    )
    assert code == 0, text
    out = tmp_path / "o.csv"
    code, text = _invoke(["compensate", src, "-m", model, "--out", out, *opts])
    assert code == 0 and "accel_z -9.8" in text and "values given at fit time" in text
    z = pd.read_csv(out)["imu_accel_z"]
    assert abs(z.mean() - (-9.8)) < 1e-3


# ------------------------------------------------------------------ units


def test_units_that_differ_from_the_model_are_refused(tmp_path, model_file) -> None:
    from rinscal.io.metadata import write_meta

    src = tmp_path / "pulses.csv"
    write_log(linear_log(), src)
    write_meta({"units": {"gyro": "pulse", "accel": "pulse"}}, src)
    # a model fitted in deg/h and ug
    train = tmp_path / "t.csv"
    write_log(linear_log(), train)
    write_meta({"units": {"gyro": "deg/h", "accel": "ug"}}, train)
    model = tmp_path / "m.json"
    assert _invoke(["fit", train, "--method", "poly-t", "--out", model])[0] == 0
    for cmd in (["compensate", "--out", tmp_path / "o.csv"], ["evaluate"]):
        code, text = _invoke([cmd[0], src, "-m", model, *cmd[1:]])
        assert code == 2, text
        assert "units differ from the model's" in text
        assert "gyro_x: model in 'deg/h', log in 'pulse'" in text and "--ignore-units" in text
    code, text = _invoke(
        ["compensate", src, "-m", model, "--out", tmp_path / "o.csv", "--ignore-units"]
    )
    assert code == 0, text


# ------------------------------------------------------------------ OS errors, bounds, memory


@pytest.mark.parametrize(
    ("errno_", "words"),
    [(13, "Permission denied; choose another location"), (28, "the disk is full")],
)
def test_os_errors_on_output_name_the_path(tmp_path, model_file, monkeypatch, errno_, words):
    import tempfile

    def refuse(*args, **kwargs):
        raise OSError(errno_, os.strerror(errno_), kwargs.get("dir", "?"))

    src = tmp_path / "in.csv"
    write_log(linear_log(), src)
    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    out = tmp_path / "out.csv"
    code, text = _invoke(["compensate", src, "-m", model_file, "--out", out])
    assert code == 2 and "Traceback" not in text
    assert f"{out}: cannot write:" in text and words.split(";")[-1].strip() in text


def test_an_output_folder_that_is_a_file_is_named(tmp_path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, text = _invoke(["navigate", "-s", "quasi-static", "--out", blocker / "sub"])
    assert code == 2 and "Traceback" not in text and str(blocker) in text


def test_numeric_options_are_bounded() -> None:
    code, text = _invoke(["navigate", "-s", "quasi-static", "--rate", "1e9", "--out", "x"])
    assert code == 2 and "'--rate'" in text and "1.0<=x<=2000.0" in text
    code, text = _invoke(["simulate", "soak", "--hours", "-1", "--out", "x.csv"])
    assert code == 2 and "'--hours'" in text


def test_simulate_refuses_what_memory_cannot_hold(tmp_path, monkeypatch) -> None:
    import rinscal._resources as res

    monkeypatch.setattr(res, "available_bytes", lambda: 4 * 2**30)
    code, text = _invoke(["simulate", "soak", "--rate", "2000", "--out", tmp_path / "big.parquet"])
    assert code == 2, text
    assert "needs about" in text and "of memory, more than the 4.0 GiB available" in text
    assert "lower --rate or --hours" in text and not (tmp_path / "big.parquet").exists()


# ------------------------------------------------------------------ messages


def test_padded_column_names_are_quoted(tmp_path) -> None:
    src = tmp_path / "pad.csv"
    log = linear_log(n=20, runs=1).rename(columns={"accel_x": " accel_x "})
    log.to_csv(src, index=False)
    code, text = _invoke(["fit", src, "--out", tmp_path / "m.json"])
    assert code == 2 and "' accel_x '" in text and "spaces around them" in text


def test_compressed_logs_get_an_answer_that_exists(tmp_path) -> None:
    src = tmp_path / "log.csv.gz"
    src.write_bytes(b"\x1f\x8b")
    code, text = _invoke(["fit", src, "--out", tmp_path / "m.json"])
    assert code == 2 and "decompress it first" in text and "explicitly" not in text


def test_time_errors_print_plain_numbers(tmp_path) -> None:
    log = linear_log(n=20, runs=1)
    log.loc[5, "time_s"] = log.loc[4, "time_s"]
    src = tmp_path / "t.csv"
    log.to_csv(src, index=False)
    code, text = _invoke(["fit", src, "--out", tmp_path / "m.json"])
    assert code == 2 and "np.float64" not in text and "41 s after 41 s at data row 5" in text


def test_policy_error_names_the_file_and_counts_rows_from_1(tmp_path, model_file) -> None:
    log = linear_log()
    log.loc[log.index[-1], "temp_in"] = 80.0  # the last row, far outside the training data
    src = tmp_path / "hot.csv"
    write_log(log, src)
    code, text = _invoke(
        ["compensate", src, "-m", model_file, "--policy", "error", "--out", tmp_path / "o.csv"]
    )
    assert code == 2, text
    assert f"{src}: gyro_x: data row {len(log)} (run 'r1'" in " ".join(text.split())
    assert "T = 80 °C outside" in text and "np.float64" not in text


def test_reproduce_headline_fits_80_columns() -> None:
    from rich.console import Console

    from rinscal.cli.reproduce import _print_headline

    rows = [
        {
            "runs": "lab + vehicle",
            "method": name,
            "n runs": 13,
            **{
                f"max error {k} [nmi]": v
                for k, v in zip(("mean", "sd", "min", "max"), vals, strict=True)
            },
        }
        for name, vals in (
            ("uncompensated", (0.9885, 0.7347, 0.2195, 2.6636)),
            ("method 2 (regression)", (0.4860, 0.3450, 0.0740, 1.2980)),
        )
    ]
    console = Console(width=80, record=True, markup=False)
    _print_headline(console, rows)
    text = console.export_text()
    assert max(len(line) for line in text.splitlines()) <= 80
    assert "[nmi]" in text and "0.989" in text and "0.486" in text and "2.664" in text

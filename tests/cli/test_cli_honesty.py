"""Every input gets a clear answer, every output keeps what it was given (issue 11).

Each test states the input a user gives and asserts the bytes or the message they get.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.io import read_log, write_log
from rinscal.schema import CHANNELS

runner = CliRunner()


def _log(n: int = 400, runs: int = 2, t0: float = 1.0) -> pd.DataFrame:
    """A small canonical log: outputs linear in T, two runs warming up."""
    rng = np.random.default_rng(0)
    parts = []
    for k in range(runs):
        t = t0 + np.arange(n) * 10.0
        temp = 10.0 + 15.0 * k + 20.0 * (1 - np.exp(-t / 1500.0))
        frame = {"time_s": t, "run": f"r{k}", "temp_in": temp}
        for j, c in enumerate(CHANNELS):
            frame[c] = (j + 1) * 0.1 * (temp - 25.0) + rng.normal(0, 0.01, n)
        parts.append(pd.DataFrame(frame))
    return pd.concat(parts, ignore_index=True)


@pytest.fixture(scope="module")
def model_file(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("model")
    log = d / "train.csv"
    write_log(_log(), log)
    out = d / "m.json"
    res = runner.invoke(app, ["fit", str(log), "--method", "poly-t", "--out", str(out)])
    assert res.exit_code == 0, res.output
    return out


def _invoke(args: list) -> tuple[int, str]:
    res = runner.invoke(app, [str(a) for a in args])
    return res.exit_code, res.output


# ------------------------------------------------------------------ time as given


def test_mapping_options_leave_time_as_given_unless_asked(tmp_path, model_file) -> None:
    from rinscal.cli._options import read_foreign_log

    src = tmp_path / "in.csv"
    _log().to_csv(src, sep=";", index=False)
    # a mapping option (the separator) no longer shifts time: it was 0.0 here before
    df, _ = read_foreign_log(src, sep="semicolon")
    assert df.groupby("run")["time_s"].first().tolist() == [1.0, 1.0]
    df, _ = read_foreign_log(src, sep="semicolon", relative_time=True)
    assert df.groupby("run")["time_s"].first().tolist() == [0.0, 0.0]
    # compensate writes the file's own time column back, and its separator
    for extra in ([], ["--relative-time"]):
        out = tmp_path / f"out{len(extra)}.csv"
        code, text = _invoke(
            ["compensate", src, "--sep", "semicolon", *extra, "-m", model_file, "--out", out]
        )
        assert code == 0, text
        back = pd.read_csv(out, sep=";")
        assert back["time_s"].tolist() == _log()["time_s"].tolist()


def test_relative_time_is_in_help() -> None:
    code, text = _invoke(["compensate", "--help"])
    assert code == 0 and "--relative-time" in text and "off unless given" in text


# ------------------------------------------------------------------ columns kept


def test_extra_text_columns_come_back_byte_for_byte(tmp_path, model_file) -> None:
    log = _log(n=50)
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
    log = _log(n=200)
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
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
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
    log = _log(n=30, runs=1)
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

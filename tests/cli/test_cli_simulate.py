"""`rinscal simulate`: log + truth + metadata, readable, reproducible, clear errors."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.io.params import read_params
from rinscal.io.tables import read_log
from rinscal.schema import CHANNELS
from rinscal.sim.config import ImuConfig

runner = CliRunner()


def _sim(tmp_path, name: str, *extra: str):
    out = tmp_path / name
    res = runner.invoke(app, ["simulate", *extra, "--out", str(out)])
    return out, res


def test_simulate_writes_log_truth_and_meta(tmp_path) -> None:
    out, res = _sim(
        tmp_path, "soak.parquet", "soak", "--hours", "0.1", "--rate", "2", "--seed", "3"
    )
    assert res.exit_code == 0, res.output
    log = read_log(out)
    truth = pd.read_parquet(tmp_path / "soak.truth.parquet")
    meta = json.loads((tmp_path / "soak.parquet.meta.json").read_text())
    assert len(log) == len(truth) == 7 * 720
    assert meta["imu"] == ImuConfig.paper().name
    assert list(log["run"].unique()) == [f"soak_{c:+03d}C" for c in (0, 7, 14, 21, 28, 35, 42)]
    assert (
        meta["seed"] == 3 and meta["rate_hz"] == 2.0 and meta["truth_file"] == "soak.truth.parquet"
    )
    # the truth explains the output: output - truth - static - offset is pure noise
    for run, g in log.groupby("run", sort=False):
        t = truth[truth["run"] == run]
        for ch in ("accel_x", "gyro_y"):
            resid = g[ch].to_numpy() - t[f"bias_{ch}"].to_numpy()
            resid -= meta["static_output"][ch] + meta["turn_on_offset"][run][ch]
            noise = ImuConfig.paper().noise  # the default plant: the paper's unit
            sd = noise.accel_vrw_ug_rthz if ch == "accel_x" else noise.gyro_arw_deg_rth * 60
            sd *= np.sqrt(2.0)  # per sample at 2 Hz
            assert abs(resid.mean()) < 5 * sd / np.sqrt(len(resid)) + 0.5 * sd  # outliers aside


def test_same_seed_same_file(tmp_path) -> None:
    a, _ = _sim(tmp_path, "a.csv", "repeat", "--hours", "0.05", "--rate", "5", "--seed", "9")
    b, _ = _sim(tmp_path, "b.csv", "repeat", "--hours", "0.05", "--rate", "5", "--seed", "9")
    assert a.read_bytes() == b.read_bytes()
    assert read_log(a)["run"].iat[0] == "repeat_+25C"


def test_pulse_output(tmp_path) -> None:
    out, res = _sim(tmp_path, "p.parquet", "repeat", "--hours", "0.02", "--rate", "10",
                    "--units", "pulses")  # fmt: skip
    assert res.exit_code == 0, res.output
    log = read_log(out)
    vals = log[list(CHANNELS)].to_numpy()
    assert np.all(vals == np.round(vals))
    meta = json.loads((tmp_path / "p.parquet.meta.json").read_text())
    assert meta["units"]["accel_z"] == "pulse"


def test_bad_options_give_clear_errors(tmp_path) -> None:
    _, res = _sim(tmp_path, "x.parquet", "bake")
    assert res.exit_code != 0 and "protocol must be one of" in res.output
    _, res = _sim(tmp_path, "x.xlsx", "soak")
    assert res.exit_code != 0 and "x.xlsx" in res.output
    bad = tmp_path / "imu.toml"
    bad.write_text("[noise]\nfoo = 1\n")
    _, res = _sim(tmp_path, "x.parquet", "soak", "--imu", str(bad))
    assert res.exit_code != 0 and "foo" in res.output and "imu.toml" in res.output
    _, res = _sim(tmp_path, "x.parquet", "soak", "--imu", "navgrade")
    assert res.exit_code != 0 and "navigation_grade" in res.output and "paper" in res.output
    _, res = _sim(tmp_path, "x.parquet", "soak", "--rate", "0")
    assert res.exit_code != 0 and "--rate" in res.output


def test_a_refused_simulate_leaves_nothing(tmp_path) -> None:
    # issue 21, item 7: --out onto a folder was refused after the truth file was written
    args = ("soak", "--hours", "0.05", "--rate", "1")
    for blocker in ("out.csv", "out.truth.csv", "out.csv.meta.json"):
        d = tmp_path / blocker
        d.mkdir(parents=True)
        before = sorted(p.name for p in tmp_path.iterdir())
        _, res = _sim(tmp_path, "out.csv", *args)
        assert res.exit_code == 2, res.output
        assert f"{d}: a folder is in the way" in res.output.replace("\n", "")
        assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written
        assert not any(d.iterdir())
        d.rmdir()


def test_compensate_onto_a_folder_leaves_nothing(tmp_path) -> None:
    log, res = _sim(tmp_path, "soak.csv", "soak", "--hours", "0.3", "--rate", "0.2")
    assert res.exit_code == 0, res.output
    res = runner.invoke(
        app, ["fit", str(log), "--method", "poly-t", "--out", str(tmp_path / "m.json")]
    )
    assert res.exit_code == 0, res.output
    (tmp_path / "c.csv.meta.json").mkdir()
    res = runner.invoke(
        app,
        ["compensate", str(log), "-m", str(tmp_path / "m.json"), "--out", str(tmp_path / "c.csv")],
    )
    assert res.exit_code == 2 and "a folder is in the way" in res.output, res.output
    assert not (tmp_path / "c.csv").exists()


def test_simulate_multiposition_writes_log_truth_table_and_meta(tmp_path) -> None:
    seq = tmp_path / "four.toml"
    seq.write_text("positions = [[0, 0], [180, 0], [-90, 0], [90, 0]]\n")
    out, res = _sim(
        tmp_path, "cal.parquet", "multiposition", "--sequence", str(seq), "--set-points",
        "10,30", "--dwell", "3", "--rates", "50", "--rate", "10", "--seed", "2",
        "--turntable-error",
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    log = read_log(out)
    meta = json.loads((tmp_path / "cal.parquet.meta.json").read_text())
    truth = read_params(tmp_path / "cal.params.truth.csv")
    assert list(log["run"].unique()) == ["cal_+10C", "cal_+30C"]
    for col in ("table_outer_deg", "table_inner_deg", "table_outer_rate_dps",
                "table_inner_rate_dps", "temp_out", "chamber_temp"):  # fmt: skip
        assert col in log.columns
    assert meta["protocol"] == "multiposition" and meta["units"]["gyro_x"] == "pulse"
    assert meta["set_points_c"] == {"cal_+10C": 10.0, "cal_+30C": 30.0}
    assert meta["turntable"] == {"position_error_arcmin": 5.0, "rate_error_ppm": 10.0,
                                 "ideal": False}  # fmt: skip
    assert meta["truth_file"] == "cal.params.truth.csv" and meta["sequence"] == str(seq)
    assert len(truth) == 2 * 33 and set(truth["temperature_c"]) == {10.0, 30.0}
    # pulses: whole counts; static rows at the first position hold still
    assert np.all(log[list(CHANNELS)].to_numpy() % 1 == 0)
    # refuses to overwrite its input (the sequence file), leaving it whole
    text = seq.read_text()
    res = runner.invoke(app, ["simulate", "multiposition", "--sequence", str(seq),
                              "--out", str(seq)])  # fmt: skip
    assert res.exit_code != 0 and seq.read_text() == text
    # --hours is the soak protocols' option
    _, res = _sim(tmp_path, "x.parquet", "multiposition", "--hours", "1")
    assert res.exit_code != 0 and "--hours" in res.output


def test_simulate_multiposition_bad_options_are_named(tmp_path) -> None:
    for extra, word in ((("--sequence", "7"), "neither built in"),
                        (("--rates", "ten"), "--rates"),
                        (("--units", "volts"), "output.mode")):  # fmt: skip
        _, res = _sim(tmp_path, "y.parquet", "multiposition", *extra)
        assert res.exit_code != 0 and word in res.output, res.output
        assert not (tmp_path / "y.parquet").exists()

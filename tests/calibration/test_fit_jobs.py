"""Issue 39: ``fit`` and ``compensate`` spread their channels (and the runs of a whole table)
over threads; the model and the compensated log are those of one thread, to the last bit."""

from __future__ import annotations

import json
import threading

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import rinscal
from rinscal.calibration.thermal import model as model_module
from rinscal.calibration.thermal.features import build_features
from rinscal.cli import app
from rinscal.errors import ConfigError
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log

JOBS = (1, 2, 4)


@pytest.fixture(scope="module")
def soak20(tmp_path_factory):
    """Seven soak cold starts, 15 min each at 20 Hz (126 000 rows): a 10 s window holds 201
    samples, so the decimated outlier screen runs too."""
    from rinscal.sim.protocols import simulate_protocol

    log, _, meta = simulate_protocol(
        "soak", hours=0.25, rate_hz=20.0, seed=5, imu="navigation_grade"
    )
    path = tmp_path_factory.mktemp("jobs") / "soak20.parquet"
    write_log(log, path)
    write_meta(meta, path)
    return log, meta, path


def _doc(result) -> str:
    return json.dumps(result.model.to_dict(), sort_keys=True)


def _threads_of(monkeypatch, name: str) -> set[int]:
    """Record the threads that call ``model_module.<name>`` (the per-channel work)."""
    seen: set[int] = set()
    real = getattr(model_module, name)

    def spy(*args, **kwargs):
        seen.add(threading.get_ident())
        return real(*args, **kwargs)

    monkeypatch.setattr(model_module, name, spy)
    return seen


@pytest.mark.parametrize("method", ["regression", "auto", "poly-t", "px4"])
def test_a_file_s_model_is_the_same_on_one_two_and_four_threads(soak20, method, monkeypatch):
    _, _, path = soak20
    seen = _threads_of(monkeypatch, "features_from_columns")
    docs = []
    for k in JOBS:
        seen.clear()
        docs.append(_doc(rinscal.fit(path, method, n_jobs=k)))
        # the channels ran on the caller's thread alone, or on several
        assert (seen == {threading.get_ident()}) if k == 1 else len(seen) > 1, (k, seen)
    assert docs[0] == docs[1] == docs[2]


def test_a_table_s_model_is_the_same_on_one_and_three_threads(soak20, monkeypatch) -> None:
    """The whole-table path: runs on threads in the features, channels in the factors."""
    log, meta, _ = soak20
    one = rinscal.fit(log, "auto", meta=meta, n_jobs=1)
    seen = _threads_of(monkeypatch, "select_thinned")
    three = rinscal.fit(log, "auto", meta=meta, n_jobs=3)
    assert len(seen) > 1  # the held-out choices of the channels ran on several threads
    assert _doc(one) == _doc(three)
    # and a table gives the model its file gives (read run by run), but for the file's name
    doc = rinscal.fit(soak20[2], "auto", n_jobs=2).model.to_dict()
    assert doc["payload"]["source"].pop("log") == "soak20.parquet"
    assert json.dumps(doc["payload"], sort_keys=True) == json.dumps(
        one.model.to_dict()["payload"], sort_keys=True
    )


def test_features_of_runs_on_threads_are_those_of_one(soak20) -> None:
    log = soak20[0]
    a, b = build_features(log, n_jobs=1), build_features(log, n_jobs=4)
    for name in ("temp", "rate", "grad", "output", "inlier"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(a.report.removed, b.report.removed)
    assert a.report.removed.sum() > 0  # the screen did flag samples (the simulated outliers)


def test_compensated_logs_are_the_same_on_one_two_and_four_threads(soak20, tmp_path) -> None:
    log, _, path = soak20
    model = rinscal.fit(path, "regression", n_jobs=1).model
    tables = []
    for k in JOBS:
        out = tmp_path / f"comp{k}.parquet"
        rinscal.compensate_file(path, model, out, n_jobs=k)
        tables.append(pd.read_parquet(out))
    pd.testing.assert_frame_equal(tables[0], tables[1], check_exact=True)
    pd.testing.assert_frame_equal(tables[0], tables[2], check_exact=True)
    # in memory alike, and both are the log minus the model's bias
    mem = rinscal.compensate(log, model, n_jobs=3)
    np.testing.assert_array_equal(mem["gyro_x"].to_numpy(), tables[0]["gyro_x"].to_numpy())
    assert not np.array_equal(mem["gyro_x"].to_numpy(), log["gyro_x"].to_numpy())


def test_fit_and_compensate_take_jobs_on_the_command_line(soak20, tmp_path) -> None:
    _, _, path = soak20
    runner = CliRunner()
    files = []
    for k in (1, 3):
        m = tmp_path / f"m{k}.json"
        res = runner.invoke(app, ["fit", str(path), "--method", "regression", "-o", str(m),
                                  "--jobs", str(k)])  # fmt: skip
        assert res.exit_code == 0, res.output
        out = tmp_path / f"c{k}.parquet"
        res = runner.invoke(app, ["compensate", str(path), "-m", str(m), "-o", str(out),
                                  "-j", str(k)])  # fmt: skip
        assert res.exit_code == 0, res.output
        files.append((m.read_bytes(), out))
    assert files[0][0] == files[1][0]
    pd.testing.assert_frame_equal(pd.read_parquet(files[0][1]), pd.read_parquet(files[1][1]))
    res = runner.invoke(app, ["fit", str(path), "-o", str(tmp_path / "x.json"), "--jobs", "0"])
    assert res.exit_code != 0 and "--jobs" in res.output


@pytest.mark.parametrize("bad", [-1, 1.5, "2"])
def test_n_jobs_is_checked_at_the_boundary(soak20, bad) -> None:
    log, meta, _ = soak20
    with pytest.raises((ConfigError, TypeError), match="n_jobs"):
        rinscal.fit(log, "poly-t", meta=meta, n_jobs=bad)
    with pytest.raises((ConfigError, TypeError), match="n_jobs"):
        rinscal.compensate(log, rinscal.fit(log, "poly-t", meta=meta).model, n_jobs=bad)


def test_quantised_counts_give_the_same_model_and_log_on_threads(tmp_path) -> None:
    """A real sensor's coarse output, not the simulator's fine default: the ring-laser unit's
    soak in whole pulses, a few counts a sample (the outlier screen's and PX4's medians see
    ties everywhere). ``auto`` and the field's PX4 fit give the same model file on one and
    three threads, and the compensated log is the same too."""
    from rinscal.sim.protocols import simulate_protocol

    log, _, meta = simulate_protocol("soak", hours=0.25, rate_hz=10.0, seed=3, imu="ring_laser")
    assert meta["units"]["gyro_x"] == "pulse"
    gyro = log["gyro_x"].to_numpy()
    assert np.array_equal(gyro, np.rint(gyro)) and np.abs(gyro).max() < 200
    path = tmp_path / "rlg.parquet"
    write_log(log, path)
    write_meta(meta, path)
    fits = {(m, k): rinscal.fit(path, m, n_jobs=k) for m in ("auto", "px4") for k in (1, 3)}
    for m in ("auto", "px4"):
        assert _doc(fits[m, 1]) == _doc(fits[m, 3]), m
    model = fits["auto", 1].model
    tables = []
    for k in (1, 3):
        out = tmp_path / f"comp{k}.parquet"
        rinscal.compensate_file(path, model, out, n_jobs=k)
        tables.append(pd.read_parquet(out))
    pd.testing.assert_frame_equal(tables[0], tables[1], check_exact=True)
    assert not np.array_equal(tables[0]["gyro_x"].to_numpy(), gyro)

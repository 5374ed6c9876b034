"""Reading and compensating a log run by run, in pieces that split runs, equals doing it whole."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal import io
from rinscal.calibration.compensate import FLAG_COLUMN, compensated_channels
from rinscal.cli import app
from rinscal.errors import LogError
from rinscal.io import InterleavedRunsError, iter_log_source, read_log_source, write_log

runner = CliRunner()


def _with_text(log: pd.DataFrame) -> pd.DataFrame:
    """The log with a foreign text column (which must come back exactly)."""
    out = log.copy()
    out.insert(1, "note", np.where(np.arange(len(log)) % 7 == 0, "NA", "ok, fine"))
    return out


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_runs_read_in_pieces_are_the_log_read_whole(tmp_path, soak_small, suffix) -> None:
    log, _, _ = soak_small
    path = tmp_path / f"soak{suffix}"
    write_log(_with_text(log), path, validate=False)
    whole = read_log_source(path)
    parts = list(iter_log_source(path, piece_rows=777))  # 1800-row runs: every run split
    assert [p.log["run"].iloc[0] for p in parts] == list(dict.fromkeys(log["run"]))
    assert [p.first_row for p in parts] == list(np.cumsum([0] + [len(p.log) for p in parts])[:-1])
    pd.testing.assert_frame_equal(
        pd.concat([p.log for p in parts], ignore_index=True), whole.log, check_categorical=False
    )
    pd.testing.assert_frame_equal(
        pd.concat([p.raw for p in parts], ignore_index=True).astype({"run": str}),
        whole.raw.astype({"run": str}),
    )


def test_errors_in_a_later_run_give_the_row_of_the_file(tmp_path, soak_small) -> None:
    log, _, _ = soak_small
    bad = log.copy()
    row = 4 * 1800 + 123  # data row 7324, in the fifth run
    bad.loc[row, "temp_gyro_x"] = np.nan
    path = tmp_path / "bad.csv"
    write_log(bad, path, validate=False)
    with pytest.raises(LogError, match=f"'temp_gyro_x', data row {row + 1}:"):
        list(iter_log_source(path, piece_rows=500))
    with pytest.raises(LogError, match=f"'temp_gyro_x', data row {row + 1}:"):
        read_log_source(path)


def _compensate_cli(log_path, model_path, out) -> pd.DataFrame:
    res = runner.invoke(
        app, ["compensate", str(log_path), "-m", str(model_path), "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    return read_log_source(out).raw


@pytest.mark.parametrize("method", ["poly-t", "sectional", "regression", "neural"])
def test_compensate_in_pieces_equals_the_whole_log(
    tmp_path, soak_small, fitted_models, monkeypatch, method
) -> None:
    log, _, _ = soak_small
    path = tmp_path / "soak.csv"
    write_log(_with_text(log), path, validate=False)
    model = tmp_path / "m.json"
    fitted_models[method].save(model)
    # whole: the library on the log read at once
    src = read_log_source(path)
    values, flagged = compensated_channels(src.log, fitted_models[method], "clamp")
    want = src.write_back(values, {FLAG_COLUMN: flagged})
    # pieces of 500 rows: the 60 s rate window (30 samples) straddles every piece boundary
    monkeypatch.setattr(io, "PIECE_ROWS", 500)
    got = _compensate_cli(path, model, tmp_path / "out.csv")
    assert list(got.columns) == list(want.columns)
    for c in want.columns:
        if c in values:
            np.testing.assert_allclose(got[c], want[c], rtol=1e-12, atol=0)
        else:
            assert (got[c].astype(str).to_numpy() == want[c].astype(str).to_numpy()).all(), c


def test_interleaved_runs_are_read_whole(tmp_path, soak_small, fitted_models) -> None:
    log, _, _ = soak_small
    a, b = log[log["run"] == log["run"].iloc[0]], log[log["run"] != log["run"].iloc[0]]
    mixed = pd.concat([a.iloc[:900], b, a.iloc[900:]], ignore_index=True)
    path = tmp_path / "mixed.csv"
    write_log(mixed, path)
    with pytest.raises(InterleavedRunsError, match="data row 11701: run 'soak_"):
        list(iter_log_source(path, piece_rows=1000))
    model = tmp_path / "m.json"
    fitted_models["regression"].save(model)
    got = _compensate_cli(path, model, tmp_path / "out.csv")
    values, _ = compensated_channels(read_log_source(path).log, fitted_models["regression"])
    assert got["run"].tolist() == mixed["run"].tolist()  # rows in the file's order
    np.testing.assert_allclose(got["accel_x"], values["accel_x"], rtol=1e-12)

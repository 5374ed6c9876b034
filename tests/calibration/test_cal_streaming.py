"""Reading and compensating a log run by run, in pieces that split runs, equals doing it whole."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.calibration.compensate import FLAG_COLUMN, compensated_channels
from rinscal.cli import app
from rinscal.errors import LogError
from rinscal.io import streaming as io
from rinscal.io.streaming import InterleavedRunsError, iter_log_source
from rinscal.io.tables import read_log_source, write_log

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


_SLOW = pytest.mark.slow


@pytest.mark.parametrize(
    "method",
    [
        "regression",
        pytest.param("neural", marks=_SLOW),
        pytest.param("poly-t", marks=_SLOW),
        pytest.param("sectional", marks=_SLOW),
    ],
)
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


def _with_extras(log: pd.DataFrame) -> pd.DataFrame:
    """The log with columns of other kinds the file keeps: text, integers, floats with gaps,
    a second dictionary-encoded column."""
    out = _with_text(log)
    k = np.arange(len(log))
    out["count"] = k.astype(np.int64)
    out["spare"] = np.where(k % 11 == 0, np.nan, np.sin(k))  # NaN: a null in Parquet
    out["bench"] = pd.Categorical(np.where(k % 3 == 0, "left", "right"))
    return out


def _parquet_groups(log: pd.DataFrame, path, rows: int | None) -> None:
    """``log`` as Parquet in row groups of ``rows`` rows (None: one group)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.Table.from_pandas(log, preserve_index=False), path, row_group_size=rows)


@pytest.mark.parametrize(("group_rows", "aligned"), [(500, True), (None, False)])
def test_parquet_runs_read_aligned_equal_the_pieces_and_the_whole(
    tmp_path, soak_small, monkeypatch, group_rows, aligned
) -> None:
    """Runs of 1800 rows over row groups of 500: each run is decoded from its first row group
    in one block (no joining of pieces); with one row group for all, the pieces are read."""
    log, _, _ = soak_small
    path = tmp_path / "soak.parquet"
    _parquet_groups(_with_extras(log), path, group_rows)
    whole = read_log_source(path)
    pieces_read = []
    real = io._table_pieces
    monkeypatch.setattr(io, "_table_pieces", lambda *a: pieces_read.append(1) or real(*a))
    parts = list(iter_log_source(path, piece_rows=777))
    assert bool(pieces_read) is not aligned
    monkeypatch.setattr(io, "ALIGNED_EXTRA", -1.0)  # never aligned: the pieces, joined
    joined = list(iter_log_source(path, piece_rows=777))
    assert (
        [p.first_row for p in parts] == [p.first_row for p in joined] == list(range(0, 12600, 1800))
    )
    for got, want in zip(parts, joined, strict=True):
        pd.testing.assert_frame_equal(got.log, want.log, check_exact=True)
        pd.testing.assert_frame_equal(got.raw, want.raw, check_exact=True)
    pd.testing.assert_frame_equal(
        pd.concat([p.log for p in parts], ignore_index=True), whole.log, check_categorical=False
    )
    for c in ("note", "count", "spare"):
        got = pd.concat([p.raw[c] for p in parts], ignore_index=True)
        pd.testing.assert_series_equal(got, whole.raw[c], check_exact=True)


def test_interleaved_parquet_runs_are_refused_before_any_is_read(tmp_path, soak_small) -> None:
    log, _, _ = soak_small
    a, b = log[log["run"] == log["run"].iloc[0]], log[log["run"] != log["run"].iloc[0]]
    mixed = pd.concat([a.iloc[:900], b, a.iloc[900:]], ignore_index=True)
    path = tmp_path / "mixed.parquet"
    _parquet_groups(mixed, path, 500)
    runs = iter_log_source(path)
    with pytest.raises(InterleavedRunsError, match="data row 11701: run 'soak_"):
        next(runs)


def test_compensate_parquet_aligned_writes_what_the_pieces_give(
    tmp_path, soak_small, fitted_models, monkeypatch
) -> None:
    """The file written from runs read in one block each is the file written from runs
    joined from pieces, byte for byte; the message counts every row (on two threads the
    last run is written after the loop)."""
    log, _, _ = soak_small
    path = tmp_path / "soak.parquet"
    _parquet_groups(_with_extras(log), path, 500)
    model = tmp_path / "m.json"
    fitted_models["regression"].save(model)
    outs = {}
    for aligned in (True, False):
        if not aligned:
            monkeypatch.setattr(io, "ALIGNED_EXTRA", -1.0)
        outs[aligned] = tmp_path / f"out_{aligned}.parquet"
        res = runner.invoke(
            app,
            ["compensate", str(path), "-m", str(model), "--out", str(outs[aligned]), "--jobs", "2"],
        )
        assert res.exit_code == 0, res.output
        assert f"{len(log):,} rows" in " ".join(res.output.split())
    assert outs[True].read_bytes() == outs[False].read_bytes()


def _leaves(obj, path=""):
    """Every number of a model file's JSON, by path."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, f"{path}/{k}")
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _leaves(v, f"{path}/{i}")
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield path, float(obj)


@pytest.mark.parametrize(
    "method",
    [
        "regression",
        pytest.param("px4", marks=_SLOW),
        pytest.param("poly-t", marks=_SLOW),
        pytest.param("sectional", marks=_SLOW),
        pytest.param("neural", marks=_SLOW),
        pytest.param("ardupilot", marks=_SLOW),
        pytest.param("auto", marks=_SLOW),
    ],
)
def test_fit_in_pieces_equals_the_whole_log(tmp_path, soak_small, method) -> None:
    import warnings

    from rinscal.calibration.thermal.model import ThermalModel
    from tests.conftest import NEURAL_FAST

    log, _, meta = soak_small
    path = tmp_path / "soak.csv"
    write_log(log, path)
    params = NEURAL_FAST if method == "neural" else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = ThermalModel(method, estimator_params=params).fit(read_log_source(path).log, meta)
        pieces = ThermalModel(method, estimator_params=params).fit_runs(
            ((s.log, s.first_row) for s in iter_log_source(path, piece_rows=500)), meta
        )
    a = dict(_leaves(whole.to_file().payload()))
    b = dict(_leaves(pieces.to_file().payload()))
    assert a.keys() == b.keys()
    for key, v in a.items():
        assert b[key] == pytest.approx(v, rel=1e-9, abs=1e-300), key


def test_run_factors_give_the_fit_of_all_rows(soak_small) -> None:
    """Per-run factors in each run's own scaling, re-expressed in the global one, give the
    least-squares fit of all rows at once (an independent QR of the stacked design)."""
    from rinscal.calibration.inference import predict_params
    from rinscal.calibration.thermal.dispatch import fit_params
    from rinscal.calibration.thermal.features import build_features
    from rinscal.calibration.thermal.runs import RunFits

    log, _, _ = soak_small
    f = build_features(log)
    j = 3  # accel_x: cubic in each input
    x, y = f.matrix(j), f.output[:, j]
    ok = f.usable(j, x)
    fits = RunFits("regression", [3, 3, 3], keep_rows=False)
    for k in range(len(f.runs)):
        rows = ok & (f.run_codes == k)
        fits.add(k, x[rows], y[rows], f.time_s[rows])
    for got, want in (
        (fits.regression([3, 3, 3]), fit_params("regression", {}, x[ok], y[ok])),
        (
            fits.regression([2, 1, 0]),
            fit_params(
                "regression", {"t_order": 2, "rate_order": 1, "grad_order": 0}, x[ok], y[ok]
            ),
        ),
        (fits.poly_t(3, t_ref=20.0), fit_params("poly-t", {"t_ref": 20.0}, x[ok], y[ok])),
    ):
        pg, pw = predict_params(got, x[ok]), predict_params(want, x[ok])
        assert np.max(np.abs(pg - pw)) <= 1e-11 * np.max(np.abs(pw))
        resid = pw - y[ok]
        total, about, n_runs = fits.residual_ss(got)
        assert total == pytest.approx(np.sum(resid**2), rel=1e-9)
        means = np.bincount(f.run_codes[ok], weights=resid) / np.bincount(f.run_codes[ok])
        assert about == pytest.approx(np.sum((resid - means[f.run_codes[ok]]) ** 2), rel=1e-9)
        assert n_runs == len(f.runs)


def test_select_in_pieces_equals_the_whole_log(tmp_path, soak_small) -> None:
    from rinscal.calibration.selection.heldout import select_model, select_regression_runs

    log, _, _ = soak_small
    path = tmp_path / "soak.parquet"
    write_log(log, path)
    channels = ("gyro_x", "accel_z")
    whole = select_model(read_log_source(path).log, "regression", (1, 3), channels=channels)
    pieces = select_regression_runs(
        (s.log for s in iter_log_source(path, piece_rows=700)), (1, 3), channels=channels
    )
    pd.testing.assert_frame_equal(pieces.table, whole.table, rtol=1e-9)
    assert pieces.recommended == whole.recommended and pieces.runs == whole.runs


def test_evaluate_in_pieces_equals_the_whole_log(tmp_path, soak_small, fitted_models) -> None:
    from rinscal.calibration.evaluate import allan_table, evaluate, evaluate_runs

    log, _, _ = soak_small
    path = tmp_path / "soak.csv"
    write_log(log, path)
    mf = fitted_models["sectional"]  # segment edges: the step columns are filled too
    whole = read_log_source(path).log
    res, allan, curves = evaluate_runs(
        ((s.log, s.first_row) for s in iter_log_source(path, piece_rows=600)), mf
    )
    pd.testing.assert_frame_equal(res, evaluate(whole, mf), rtol=1e-12)
    want_allan, want_curves = allan_table(whole, mf)
    pd.testing.assert_frame_equal(allan, want_allan, rtol=1e-12)
    assert curves.keys() == want_curves.keys()
    assert (res["crossings"] > 0).any()


@pytest.mark.parametrize("writeback", [False, True])
def test_stream_writer_writes_the_bytes_of_one_table_per_run(
    tmp_path, soak_small, writeback
) -> None:
    """Runs after the first are converted without from_pandas where a float column has no
    NaN (_arrow_table), and the pages may be handed to the disk as they come: the file is
    byte for byte what writing each run's from_pandas table gives, NaN (nulls) included."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    log, _, _ = soak_small
    log = _with_text(log).assign(run=lambda d: d["run"].astype("category"))
    log.loc[5, "gyro_x"] = np.nan  # a dropped sample in the first run, one in the last
    log.loc[len(log) - 3, "accel_z"] = np.nan
    runs = [g for _, g in log.groupby("run", sort=False, observed=True)]
    assert len(runs) > 2
    got = tmp_path / "stream.parquet"
    with io.LogStreamWriter(got, validate=False, writeback=writeback) as w:
        for run in runs:
            w.write(run)
    want = tmp_path / "want.parquet"
    schema = pa.Table.from_pandas(runs[0], preserve_index=False).schema
    with pq.ParquetWriter(want, schema, use_dictionary=["run", "note"]) as pw:
        for run in runs:
            table = pa.Table.from_pandas(run, schema=schema, preserve_index=False)
            pw.write_table(table, row_group_size=io.PIECE_ROWS)
    assert got.read_bytes() == want.read_bytes()
    assert pq.read_table(got).column("gyro_x").null_count == 1

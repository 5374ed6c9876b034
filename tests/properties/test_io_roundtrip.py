"""Property: any valid log survives CSV -> Parquet -> TSV -> CSV bit for bit."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rinscal.io.tables import read_log, write_log
from rinscal.schema import CHANNELS, TEMP_CHANNELS

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
# a sensor sample: any finite float (subnormals, -0.0, huge and tiny included) or a dropout
sample = st.one_of(finite, st.just(float("nan")))
run_name = st.text(
    alphabet="abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_+-.:# ",
    min_size=1,
    max_size=12,
).filter(lambda s: s.strip() == s and s.strip() != "")


@st.composite
def logs(draw) -> pd.DataFrame:
    names = draw(st.lists(run_name, min_size=1, max_size=4, unique=True))
    per_channel = draw(st.booleans())
    with_out = draw(st.booleans())
    frames = []
    for name in names:
        n = draw(st.integers(2, 12))
        t0 = draw(st.floats(-1e6, 1e6, allow_nan=False))
        steps = draw(st.lists(st.floats(1e-9, 1e4), min_size=n, max_size=n))
        t = t0 + np.cumsum(steps)
        if np.any(np.diff(t) <= 0):  # tiny steps lost in rounding: make them visible
            t = t0 + np.arange(n, dtype=float)
        d: dict[str, object] = {"time_s": t, "run": name}
        for ch in CHANNELS:
            d[ch] = draw(st.lists(sample, min_size=n, max_size=n))
        temps = TEMP_CHANNELS if per_channel else ("temp_in",)
        for col in temps:
            d[col] = draw(st.lists(st.floats(-60, 150), min_size=n, max_size=n))
        if with_out:
            d["temp_out"] = draw(st.lists(finite, min_size=n, max_size=n))
        frames.append(pd.DataFrame(d))
    return pd.concat(frames, ignore_index=True)


def same_bits(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert list(a.columns) == list(b.columns)
    assert a["run"].tolist() == b["run"].tolist()
    for col in a.columns:
        if col == "run":
            continue
        x = a[col].to_numpy(np.float64)
        y = b[col].to_numpy(np.float64)
        nan = np.isnan(x)
        assert np.array_equal(nan, np.isnan(y)), col  # dropouts kept where they were
        assert np.array_equal(x[~nan].view(np.int64), y[~nan].view(np.int64)), col  # -0.0 too


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(logs())
def test_csv_parquet_tsv_round_trip_is_lossless(df):
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_log(df, d / "a.csv")
        a = read_log(d / "a.csv")
        same_bits(df, a)
        write_log(a, d / "b.parquet")
        b = read_log(d / "b.parquet")
        same_bits(df, b)
        write_log(b, d / "c.tsv")
        c = read_log(d / "c.tsv")
        same_bits(df, c)
        write_log(c, d / "d.csv")
        assert (d / "d.csv").read_bytes() == (d / "a.csv").read_bytes()

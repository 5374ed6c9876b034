"""Parked cold starts (`rinscal simulate field-starts`): recordings without a heading whose
truth explains them, at the ambients asked for, reproducible, never overwriting."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal import earth
from rinscal.cli import app
from rinscal.io.metadata import meta_path
from rinscal.io.navopen import open_nav_log
from rinscal.schema import CHANNELS
from rinscal.sim.fieldstarts import simulate_field_starts

runner = CliRunner()
#: Long enough for the four positions at 60 s dwell (−135° 0-60 s, 45°, 135°, −45° by 290 s).
HOURS = 0.1
RATE = 10.0
POSITIONS = (-135.0, 45.0, 135.0, -45.0)


@pytest.fixture(scope="module")
def starts(tmp_path_factory):
    out = tmp_path_factory.mktemp("fs") / "starts"
    logs = simulate_field_starts(out, runs=2, ambient_c=(3.0, 38.0), hours=HOURS, rate_hz=RATE)
    return out, logs


def _samples(log):
    nav = open_nav_log(log)
    pieces = list(nav.pieces())
    t = np.concatenate([p.t for p in pieces])
    dt = np.concatenate([p.dt for p in pieces])
    rate = np.concatenate([np.concatenate([p.dtheta, p.dv], axis=1) for p in pieces]) / dt[:, None]
    table = np.rad2deg(np.concatenate([p.table for p in pieces]))
    return nav, t, rate, table


def _static_signal(lat_deg, h_m, heading, pitch, roll, table_deg):
    """Earth rate and gravity in r [rad/s, m/s²] for the body's attitude and the encoder [deg]."""
    lat = math.radians(lat_deg)
    C_nb = earth.C_nb_from_euler(*np.radians([heading, pitch, roll]))
    p = math.radians(table_deg)
    C_br = np.array([[math.cos(p), -math.sin(p), 0], [math.sin(p), math.cos(p), 0], [0, 0, 1]])
    C_rn = (C_nb @ C_br).T
    return np.concatenate([C_rn @ earth.rate_n(lat), -(C_rn @ earth.gravity_n(lat, h_m))])


def test_recording_reads_back_without_heading_and_truth_explains_it(starts) -> None:
    out, logs = starts
    assert [p.name for p in logs] == ["start_0.parquet", "start_1.parquet"]
    nav, t, rate, table = _samples(logs[0])
    meta = json.loads(meta_path(logs[0]).read_text())
    assert nav.heading_deg is None and "heading_deg" not in meta
    assert not nav.has_ref and not nav.has_ref_heading and nav.has_temps and nav.has_table
    assert meta["field_start"]["ambient_c"] == 3.0 and meta["rate_hz"] == RATE
    assert len(t) == round(HOURS * 3600 * RATE)
    truth = pd.read_parquet(out / "start_0.truth.parquet")
    assert np.allclose(truth["time_s"], np.arange(1.0, HOURS * 3600 + 0.5))
    heading, pitch, roll = (
        float(truth[c].iloc[0]) for c in ("heading_deg", "pitch_deg", "roll_deg")
    )
    assert abs(pitch) < 3.0 and abs(roll) < 3.0
    site = meta["site"]
    wd = np.array(
        [meta["noise"]["gyro_noise_density"]] * 3 + [meta["noise"]["accel_noise_density"]] * 3
    )
    err_cols = [f"error_{c}" for c in CHANNELS]
    seen = []
    for pos in POSITIONS:
        # samples wholly at rest at this position (the table there at both ends)
        at = np.isclose(table, pos, atol=1e-6)
        still = at & np.concatenate([[pos == POSITIONS[0]], at[:-1]])
        first = np.flatnonzero(still)
        end = (
            first[np.flatnonzero(np.diff(first) > 1)[0]]
            if np.any(np.diff(first) > 1)
            else first[-1]
        )
        t0, t1 = t[first[0]], t[end]  # the first dwell there
        span = (t > t0) & (t <= t1) & still
        rows = (truth["time_s"] > t0) & (truth["time_s"] <= t1)
        seen.append(span.sum() / RATE)
        expected = truth.loc[rows, err_cols].to_numpy().mean(axis=0) + _static_signal(
            site["lat_deg"], site["h_m"], heading, pitch, roll, pos
        )
        got = rate[span].mean(axis=0)
        sd = wd / math.sqrt(span.sum() / RATE)  # the white noise's sd of the mean
        assert np.all(np.abs(got - expected) < 6.0 * sd + 1e-9 * np.abs(expected)), (
            pos,
            got - expected,
            sd,
        )
        # the errors matter: without them the gyros or accelerometers miss by far more
        errs = truth.loc[rows, err_cols].to_numpy().mean(axis=0)
        assert np.any(np.abs(errs) > 20.0 * sd)
    assert min(seen) > 30.0  # every position held for at least half its dwell


def test_ambients_as_listed_and_starts_independent(starts) -> None:
    out, _ = starts
    t0 = pd.read_parquet(out / "start_0.truth.parquet")
    t1 = pd.read_parquet(out / "start_1.truth.parquet")
    assert np.allclose(t0["temp_chamber"], 3.0) and np.allclose(t1["temp_chamber"], 38.0)
    m1 = json.loads((out / "start_1.parquet.meta.json").read_text())
    assert m1["field_start"] == {"index": 1, "ambient_c": 38.0, "daily_cycle_c": 0.0,
                                 "hours": HOURS, "seed": 0}  # fmt: skip
    assert t0["heading_deg"].iloc[0] != t1["heading_deg"].iloc[0]


def test_same_seed_same_files_other_start_other_offsets(tmp_path) -> None:
    a = simulate_field_starts(tmp_path / "a", runs=2, ambient_c=(20.0,), hours=0.01, rate_hz=RATE)
    b = simulate_field_starts(tmp_path / "b", runs=1, ambient_c=(20.0,), hours=0.01, rate_hz=RATE)
    pd.testing.assert_frame_equal(pd.read_parquet(a[0]), pd.read_parquet(b[0]))
    t0, t1 = (pd.read_parquet(tmp_path / "a" / f"start_{k}.truth.parquet") for k in (0, 1))
    thermal = [f"thermal_{c}" for c in CHANNELS]
    # each start its own turn-on offsets: error − thermal is the offset (plus a random walk
    # of a tenth of it at most over 36 s), different per start
    e0 = t0[[f"error_{c}" for c in CHANNELS]].to_numpy() - t0[thermal].to_numpy()
    e1 = t1[[f"error_{c}" for c in CHANNELS]].to_numpy() - t1[thermal].to_numpy()
    step = np.abs(e0[0] - e1[0])
    assert np.all(step > 0)
    assert np.all(np.ptp(e0, axis=0) < 0.1 * step) and np.all(np.ptp(e1, axis=0) < 0.1 * step)


def test_daily_cycle_follows_the_sinusoid(tmp_path) -> None:
    simulate_field_starts(tmp_path, runs=1, ambient_c=(10.0,), hours=0.02, rate_hz=RATE,
                          daily_cycle_c=8.0)  # fmt: skip
    tr = pd.read_parquet(tmp_path / "start_0.truth.parquet")
    t = tr["time_s"].to_numpy()
    np.testing.assert_allclose(tr["temp_chamber"], 10.0 + 8.0 * np.sin(2 * np.pi * t / 86400),
                               atol=1e-3)  # fmt: skip


def test_cli_writes_only_its_files_and_refuses_to_overwrite(tmp_path) -> None:
    out = tmp_path / "fs"
    args = ["simulate", "field-starts", "--runs", "3", "--ambient", "0,21", "--hours", "0.01",
            "--rate", "10", "--out", str(out)]  # fmt: skip
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(
        f"start_{k}{s}"
        for k in range(3)
        for s in (".parquet", ".parquet.meta.json", ".truth.parquet")
    )
    metas = [json.loads((out / f"start_{k}.parquet.meta.json").read_text()) for k in range(3)]
    amb = [m["field_start"]["ambient_c"] for m in metas]
    assert amb == [0.0, 21.0, 0.0]
    before = (out / "start_0.parquet").read_bytes()
    res = runner.invoke(app, args)
    assert res.exit_code != 0 and "exists" in res.output and "start_0.parquet" in res.output
    assert (out / "start_0.parquet").read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == names
    res = runner.invoke(
        app, ["simulate", "soak", "--ambient", "5", "--out", str(tmp_path / "x.parquet")]
    )
    assert res.exit_code != 0 and "field-starts only" in res.output

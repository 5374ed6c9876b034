"""Issue 39: navigation's variants on every core. A recording's variants navigated on
threads (the next piece read on one more) give the same errors, bit for bit, as on one; so
does a scenario's; the command's outputs are the same files whatever ``--jobs``."""

from __future__ import annotations

import json
import threading

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.errors import ArgumentTypeError, ConfigError

runner = CliRunner()


@pytest.fixture(scope="module")
def recording(tmp_path_factory):  # type: ignore[no-untyped-def]
    """A 0.25 h quasi-static recording at 10 Hz (with its metadata) and two thermal models
    fitted on a short soak: three variants to navigate."""
    d = tmp_path_factory.mktemp("jobs")
    soak = d / "soak.parquet"
    res = runner.invoke(
        app, ["simulate", "soak", "--hours", "0.5", "--rate", "0.2", "--out", str(soak)]
    )
    assert res.exit_code == 0, res.output
    for method, name in (("regression", "reg"), ("poly-t", "polyt")):
        model = str(d / f"{name}.json")
        res = runner.invoke(app, ["fit", str(soak), "--method", method, "--out", model])
        assert res.exit_code == 0, res.output
    args = ["navigate", "--scenario", "quasi-static", "--hours", "0.25", "--rate", "10"]
    res = runner.invoke(
        app, [*args, "--no-oracle", "--out", str(d / "sim"), "--record", str(d / "run.parquet")]
    )
    assert res.exit_code == 0, res.output
    return d


def _run_threads(monkeypatch) -> list[str]:  # type: ignore[no-untyped-def]
    """Record the names of the threads that navigate a piece's variants."""
    import rinscal.nav.engine as engine

    seen: list[str] = []
    real = engine._advance

    def spy(*args, **kw):  # type: ignore[no-untyped-def]
        seen.append(threading.current_thread().name)
        return real(*args, **kw)

    monkeypatch.setattr(engine, "_advance", spy)
    return seen


def test_recorded_variants_on_threads_are_bit_identical_to_one(recording, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Many small pieces (read ahead on a thread), three variants on three threads: every
    error column and the alignment of every variant equal to the one-thread run's."""
    from rinscal.calibration.compensator import Compensator
    from rinscal.calibration.modelfile import FittedModel
    from rinscal.io.navopen import open_nav_log
    from rinscal.nav.recorded.blocks import BlockStats
    from rinscal.nav.recorded.navigate import Reference, navigate_recording
    from rinscal.nav.recorded.window import Noise, align_config, find_window

    log = open_nav_log(recording / "run.parquet")
    stats = BlockStats()
    for s in log.pieces(2000):
        stats.add(s)
    window = find_window(stats.finish(), 600.0)
    noise = Noise(log.noise["gyro_noise_density"], log.noise["accel_noise_density"])
    lat, lon, h = log.site

    def run(n_jobs: int):  # type: ignore[no-untyped-def]
        comps = {"none": None}
        for name in ("reg", "polyt"):  # fresh compensators: their history is their own
            comps[name] = Compensator(FittedModel.load(recording / f"{name}.json"))
        return navigate_recording(
            log.pieces(2000), Reference(lat, lon, h), window, align_config(noise, window),
            1.0 / log.rate_hz, comps, n_jobs=n_jobs,
        )  # fmt: skip

    seen = _run_threads(monkeypatch)
    one = run(1)
    assert set(seen) == {threading.current_thread().name}
    seen.clear()
    many = run(3)
    assert len(set(seen)) > 1  # the variants did run on threads
    assert list(one.errors) == list(many.errors) == ["none", "reg", "polyt"]
    for name in one.errors:
        pd.testing.assert_frame_equal(one.errors[name], many.errors[name], check_exact=True)
        a, b = one.alignment[name], many.alignment[name]
        assert np.array_equal(a.C_nr, b.C_nr) and np.array_equal(a.gyro_bias, b.gyro_bias)
    pd.testing.assert_frame_equal(one.truth, many.truth, check_exact=True)
    # the models did something: the variants differ from each other
    assert not one.errors["reg"]["horizontal_m"].equals(one.errors["none"]["horizontal_m"])


def test_scenario_variants_on_threads_are_bit_identical_to_one(recording) -> None:  # type: ignore[no-untyped-def]
    import rinscal

    kw = dict(hours=0.25, rate_hz=10.0, seed=2, models=[str(recording / "reg.json")])
    one = rinscal.navigate_scenario("quasi-static", n_jobs=1, **kw)
    many = rinscal.navigate_scenario("quasi-static", n_jobs=3, **kw)
    assert list(one.errors) == ["none", "true", "reg"]
    for name in one.errors:
        pd.testing.assert_frame_equal(one.errors[name], many.errors[name], check_exact=True)
    assert one.summary == many.summary


def test_navigate_jobs_gives_the_same_files(recording) -> None:  # type: ignore[no-untyped-def]
    """``navigate --log`` with two models: summary.json, errors.csv and truth.csv byte for
    byte the same with --jobs 1, -j 3 and the default (every core)."""
    d = recording
    base = ["navigate", "--log", str(d / "run.parquet"), "-m", str(d / "reg.json"),
            "-m", str(d / "polyt.json")]  # fmt: skip
    outs = {}
    for tag, extra in (("one", ["--jobs", "1"]), ("three", ["-j", "3"]), ("default", [])):
        res = runner.invoke(app, [*base, *extra, "--out", str(d / f"log_{tag}")])
        assert res.exit_code == 0, res.output
        outs[tag] = {n: (d / f"log_{tag}" / n).read_bytes()
                     for n in ("summary.json", "errors.csv", "truth.csv")}  # fmt: skip
    assert outs["one"] == outs["three"] == outs["default"]
    summary = json.loads(outs["one"]["summary.json"])
    assert list(summary["variants"]) == ["none", "reg", "polyt"]


def test_jobs_is_checked(recording) -> None:  # type: ignore[no-untyped-def]
    import rinscal

    res = runner.invoke(app, ["navigate", "--log", str(recording / "run.parquet"), "-j", "0",
                              "--out", str(recording / "x")])  # fmt: skip
    assert res.exit_code == 2 and "--jobs" in res.output
    with pytest.raises(ConfigError, match="n_jobs"):
        rinscal.navigate_log(recording / "run.parquet", n_jobs=-1)
    with pytest.raises(ArgumentTypeError, match="n_jobs"):
        rinscal.navigate_scenario("quasi-static", hours=0.2, rate_hz=10.0, n_jobs="2")


def test_a_drive_aligned_in_motion_and_aided_on_threads_is_bit_identical(
    recording, tmp_path
) -> None:  # type: ignore[no-untyped-def]
    """The in-motion alignment (which keeps the increments it is fed) and the GNSS-aided
    filter, three variants on three threads, the drive read ahead: the same errors as on
    one thread."""
    import rinscal
    from tests.cli._vehicle import record_vehicle

    rec = record_vehicle(tmp_path, 0.12)
    full = pd.read_parquet(rec)
    drive = tmp_path / "drive.parquet"
    full[full["time_s"] > 61.0].to_parquet(drive, index=False)
    (tmp_path / "drive.parquet.meta.json").write_text(
        (tmp_path / "veh.parquet.meta.json").read_text()
    )
    track = full.iloc[::5][["time_s", "ref_lat_deg", "ref_lon_deg", "ref_h_m"]]
    track.to_csv(tmp_path / "track.csv", index=False)
    models = [str(recording / "reg.json"), str(recording / "polyt.json")]
    for aiding in ("none", "gnss"):
        kw = dict(models=models, track=tmp_path / "track.csv", align_s=300.0, aiding=aiding)
        one = rinscal.navigate_log(drive, n_jobs=1, **kw)
        many = rinscal.navigate_log(drive, n_jobs=3, **kw)
        assert "in motion" in one.report["window"]["how"]
        assert list(one.errors) == ["none", "reg", "polyt"]
        for name in one.errors:
            pd.testing.assert_frame_equal(one.errors[name], many.errors[name], check_exact=True)
        assert one.summary == many.summary


@pytest.fixture(scope="module")
def ring_laser_models(tmp_path_factory):  # type: ignore[no-untyped-def]
    """Two thermal models of the ring-laser unit, fitted on its own soak: whole pulses of 0.1″
    and 125 µg·s per sample, a few counts each (the outputs are coarse, ties everywhere)."""
    from rinscal.io.metadata import write_meta
    from rinscal.io.tables import write_log
    from rinscal.sim.protocols import simulate_protocol

    d = tmp_path_factory.mktemp("rlg_models")
    log, _, meta = simulate_protocol("soak", hours=0.25, rate_hz=10.0, seed=3, imu="ring_laser")
    assert meta["units"]["gyro_x"] == "pulse"
    assert np.array_equal(log["gyro_x"], np.rint(log["gyro_x"]))  # whole counts
    soak = d / "soak.parquet"
    write_log(log, soak)
    write_meta(meta, soak)
    models = []
    for method, name in (("regression", "reg"), ("poly-t", "polyt")):
        out = d / f"{name}.json"
        res = runner.invoke(app, ["fit", str(soak), "--method", method, "--out", str(out)])
        assert res.exit_code == 0, res.output
        models.append(str(out))
    return models


@pytest.mark.parametrize("which", ["realistic_rlg", "realistic_rlg_1hz"])
def test_a_recording_like_the_real_one_gives_the_same_files_on_threads(
    which, ring_laser_models, request, tmp_path
) -> None:  # type: ignore[no-untyped-def]
    """What a real sensor puts out, not the simulator's clean default: integer counts of a
    dithered ring laser, people about the parked vehicle for its first 9 min, at 100 Hz and
    summed to 1 Hz; three variants read through the default options. ``navigate --log``
    with --jobs 1 and -j 3 writes the same summary.json, errors.csv and truth.csv, byte for
    byte, and the window is found after the disturbance it reports."""
    rec = request.getfixturevalue(which)
    assert rec.counts
    base = ["navigate", "--log", str(rec.path)]
    for m in ring_laser_models:
        base += ["-m", m]
    outs = {}
    for tag, extra in (("one", ["--jobs", "1"]), ("three", ["-j", "3"])):
        res = runner.invoke(app, [*base, *extra, "--out", str(tmp_path / tag)])
        assert res.exit_code == 0, res.output
        outs[tag] = {n: (tmp_path / tag / n).read_bytes()
                     for n in ("summary.json", "errors.csv", "truth.csv")}  # fmt: skip
    assert outs["one"] == outs["three"]
    summary = json.loads(outs["one"]["summary.json"])
    assert list(summary["variants"]) == ["none", "reg", "polyt"]
    window = summary["recording"]["window"]
    assert window["how"] == "found" and window["disturbed"]
    assert window["start_s"] >= window["disturbed"][-1]["end_s"] >= 0.9 * rec.disturbed[1]
    errors = pd.read_csv(tmp_path / "one" / "errors.csv")
    by = {v: g["horizontal_m"].to_numpy() for v, g in errors.groupby("variant")}
    assert not np.array_equal(by["none"], by["reg"])  # the models did correct something

"""`rinscal navigate --log` on a pulse-output recording: the filter's noise from the
window's Allan deviation, not from first differences.

A simulated quasi-static run is re-written as a ring-laser-like unit writes it: the
gyros' angle with 2.5″ of white angle noise (a dithered laser's) counted in 0.1″, the
accelerometers' velocity counted in 125 µg·s, the remainders carried; the metadata's noise
is dropped, so the noise must come from the recording. Measured (10 Hz, 0.2 h, seed 3):
first differences read the counts as 0.21 °/√h of angle random walk (300× the unit's
0.0007 °/√h) and the heading handed over is 30 000″ off; the Allan fit finds the 2.4″
white angle noise, bounds the random walk by 0.016 °/√h (the 60 s dwells reach τ = 29 s
only) and the heading is 4 100″ off (the true noise: −260″).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal import units
from rinscal.cli import app

runner = CliRunner()


def counted(x: np.ndarray, q: float) -> np.ndarray:
    c = np.floor(np.cumsum(x) / q)
    return np.diff(c, prepend=0.0) * q


@pytest.fixture(scope="module")
def ring_laser(tmp_path_factory) -> dict:  # type: ignore[no-untyped-def]
    d = tmp_path_factory.mktemp("rlg")
    run = d / "run.parquet"
    args = ["navigate", "--scenario", "quasi-static", "--hours", "0.2", "--rate", "10"]
    res = runner.invoke(
        app, [*args, "--seed", "3", "--no-oracle", "--out", str(d / "sim"), "--record", str(run)]
    )
    assert res.exit_code == 0, res.output
    rec = pd.read_parquet(run)
    meta = json.loads((d / "run.parquet.meta.json").read_text())
    rng = np.random.default_rng(1)
    dt = 0.1
    for c in ("gyro_x", "gyro_y", "gyro_z"):  # deg/h × s = arcsec
        angle = rec[c].to_numpy() * dt
        angle[0] += rng.normal(0.0, 2.5)
        angle[1:] += np.diff(rng.normal(0.0, 2.5, len(rec)))  # white angle noise
        rec[c] = counted(angle, 0.1) / dt
    for c in ("accel_x", "accel_y", "accel_z"):  # µg × s
        rec[c] = counted(rec[c].to_numpy() * dt, 125.0) / dt
    rec.to_parquet(d / "rlg.parquet")
    (d / "rlg.parquet.meta.json").write_text(
        json.dumps({k: v for k, v in meta.items() if k != "noise"})
    )
    res = runner.invoke(app, ["navigate", "--log", str(d / "rlg.parquet"), "--out", str(d / "o")])
    assert res.exit_code == 0, res.output
    return {"dir": d, "meta": meta, "output": res.output}


def _summary(folder) -> dict:  # type: ignore[no-untyped-def]
    return json.loads((folder / "summary.json").read_text())


def test_the_counts_are_white_angle_noise_and_the_random_walk_is_bounded(ring_laser) -> None:  # type: ignore[no-untyped-def]
    d, meta = ring_laser["dir"], ring_laser["meta"]
    noise = _summary(d / "o")["recording"]["noise"]
    assert noise["source"].startswith("estimated on the window (Allan, τ 1-")
    allan = noise["allan"]
    gyro = allan["gyro"]["terms"]
    # the 2.5″ of white angle noise (and the count's 0.03″) is found as such
    assert gyro["q"]["resolved"] and gyro["q"]["value"] == pytest.approx(2.5, rel=0.1)
    assert noise["gyro_angle_white_arcsec"] == pytest.approx(gyro["q"]["value"])
    # the random walk: the unit's 0.0007 °/√h lies under the bound the filter gets
    true_arw = meta["noise"]["gyro_noise_density"] / units.DPRH_TO_RPRS
    assert not gyro["n"]["resolved"] and allan["filter"]["gyro_n"].startswith("bound at τ")
    assert noise["gyro_arw_deg_per_rth"] == pytest.approx(gyro["n"]["bound"], rel=1e-12)
    assert gyro["n"]["bound"] >= true_arw
    # ... and far under the first differences', which take the counts for a random walk
    first = allan["first_differences"]
    assert first["gyro_arw_deg_per_rth"] > 5 * noise["gyro_arw_deg_per_rth"]
    # the accelerometers' velocity counts: Q = 125 µg·s/√12 = 0.35 mm/s, and their VRW
    acc = allan["accel"]["terms"]
    # (resolved or not, its value enters the velocity measurement's sd)
    assert acc["q"]["value"] == pytest.approx(0.354, rel=0.3)
    true_vrw = meta["noise"]["accel_noise_density"] / units.UG_TO_MPS2
    assert 1 / 1.5 <= noise["accel_vrw_ug_per_rthz"] / true_vrw <= 1.5
    # the counts enter the zero-velocity measurement, above the filter's 1 mm/s
    assert 1.0 < noise["velocity_meas_sd_mm_per_s"] < 1.2
    # the console says what was found, on which τ, and what the filter used
    out = " ".join(ring_laser["output"].split())
    assert "noise from the window's Allan deviation" in out
    assert "gyro on τ 1-" in out and "(bound at τ =" in out and "filter: ARW" in out


def test_the_heading_is_better_than_with_the_first_difference_noise(ring_laser) -> None:  # type: ignore[no-untyped-def]
    """Today's estimate, given through the metadata: the heading 5× worse."""
    d, meta = ring_laser["dir"], ring_laser["meta"]
    s = _summary(d / "o")
    first = s["recording"]["noise"]["allan"]["first_differences"]
    old = dict(meta)
    old["noise"] = {
        "gyro_noise_density": first["gyro_arw_deg_per_rth"] * units.DPRH_TO_RPRS,
        "accel_noise_density": first["accel_vrw_ug_per_rthz"] * units.UG_TO_MPS2,
    }
    rec = pd.read_parquet(d / "rlg.parquet")
    rec.to_parquet(d / "old.parquet")
    (d / "old.parquet.meta.json").write_text(json.dumps(old))
    res = runner.invoke(app, ["navigate", "--log", str(d / "old.parquet"), "--out", str(d / "o2")])
    assert res.exit_code == 0, res.output

    def heading(folder) -> float:  # type: ignore[no-untyped-def]
        v = _summary(folder)["variants"]["none"]
        return abs(v["attitude_error_at_nav_start"]["heading_arcsec"])

    assert heading(d / "o2") > 3.0 * heading(d / "o")


def test_the_metadata_gives_the_white_angle_and_velocity_noise_too(ring_laser) -> None:  # type: ignore[no-untyped-def]
    d, meta = ring_laser["dir"], ring_laser["meta"]
    rec = pd.read_parquet(d / "rlg.parquet")
    q_th, q_v = 2.5 * units.ARCSEC_TO_RAD, 125.0 * units.UG_TO_MPS2 / np.sqrt(12.0)
    given = {
        **meta,
        "noise": {**meta["noise"], "gyro_angle_noise": q_th, "accel_velocity_noise": q_v},
    }
    rec.to_parquet(d / "given.parquet")
    (d / "given.parquet.meta.json").write_text(json.dumps(given))
    res = runner.invoke(
        app, ["navigate", "--log", str(d / "given.parquet"), "--out", str(d / "o3")]
    )
    assert res.exit_code == 0, res.output
    noise = _summary(d / "o3")["recording"]["noise"]
    assert noise["source"] == "metadata of the log"
    want = np.sqrt(1e-6 + q_v**2 + (9.80665 * q_th * 0.5) ** 2) * 1e3
    assert noise["velocity_meas_sd_mm_per_s"] == pytest.approx(want)
    assert noise["gyro_angle_white_arcsec"] == pytest.approx(2.5)
    bad = {**meta, "noise": {**meta["noise"], "accel_velocity_noise": -1.0}}
    (d / "given.parquet.meta.json").write_text(json.dumps(bad))
    res = runner.invoke(
        app, ["navigate", "--log", str(d / "given.parquet"), "--out", str(d / "o4")]
    )
    assert res.exit_code != 0 and "noise.accel_velocity_noise: -1.0 is negative" in res.output
    assert not (d / "o4").exists()

"""Motion that quantisation cannot hide (issue 35, items 2-4): a parked vehicle's recording in
coarse counts (0.1″ and 125 µg·s at 100 Hz, the remainder carried as hardware does), people
moving about it for the first 9 minutes (a sway of a few arc-minutes at 1-3 Hz and tilt
steps), then quiet. The window is found after the disturbance, the disturbance is reported
with its interval, peak and tilt steps; the checks at rest raise no false warning; a 1 Hz
recording is judged at its own rate."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal import earth, units
from rinscal.cli import app
from rinscal.errors import LogError
from rinscal.nav.recorded.blocks import BlockStats
from rinscal.nav.recorded.window import (
    check_at_rest,
    check_never_at_rest,
    find_window,
    motion,
    robust_limit,
)
from rinscal.schema import NavSamples

runner = CliRunner()
LAT = math.radians(34.75)
RATE = 100.0
GYRO_COUNT = units.ARCSEC_TO_RAD * 0.1  # rad
ACCEL_COUNT = 125e-6 * 9.80665  # m/s (125 µg·s)
DISTURBED_S = 540.0
TILT_AT = (130.0, 300.0, 470.0, DISTURBED_S)  # tilt steps [s], the last ends the disturbance


def _counts(x: np.ndarray, q: float) -> np.ndarray:
    """Integer counts of weight ``q`` of increments ``x`` (per axis), the remainder carried:
    the sum of the counts over any k samples is the true sum to one count."""
    return np.diff(np.floor(np.cumsum(x, axis=0) / q), axis=0, prepend=0.0)


def parked_vehicle(
    seconds: float = 1000.0,
    rate: float = RATE,
    disturbed_s: float = DISTURBED_S,
    seed: int = 0,
    wander_arcsec: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times [s] and increments (dθ [rad], dv [m/s], in counts × weight) of a level IMU on a
    parked vehicle facing north, x east, y north, z up.

    Gyros: white angle noise of 2.5″ a sample (σ ≈ 4 °/h in 1 s), a random walk of
    0.005 °/√h; accelerometers 50 µg/√Hz. Before ``disturbed_s``: a sway of 2-4 arc-minutes
    at 1.3, 2.1 and 2.9 Hz about x and y that comes and goes (people climbing in and out),
    with the lever arm of an IMU 1 m above the roll centre, until 20 s before, and tilt steps
    of 60-120″ at :data:`TILT_AT` (smoothed over 0.3 s).
    """
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    n = round(seconds * rate)
    t = np.arange(1, n + 1) * dt  # sample ends
    te = np.concatenate([[0.0], t])  # sample edges
    # attitude disturbance: small angles about x and y [rad], at the sample edges
    ang = np.zeros((te.size, 2))
    acc = np.zeros((te.size, 2))  # its second derivative [rad/s²]
    busy = te < disturbed_s - 20.0  # the last people leave; a door shuts at disturbed_s
    gate = 0.5 * (1 + np.sin(2 * np.pi * te / 97.0)) * busy  # comes and goes
    for j in range(2):
        for fr, amp in ((1.3, 4.0), (2.1, 3.0), (2.9, 2.0)):
            a = amp / 60 * units.DEG_TO_RAD * rng.uniform(0.5, 1.0)
            ph = rng.uniform(0, 2 * np.pi)
            w = 2 * np.pi * fr
            ang[:, j] += gate * a * np.sin(w * te + ph)
            acc[:, j] -= gate * a * w * w * np.sin(w * te + ph)
    for k, at in enumerate(a for a in TILT_AT if a <= disturbed_s):
        x = np.clip((te - at) / 0.3, 0.0, 1.0)
        step = (60.0 + 60.0 * rng.uniform()) * units.ARCSEC_TO_RAD
        ang[:, k % 2] += step * x * x * (3 - 2 * x)
    if wander_arcsec:
        knots = np.arange(0.0, seconds + 2.0)
        walk = np.cumsum(rng.normal(0, wander_arcsec * units.ARCSEC_TO_RAD, (knots.size, 2)), 0)
        for j in range(2):
            ang[:, j] += np.interp(te, knots, walk[:, j])
    # rates: the Earth's (x east, y north, z up) plus the disturbance's turn
    w_e = earth.RATE * np.array([0.0, math.cos(LAT), math.sin(LAT)])
    dth = np.tile(w_e * dt, (n, 1))
    dth[:, :2] += np.diff(ang, axis=0)
    noise = rng.normal(0, 2.5 * units.ARCSEC_TO_RAD, (n + 1, 3))
    dth += np.diff(noise, axis=0)  # white angle noise
    dth += rng.normal(0, 0.005 * units.DEG_TO_RAD / 60 * math.sqrt(dt), (n, 3))
    # specific force: gravity seen tilted, plus the lever arm's acceleration (1 m up)
    g = float(earth.gravity(LAT, 0.0))
    mid = 0.5 * (ang[1:] + ang[:-1])
    amid = 0.5 * (acc[1:] + acc[:-1])
    f = np.zeros((n, 3))
    f[:, 0] = g * mid[:, 1] + amid[:, 1]  # a tilt about y turns gravity into +x
    f[:, 1] = -g * mid[:, 0] - amid[:, 0]
    f[:, 2] = g
    dv = f * dt + rng.normal(0, 50e-6 * 9.80665 * math.sqrt(dt), (n, 3))
    return t, _counts(dth, GYRO_COUNT) * GYRO_COUNT, _counts(dv, ACCEL_COUNT) * ACCEL_COUNT


def _blocks(t: np.ndarray, dth: np.ndarray, dv: np.ndarray, piece: int = 7001):
    st = BlockStats()
    for a in range(0, t.size, piece):
        s = slice(a, a + piece)
        dt = np.diff(np.concatenate([[t[0] - (t[1] - t[0])], t]))[s]
        st.add(NavSamples(t[s], dt, dth[s], dv[s]))
    return st.finish()


def _write(path: Path, t: np.ndarray, dth: np.ndarray, dv: np.ndarray, noise: bool) -> Path:
    """The recording as rates in the default units (deg/h, µg) with its metadata."""
    dt = np.diff(np.concatenate([[0.0], t]))
    frame = {"time_s": t}
    for j, ax in enumerate("xyz"):
        frame[f"gyro_{ax}"] = dth[:, j] / dt / units.DPH_TO_RPS
    for j, ax in enumerate("xyz"):
        frame[f"accel_{ax}"] = dv[:, j] / dt / units.UG_TO_MPS2
    pd.DataFrame(frame).to_parquet(path)
    meta: dict = {
        "kind": "navigation recording",
        "rate_hz": 1.0 / float(np.median(dt)),
        "site": {"lat_deg": math.degrees(LAT), "lon_deg": 118.78, "h_m": 0.0},
    }
    if noise:  # the truth: 0.005 °/√h, 50 µg/√Hz
        meta["noise"] = {
            "gyro_noise_density": 0.005 * units.DEG_TO_RAD / 60,
            "accel_noise_density": 50 * units.UG_TO_MPS2,
        }
    Path(f"{path}.meta.json").write_text(json.dumps(meta))
    return path


@pytest.fixture(scope="module")
def vehicle():  # type: ignore[no-untyped-def]
    return parked_vehicle()


def test_quantisation_hides_nothing_the_window_starts_after_the_disturbance(vehicle) -> None:  # type: ignore[no-untyped-def]
    t, dth, dv = vehicle
    blocks = _blocks(t, dth, dv)
    # the |f| spread within a second is all quantisation: as large disturbed as quiet
    quiet_sd = np.median(blocks.fmag_sd[t[:: int(RATE)] > 600][:100])
    assert quiet_sd > 5e-3  # several mg: one count is 12.5 mg in 10 ms
    win = find_window(blocks, 300.0)
    assert win.how == "found" and DISTURBED_S <= win.start_s <= DISTURBED_S + 10
    assert win.quality["quiet_fraction"] == 1.0
    # what moved and where: one stretch up to the last tilt step, its peak rate far above
    # the quiet gyros (some °/h), and the tilt steps the accelerometers saw
    (d,) = [d for d in win.disturbed if d.end_s > 100]
    assert d.start_s <= 5.0 and DISTURBED_S - 2 <= d.end_s <= DISTURBED_S + 10
    assert d.gyro_peak_dph > 300.0
    assert win.limits["gyro_step_xy_dph"] < 60.0  # set by the quiet seconds, not the sway
    steps = [ts for ts, _ in d.tilt_steps]
    assert any(abs(ts - DISTURBED_S) <= 2 for ts in steps)
    assert all(30.0 < a < 250.0 for _, a in d.tilt_steps)  # 60-120″ steps (and sway)
    assert "0-" in d.text() and "disturbed: gyro peaks" in d.text() and "tilt step" in d.text()
    assert win.text().endswith(f"window {win.start_s:.0f}-{win.end_s:.0f} s")


def test_the_rate_at_rest_is_a_mean_not_a_median_of_magnitudes(vehicle) -> None:  # type: ignore[no-untyped-def]
    t, dth, dv = vehicle
    blocks = _blocks(t, dth, dv)
    win = find_window(blocks, 400.0, start_s=560.0)
    vals, warn = check_at_rest(blocks, win, LAT, 0.0)
    assert not warn, warn
    # 4 °/h of noise a second on each axis: a median over the quietest quarter of seconds
    # reads |ω| 10 % low; the window's mean is within 1 % and the latitude within 0.3°
    assert vals["omega_dph"] == pytest.approx(earth.RATE / units.DPH_TO_RPS, rel=0.01)
    assert vals["latitude_measured_deg"] == pytest.approx(34.75, abs=0.3)


def test_never_at_rest_is_judged_where_quantisation_has_averaged_out() -> None:
    # quiet all through, the true noise told: the 1 s scatter is the counts' (2-3 × the
    # 50 µg of white noise), which averages out as 1/τ: no warning
    t, dth, dv = parked_vehicle(seconds=400.0, disturbed_s=0.0)
    blocks = _blocks(t, dth, dv)
    assert find_window(blocks, 300.0).start_s <= 3.0  # a level IMU's counts: all quiet
    win = find_window(blocks, 300.0, start_s=50.0)
    info, warn = check_never_at_rest(blocks, win, 50 * units.UG_TO_MPS2, "metadata")
    assert not warn and info["adev_1s_ug"] > 1.5 * 50.0
    assert info["adev_tau_ug"] == pytest.approx(50 / math.sqrt(10), rel=0.5)
    # a tilt wandering by 10″ per √s (people leaning on it all the time): warned
    t, dth, dv = parked_vehicle(seconds=400.0, disturbed_s=0.0, wander_arcsec=10.0)
    blocks = _blocks(t, dth, dv)
    info, warn = check_never_at_rest(blocks, win, 50 * units.UG_TO_MPS2, "metadata")
    assert len(warn) == 1 and "may never have been at rest" in warn[0]
    assert "metadata" in warn[0] and info["adev_tau_ug"] > 3 * info["expected_tau_ug"]


def test_a_robust_limit_is_set_by_the_quiet_part() -> None:
    rng = np.random.default_rng(2)
    quiet = np.abs(rng.normal(0, 1.0, 700))
    loud = 50 + 100 * rng.random(300)  # 30 % disturbed
    c, s, lim = robust_limit(np.concatenate([loud, quiet]))
    assert 0.5 < c < 0.9 and 0.4 < s < 1.0 and 3.0 < lim < 8.0
    assert robust_limit(np.zeros(10), floor=1e-3)[2] == 1e-3  # no step at all: the floor
    # steps of a coarse count: mostly 0, else a count or two (125): 4 counts is the limit
    counts = np.where(rng.random(1000) < 0.6, 0.0, 125.0 * rng.integers(1, 3, 1000))
    assert robust_limit(counts, floor=10.0)[2] == pytest.approx(500.0)


def test_the_cli_finds_and_reports_the_disturbance_without_false_warnings(
    tmp_path: Path,
    vehicle,  # type: ignore[no-untyped-def]
) -> None:
    t, dth, dv = vehicle
    log = _write(tmp_path / "parked.parquet", t, dth, dv, noise=True)
    res = runner.invoke(
        app, ["navigate", "--log", str(log), "--align-s", "300", "--out", str(tmp_path / "o")]
    )
    assert res.exit_code == 0, res.output
    rec = json.loads((tmp_path / "o" / "summary.json").read_text())["recording"]
    w = rec["window"]
    assert w["how"] == "found" and w["start_s"] >= DISTURBED_S
    (d,) = [d for d in w["disturbed"] if d["end_s"] > 100]
    assert d["start_s"] <= 5 and d["end_s"] >= DISTURBED_S - 2 and d["gyro_peak_dph"] > 300
    assert any(abs(s["time_s"] - DISTURBED_S) <= 2 for s in d["tilt_steps"])
    out = " ".join(res.output.split())
    assert f"0-{d['end_s']:.0f} s disturbed: gyro peaks" in out
    # a correct site and the true noise: no latitude, no "never at rest"
    assert not any("latitude" in x or "never" in x for x in rec["warnings"]), rec["warnings"]
    assert rec["at_rest"]["latitude_measured_deg"] == pytest.approx(34.75, abs=0.3)
    # nor with a preset's noise (a navigation-grade unit's, finer than this one's)
    res = runner.invoke(
        app,
        ["navigate", "--log", str(log), "--align-s", "300", "--imu", "navigation_grade",
         "--out", str(tmp_path / "p")],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    rec = json.loads((tmp_path / "p" / "summary.json").read_text())["recording"]
    assert not any("latitude" in x or "never" in x for x in rec["warnings"]), rec["warnings"]


def test_a_turntable_without_its_encoder_is_checked_at_rest_dwell_by_dwell(
    tmp_path: Path,
) -> None:
    run = tmp_path / "table.parquet"
    res = runner.invoke(
        app,
        ["navigate", "--scenario", "quasi-static", "--hours", "0.25", "--rate", "10",
         "--no-oracle", "--out", str(tmp_path / "sim"), "--record", str(run)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    bare = tmp_path / "bare.parquet"
    pd.read_parquet(run).drop(columns=["table_deg"]).to_parquet(bare)
    Path(f"{bare}.meta.json").write_text(Path(f"{run}.meta.json").read_text())
    res = runner.invoke(app, ["navigate", "--log", str(bare), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    at_rest = json.loads((tmp_path / "o" / "summary.json").read_text())["recording"]["at_rest"]
    # the four positions' dwells, each its own mean: the Earth rate and the site's latitude
    assert at_rest["omega_checked"] and at_rest["dwells"] >= 4
    assert at_rest["omega_over_earth_rate"] == pytest.approx(1.0, abs=0.02)
    assert at_rest["latitude_measured_deg"] == pytest.approx(32.06, abs=0.5)


def test_a_one_hertz_recording_is_judged_at_its_own_rate(tmp_path: Path) -> None:
    run = tmp_path / "run1hz.parquet"
    res = runner.invoke(
        app,
        [
            "navigate",
            "--scenario",
            "quasi-static",
            "--hours",
            "0.25",
            "--rate",
            "1",
            "--no-oracle",
            "--out",
            str(tmp_path / "sim"),
            "--record",
            str(run),
        ],
    )
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["navigate", "--log", str(run), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output  # was: "longest quiet stretch 1 s ... floor of 0 µg"
    rec = json.loads((tmp_path / "o" / "summary.json").read_text())["recording"]
    assert rec["window"]["how"] == "found" and rec["window"]["start_s"] == pytest.approx(0, abs=1)
    assert not any("latitude" in x or "never" in x for x in rec["warnings"]), rec["warnings"]
    # moving all through (a sway at 1 Hz sampling): refused, naming the rate
    rec_df = pd.read_parquet(run)
    rng = np.random.default_rng(4)
    for c in ("accel_x", "accel_y"):
        rec_df[c] += rng.normal(0, 5000.0, len(rec_df)) * (rng.random(len(rec_df)) < 0.3)
    rec_df.to_parquet(tmp_path / "moving.parquet")
    (tmp_path / "moving.parquet.meta.json").write_text(Path(f"{run}.meta.json").read_text())
    res = runner.invoke(
        app, ["navigate", "--log", str(tmp_path / "moving.parquet"), "--out", str(tmp_path / "m")]
    )
    assert res.exit_code != 0
    assert "no static window" in res.output and "at 1 Hz" in " ".join(res.output.split())


def test_a_low_rate_motion_judgement_needs_no_spread_within_a_second(vehicle) -> None:  # type: ignore[no-untyped-def]
    t, dth, dv = vehicle
    # the same recording summed to 2 Hz (a sum of counts is still exact to one count)
    k = 50
    m = t.size // k
    t2 = t[k - 1 :: k][:m]
    d2 = dth[: m * k].reshape(m, k, 3).sum(1)
    v2 = dv[: m * k].reshape(m, k, 3).sum(1)
    blocks = _blocks(t2, d2, v2, piece=333)
    mot = motion(blocks)
    assert math.isnan(mot.threshold)  # no spread judged in 2 samples
    win = find_window(blocks, 300.0)
    assert DISTURBED_S - 5 <= win.start_s <= DISTURBED_S + 10
    # cut at 700 s: under 200 s of quiet, refused, naming the rate it was judged at
    with pytest.raises(LogError, match=r"longest quiet stretch is 1\d\d s.*at 2 Hz"):
        find_window(_blocks(t2[:1400], d2[:1400], v2[:1400]), 300.0)

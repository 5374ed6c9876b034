"""`rinscal navigate --log` says what the recording is before it judges anything on it: a
drive is named as moving (by its GGA track, or by its own specific force), never "quiet" nor
"wrong gyro units"; a parked start before a drive is aligned on; a chamber or turntable
calibration log is named and pointed at `fit` or `calibrate-imu`; a 1 Hz recording's
refusal names its rate and a window set by hand at 1 Hz is not called disturbed."""

from __future__ import annotations

import json
import math
from functools import reduce
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal import earth, units
from rinscal.cli import app
from rinscal.nav.recorded.blocks import Blocks
from rinscal.nav.recorded.kind import motion, moving_message
from tests.cli._vehicle import record_vehicle

runner = CliRunner()
UTC_START = "2026-11-20T08:14:03Z"


def _nmea(body: str) -> str:
    return f"${body}*{reduce(lambda x, c: x ^ ord(c), body, 0):02X}"


def _gga(t_s: float, lat_deg: float, lon_deg: float, h_m: float) -> str:
    """A GGA sentence at ``t_s`` after :data:`UTC_START` (08:14:03)."""
    tod = 8 * 3600 + 14 * 60 + 3 + t_s
    hh, mm, ss = int(tod // 3600), int(tod % 3600 // 60), tod % 60
    la, lo = abs(lat_deg), abs(lon_deg)
    lat = f"{int(la):02d}{(la - int(la)) * 60:09.6f}"
    lon = f"{int(lo):03d}{(lo - int(lo)) * 60:09.6f}"
    ns, ew = ("N" if lat_deg >= 0 else "S"), ("E" if lon_deg >= 0 else "W")
    return _nmea(
        f"GPGGA,{hh:02d}{mm:02d}{ss:05.2f},{lat},{ns},{lon},{ew},1,08,0.9,{h_m:.2f},M,0.0,M,,"
    )


def _run(*args: object) -> tuple[int, str]:
    res = runner.invoke(app, [str(a) for a in args])
    return res.exit_code, res.output


@pytest.fixture(scope="module")
def vehicle(tmp_path_factory) -> dict[str, Path]:  # type: ignore[no-untyped-def]
    """The vehicle scenario recorded at 5 Hz: 60 s parked, then 4 min of driving (a 90° turn
    at 230 s); and the
    drive alone (the log from 61 s, no reference columns) with its track as NMEA GGA."""
    d = tmp_path_factory.mktemp("veh")
    rec = record_vehicle(d, 0.07)
    df = pd.read_parquet(rec)
    drive = df[df["time_s"] > 61.0]
    lines = [
        _gga(t, la, lo, h)
        for t, la, lo, h in drive[["time_s", "ref_lat_deg", "ref_lon_deg", "ref_h_m"]]
        .iloc[::5]
        .itertuples(index=False)
    ]
    (d / "drive.nmea").write_text("\n".join(lines) + "\n")
    ref = ["ref_lat_deg", "ref_lon_deg", "ref_h_m", "ref_heading_deg"]
    drive.drop(columns=ref).to_parquet(d / "drive.parquet", index=False)
    meta = json.loads(Path(f"{rec}.meta.json").read_text())
    Path(d / "drive.parquet.meta.json").write_text(json.dumps(meta))
    return {"dir": d, "rec": rec, "drive": d / "drive.parquet", "nmea": d / "drive.nmea"}


def test_a_drive_with_a_gga_track_is_named_moving_not_quiet(vehicle, tmp_path) -> None:  # type: ignore[no-untyped-def]
    track = ["--track", vehicle["nmea"], "--track-utc-start", UTC_START]
    # found: before, the finder called the drive 100 % quiet and navigated it; then it was
    # refused as moving; now, with its track and no still stretch, it is aligned in motion
    code, text = _run("navigate", "--log", vehicle["drive"], *track, "--align-s", "60",
                      "--out", tmp_path / "a")  # fmt: skip
    assert code == 0, text
    assert "recording: moving (track speed" in text
    speed = [float(v) for v in text.split("track speed ")[1].split(" m/s")[0].split("-")]
    assert 12 <= speed[-1] <= 21  # the route drives at 12, then 20 m/s
    yaw = float(text.split("yaw rates up to ")[1].split(" °/s")[0])
    assert 12 <= yaw <= 17  # 90° in 12 s (the table's own turn removed)
    assert "aligned in motion on the track" in text
    rec = json.loads((tmp_path / "a" / "summary.json").read_text())["recording"]
    assert rec["recording_kind"]["kind"] == "moving"
    assert (
        rec["alignment"] == "in motion (OBA + GNSS, 60 s)" and rec["window"]["how"] == "in motion"
    )
    assert "wrong gyro units" not in text and "Traceback" not in text
    # without a track file, a moving recording with no still stretch is refused, naming it
    said = moving_message("track speed 12-20 m/s", (0.0, 0.0), 60.0)
    assert "the alignment needs the vehicle at rest" in said
    assert "stop for 5-10 min for the alignment" in said
    assert "give its reference track file (track=) to align it in motion" in said
    # a window set by hand on the drive: moving, not a unit
    code, text = _run("navigate", "--log", vehicle["drive"], *track, "--align-start-s", "70",
                      "--align-s", "60", "--out", tmp_path / "b")  # fmt: skip
    assert code == 2 and "moves (track speed" in text and "wrong gyro units" not in text
    # no track: the accelerometers alone see the drive where it accelerates, climbs or
    # brakes (a steady straight drive is rest to an IMU): named as moving in part
    code, text = _run("navigate", "--log", vehicle["drive"], "--align-s", "60",
                      "--out", tmp_path / "c")  # fmt: skip
    kind = json.loads((tmp_path / "c" / "summary.json").read_text())["recording"]
    kind = kind["recording_kind"]
    assert code == 0 and kind["kind"] == "at rest, moving in part", text
    assert kind["evidence"]["force_mps2_max"] > 0.5 and "track_speed_mps" not in kind["evidence"]
    assert "specific force across gravity up to" in text


def test_a_parked_start_is_aligned_on_and_a_moving_window_set_by_hand_refused(
    vehicle, tmp_path
) -> None:  # type: ignore[no-untyped-def]
    code, text = _run("navigate", "--log", vehicle["rec"], "--align-s", "60",
                      "--out", tmp_path / "a")  # fmt: skip
    assert code == 0, text
    assert "recording: at rest 0-" in text and "moving" in text
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    kind = summary["recording"]["recording_kind"]
    assert kind["kind"] == "at rest, moving in part"
    ev = kind["evidence"]
    assert 58 <= ev["longest_still_s"] <= 66 and ev["longest_still_from_s"] < 1
    assert 60 <= ev["from_s"] <= 66  # the drive starts at 60 s (the track's own columns)
    assert 12 <= ev["track_speed_mps"][1] <= 21
    assert 12 <= ev["yaw_dps_max"] <= 17
    assert summary["recording"]["window"]["start_s"] < 1
    code, text = _run("navigate", "--log", vehicle["rec"], "--align-start-s", "100",
                      "--align-s", "60", "--out", tmp_path / "b")  # fmt: skip
    assert code == 2
    assert "the alignment window set by hand (100-160 s) moves (track speed" in text
    assert "the longest still stretch is" in text and "from 0 s" in text
    assert "wrong gyro units" not in text


def test_a_parked_recording_is_at_rest_and_a_1_hz_one_names_its_rate(tmp_path) -> None:  # type: ignore[no-untyped-def]
    rec = tmp_path / "q1.parquet"
    code, text = _run("navigate", "--scenario", "quasi-static", "--hours", "0.2", "--rate", "1",
                      "--align-s", "300", "--no-oracle", "--out", tmp_path / "sim",
                      "--record", rec)  # fmt: skip
    assert code == 0, text
    code, text = _run("navigate", "--log", rec, "--align-start-s", "0", "--align-s", "300",
                      "--out", tmp_path / "a")  # fmt: skip
    assert code == 0, text
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["recording"]["recording_kind"]["kind"] == "at rest"
    assert summary["recording"]["recording_kind"]["rate_hz"] == pytest.approx(1.0)
    assert "recording: at rest" in text
    # one sample a second has no spread of |f|: not "0 % quiet: the base moved"
    assert "the base moved" not in text and not summary["recording"]["warnings"]
    # with default options the finder judges the window at 1 Hz and it navigates
    code, text = _run("navigate", "--log", rec, "--out", tmp_path / "b")
    assert code == 0, text
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert summary["recording"]["window"]["how"] == "found"
    assert summary["variants"]["none"]["max_error_nmi"] < 0.1


@pytest.fixture(scope="module")
def soak(tmp_path_factory) -> Path:  # type: ignore[no-untyped-def]
    d = tmp_path_factory.mktemp("soak")
    code, text = _run("simulate", "soak", "--hours", "0.05", "--rate", "1", "--out",
                      d / "soak.parquet")  # fmt: skip
    assert code == 0, text
    return d / "soak.parquet"


def test_a_chamber_calibration_log_is_named_and_pointed_at_fit(soak, tmp_path) -> None:  # type: ignore[no-untyped-def]
    code, text = _run("navigate", "--log", soak, "--out", tmp_path / "a")
    assert code == 2, text
    assert "is a thermal calibration log (7 run(s) 'soak_+00C'" in text
    assert "metadata protocol 'soak'" in text and "1 Hz" in text
    assert f"rinscal fit {soak} --out M.json" in text
    assert "where was it recorded" not in text and "Traceback" not in text
    # one of its runs chosen: navigated as a static recording at its metadata's site, and
    # what refuses it names the rate and what it is
    code, text = _run("navigate", "--log", soak, "--run", "soak_+00C", "--out", tmp_path / "b")
    assert code == 2
    assert "where was it recorded" not in text
    assert "(1 Hz, calibration log run)" in text
    # the same log as CSV (its runs read from the text)
    csv = tmp_path / "soak.csv"
    pd.read_parquet(soak).to_csv(csv, index=False)
    Path(f"{csv}.meta.json").write_text(Path(f"{soak}.meta.json").read_text())
    code, text = _run("navigate", "--log", csv, "--out", tmp_path / "c")
    assert code == 2 and "is a thermal calibration log (7 run(s)" in text
    # by its columns alone: several runs and an outer temperature, no encoder, no metadata
    bare = tmp_path / "bare.parquet"
    pd.read_parquet(soak).drop(columns=["chamber_temp"]).to_parquet(bare, index=False)
    code, text = _run("navigate", "--log", bare, "--site", "32,118,10", "--out", tmp_path / "d")
    assert code == 2 and "is a thermal calibration log (7 run(s)" in text
    assert "columns temp_out" in text and "protocol" not in text
    # a navigation recording of several runs with temp_out and an encoder is not one
    nav = tmp_path / "nav.parquet"
    pd.read_parquet(soak).drop(columns=["chamber_temp"]).assign(table_deg=0.0).to_parquet(nav)
    code, text = _run("navigate", "--log", nav, "--site", "32,118,10", "--out", tmp_path / "e")
    assert code == 2 and "calibration log" not in text and "choose one with --run" in text


def test_a_multiposition_turntable_log_is_pointed_at_calibrate_imu(tmp_path) -> None:  # type: ignore[no-untyped-def]
    log = tmp_path / "mp.parquet"
    code, text = _run("simulate", "multiposition", "--out", log, "--sequence", "12",
                      "--set-points", "20,30", "--dwell", "2", "--rate", "10",
                      "--rates", "10")  # fmt: skip
    assert code == 0, text
    for run in ([], ["--run", "cal_+20C"]):
        code, text = _run("navigate", "--log", log, *run, "--out", tmp_path / "a")
        assert code == 2, text
        assert "is a turntable calibration log (2 run(s)" in text
        assert "table_outer_deg, table_inner_deg" in text
        assert f"rinscal calibrate-imu {log} --out imu.json" in text
        assert "pulse" not in text  # before: its units in pulses were what it was told


# --------------------------------------------------------------------------- the evidence
def _blocks(w: np.ndarray, f: np.ndarray) -> Blocks:
    m = w.shape[0]
    t = np.arange(m, dtype=float)
    z = np.zeros(m)
    return Blocks(
        t0=t, t1=t + 1.0, n=np.full(m, 100.0), fmag_mean=np.linalg.norm(f, axis=1),
        fmag_sd=np.full(m, 1e-3), f_mean=f, w_mean=w, f_dvar=np.zeros((m, 3)),
        w_dvar=np.zeros((m, 3)), table_turn=z, dt=0.01, has_table=False,
    )  # fmt: skip


def _parked(m: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A parked vehicle with people about it for the first 9 minutes: sway of 0.2 °/s
    peaks, tilt steps of a few arc-minutes, the Earth rate at 32° N."""
    lat = math.radians(32.0)
    w = np.tile([0.0, earth.RATE * math.cos(lat), earth.RATE * math.sin(lat)], (m, 1))
    w[:540, :2] += 0.2 * units.DEG_TO_RAD * np.sin(np.arange(540) * 1.3)[:, None]
    w += rng.normal(0, 3 * units.DPH_TO_RPS, (m, 3))
    tilt = np.zeros((m, 2))
    for k in range(0, 540, 60):
        tilt[k:] += rng.normal(0, 3 / 60 * units.DEG_TO_RAD, 2)
    g = 9.79
    f = np.column_stack([g * tilt[:, 0], g * tilt[:, 1], np.full(m, g)])
    return w, f + rng.normal(0, 50 * units.UG_TO_MPS2, (m, 3))


def test_a_parked_vehicle_with_people_about_it_is_never_called_moving() -> None:
    rng = np.random.default_rng(1)
    w, f = _parked(1800, rng)
    mo = motion(_blocks(w, f))
    assert not mo.moving.any()
    # the same in a wrong gyro unit (deg/h read as rad/s): no motion, the units check speaks
    mo = motion(_blocks(w / units.DPH_TO_RPS, f))
    assert not mo.moving.any()
    # a car turning: 15 °/s of yaw for 6 s at 12 m/s, 3 m/s² of centripetal force
    w2, f2 = w.copy(), f.copy()
    w2[1000:1006, 2] += 15 * units.DEG_TO_RAD
    f2[1000:1006, 0] += 12 * 15 * units.DEG_TO_RAD
    mo = motion(_blocks(w2, f2))
    assert mo.moving.sum() == 6 and mo.sustained and mo.by_force[1000:1006].all()

"""PX4 ULog and ArduPilot DataFlash logs in: reading, instances, corrections, device ids.

Two kinds of evidence:

* the real PX4 log in ``tests/data/real/ulog`` (three IMUs, six samples each): read against
  pyulog's own full parse and against the log's ``CAL_*_ID`` parameters, and the refusal of a
  fit over its 0.1 °C of temperature;
* warm-up logs written here (``tests/_flightlogs.py``, from the formats' published
  descriptions) from a simulated warm-up whose thermal bias is a known cubic: the fit on the
  ``.ulg``/``.bin`` equals the fit on the equivalent CSV, an active ArduPilot correction
  (written here with its own formula) is undone, PX4's is (rightly) left alone, and the
  exports carry the log's ids.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.calibration.modelfile import ThermalModelFile
from rinscal.cli import app
from rinscal.errors import LogError, LogNoteWarning
from rinscal.io.flightinfo import FlightLogOptions
from rinscal.io.flightlog import read_flight_log, scan_flight_log
from rinscal.io.tables import read_log, write_log
from rinscal.schema import CHANNELS
from tests._flightlogs import (
    DataFlashImu,
    Topic,
    px4_topics,
    ulog_data_start,
    write_dataflash,
    write_ulog,
)
from tests._shared import real_log_dir

runner = CliRunner()
REAL_ULOG = real_log_dir() / "ulog" / "px4_cubeorange_sample_log_small.ulg"
#: device_id of sensor_gyro/sensor_accel per instance in the real log (pyulog's parse)
REAL_IDS = {0: 2424842, 1: 3670050, 2: 2621474}

# a warm-up with a known thermal bias: b(T) = c1 d + c2 d^2 + c3 d^3 + c0, d = T - 30 °C
RATE_HZ, SECONDS = 20.0, 1800.0
GYRO_C = np.array([[2e-3, 4e-4, -2e-5, 3e-7], [-1e-3, -3e-4, 1e-5, 0.0], [5e-4, 1e-4, 0.0, -1e-7]])
ACCEL_C = np.array([[0.05, 2e-3, -4e-5, 1e-6], [-0.03, -1e-3, 3e-5, 0.0], [-9.80, 4e-3, 0.0, 0.0]])


def _bias(c: np.ndarray, temp: np.ndarray) -> np.ndarray:
    d = temp - 30.0
    return np.column_stack([r[0] + r[1] * d + r[2] * d**2 + r[3] * d**3 for r in c])


def _warmup(seed: int, offset_c: float = 0.0) -> dict[str, np.ndarray]:
    """Time [s] since boot, temperature [°C], raw gyro [rad/s] and accel [m/s²] (float32)."""
    rng = np.random.default_rng(seed)
    t = 2.0 + np.arange(int(RATE_HZ * SECONDS)) / RATE_HZ
    temp = 12.0 + offset_c + 38.0 * (1 - np.exp(-t / 500.0)) + rng.normal(0, 0.01, t.size)
    gyro = _bias(GYRO_C, temp) + rng.normal(0, 2e-4, (t.size, 3))
    accel = _bias(ACCEL_C, temp) + rng.normal(0, 2e-3, (t.size, 3))
    f32 = np.float32
    return {
        "t": t,
        "temp": temp.astype(f32),
        "gyro": gyro.astype(f32),
        "accel": accel.astype(f32),
    }


def _csv(w: dict[str, np.ndarray], path: Path, shared_temp: bool = False) -> Path:
    """The equivalent canonical CSV (the same float32 values, time in µs / 1e6)."""
    us = np.round(w["t"] * 1e6).astype(np.int64)
    cols: dict[str, object] = {"time_s": us / 1e6, "run": path.stem}
    for j, c in enumerate(CHANNELS):
        src = w["gyro"] if j < 3 else w["accel"]
        cols[c] = src[:, j % 3].astype(np.float64)
    temp = w["temp"].astype(np.float64)
    if shared_temp:
        cols["temp_in"] = temp
    else:
        for c in CHANNELS:
            cols[f"temp_{c}"] = temp
    write_log(pd.DataFrame(cols), path)
    path.with_name(path.name + ".meta.json").write_text(
        json.dumps({"units": {"gyro": "rad/s", "accel": "m/s^2"}}), encoding="utf-8"
    )
    return path


def _ok(args: list[object]) -> str:
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return res.output


def _fails(args: list[object]) -> str:
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 2, res.output
    return " ".join(res.output.split())


def _predictions(model: Path, temp: np.ndarray) -> np.ndarray:
    mf = ThermalModelFile.load(model)
    return mf.predict(temp, np.zeros_like(temp))


# ----------------------------------------------------------------------------- real ULog


@pytest.fixture(scope="module")
def real_ulog() -> Path:
    return REAL_ULOG


def test_real_ulog_instances_ids_and_parameters(real_ulog) -> None:
    info = scan_flight_log(real_ulog)
    assert info.autopilot == "px4"
    assert {i.index: i.gyro_id for i in info.instances} == REAL_IDS
    assert {i.index: i.accel_id for i in info.instances} == REAL_IDS
    # the ids agree with the vehicle's own calibration parameters (CAL_GYRO<n>_ID)
    for n, dev in REAL_IDS.items():
        assert int(info.params[f"CAL_GYRO{n}_ID"]) == dev
        assert int(info.params[f"CAL_ACC{n}_ID"]) == dev
    assert info.params["TC_G_ENABLE"] == 0 and info.params["TC_A_ENABLE"] == 0
    assert all(i.correction is None and i.samples == 6 for i in info.instances)
    # PX4 v1.11.2: its drivers publish raw output, so its (non-default) CAL_* offsets and
    # scales are not in sensor_gyro/sensor_accel and no note names them
    assert info.params["CAL_GYRO0_XOFF"] != 0 and info.params["CAL_ACC0_XSCALE"] != 1
    assert not [n for n in info.notes if "CAL_" in n]


def test_real_ulog_samples_equal_pyulogs_full_parse(real_ulog) -> None:
    from pyulog import ULog

    ulog = ULog(str(real_ulog), message_name_filter_list=["sensor_gyro", "sensor_accel"])
    for n in REAL_IDS:
        log = read_flight_log(real_ulog, FlightLogOptions(instance=n)).frame
        g = ulog.get_dataset("sensor_gyro", n).data
        a = ulog.get_dataset("sensor_accel", n).data
        np.testing.assert_array_equal(log["time_s"], g["timestamp_sample"] / 1e6)
        for j, ax in enumerate("xyz"):
            np.testing.assert_array_equal(log[CHANNELS[j]], g[ax].astype(np.float64))
        np.testing.assert_array_equal(log["temp_gyro_x"], g["temperature"].astype(np.float64))
        # gyro and accel of one chip share their sample times: the join is exact
        np.testing.assert_array_equal(a["timestamp_sample"], g["timestamp_sample"])
        np.testing.assert_array_equal(log["accel_z"], a["z"].astype(np.float64))


def test_real_ulog_cli_instance_choice_and_too_little_range(real_ulog, tmp_path) -> None:
    out = tmp_path / "m.json"
    text = _fails(["fit", real_ulog, "--out", out])
    assert "3 IMU instances" in text and "--instance" in text
    assert all(str(d) in text for d in REAL_IDS.values())
    text = _fails(["fit", real_ulog, "--instance", "3", "--out", out])
    assert "no IMU instance 3" in text
    text = _fails(["fit", real_ulog, "--instance", "1", "--out", out])
    assert "too little temperature range" in text
    assert "28.25 .. 28.37 °C" in text and "at least 5 °C" in text
    assert not out.exists()
    text = _fails(["fit", real_ulog, "--instance", "1", "--col", "a=b", "--out", out])
    assert "--col" in text and "--instance" in text
    fig = tmp_path / "all.png"
    assert "3 run(s), 18 samples" in _ok(["plot", real_ulog, "--out", fig])


# ----------------------------------------------------------------------------- PX4 warm-up


@pytest.fixture(scope="module")
def px4_logs(tmp_path_factory) -> dict[str, Path]:
    """Instance 1 of a two-IMU ULog, plain and with an active TC_G1/TC_A1 set; its CSV."""
    d = tmp_path_factory.mktemp("px4")
    w0, w1 = _warmup(1, offset_c=3.0), _warmup(2)
    topics = px4_topics(w0["t"], w0["gyro"], w0["accel"], w0["temp"], 0, 1001, 1002)
    topics += px4_topics(w1["t"], w1["gyro"], w1["accel"], w1["temp"], 1, 2293768, 2294024)
    tc = {"TC_G_ENABLE": 1, "TC_A_ENABLE": 1, "TC_G1_ID": 2293768, "TC_A1_ID": 2294024}
    tc |= {f"TC_G1_X{k}_{i}": 1e-3 * (k + 1) for k in range(4) for i in range(3)}
    tc |= {f"TC_A1_X{k}_{i}": 1e-2 * (k + 1) for k in range(4) for i in range(3)}
    tc |= {"TC_G1_TREF": 30.0, "TC_G1_TMIN": 0.0, "TC_G1_TMAX": 60.0}
    return {
        "plain": write_ulog(d / "warm.ulg", topics, {"TC_G_ENABLE": 0, "TC_A_ENABLE": 0}),
        "tc": write_ulog(d / "warm_tc.ulg", topics, tc),
        "csv": _csv(w1, d / "warm.csv"),
        "w1": w1,  # type: ignore[dict-item]
    }


def test_ulog_fit_equals_csv_fit_and_recovers_the_cubic(px4_logs, tmp_path) -> None:
    m_ulg, m_csv = tmp_path / "ulg.json", tmp_path / "csv.json"
    fit = ["--method", "poly-t", "--orders", "3"]
    _ok(["fit", px4_logs["plain"], "--instance", "1", "--out", m_ulg, *fit])
    _ok(["fit", px4_logs["csv"], "--out", m_csv, *fit])
    temp = np.linspace(14.0, 49.0, 36)
    p_ulg, p_csv = _predictions(m_ulg, temp), _predictions(m_csv, temp)
    np.testing.assert_allclose(p_ulg, p_csv, rtol=0, atol=1e-12 * np.abs(p_csv).max())
    # the known cubic, within the noise (2e-4 rad/s, 2e-3 m/s^2 over 36 000 samples)
    truth = np.column_stack([_bias(GYRO_C, temp), _bias(ACCEL_C, temp)])
    span = truth.max(axis=0) - truth.min(axis=0)
    assert (np.abs(p_ulg - truth).max(axis=0) < 0.01 * np.maximum(span, 1e-3)).all()
    mf = ThermalModelFile.load(m_ulg)
    assert mf.source["autopilot"] == "px4" and mf.source["instance"] == 1
    assert mf.source["device_ids"] == {"gyro": 2293768, "accel": 2294024}
    assert mf.models["gyro_x"].unit == "rad/s" and mf.models["accel_z"].unit == "m/s^2"


def test_ulog_active_tc_is_reported_and_not_undone(px4_logs, tmp_path) -> None:
    # PX4 logs sensor_gyro/sensor_accel before its TC_* correction: the fitted model must
    # not change when a TC set is active in the log (undoing it would add it to raw data)
    info = scan_flight_log(px4_logs["tc"])
    note = info.instance(1).correction
    assert note is not None and "TC_G1" in note and "TC_A1" in note and "nothing is undone" in note
    assert info.instance(0).correction is None  # ids of instance 0 match no set
    m_tc, m_plain = tmp_path / "tc.json", tmp_path / "plain.json"
    fit = ["--method", "poly-t", "--orders", "3"]
    _ok(["fit", px4_logs["tc"], "--instance", "1", "--out", m_tc, *fit])
    _ok(["fit", px4_logs["plain"], "--instance", "1", "--out", m_plain, *fit])
    temp = np.linspace(14.0, 49.0, 8)
    np.testing.assert_array_equal(_predictions(m_tc, temp), _predictions(m_plain, temp))
    assert "nothing is undone" in ThermalModelFile.load(m_tc).source["autopilot_correction"]


def test_px4_export_takes_the_logs_ids_and_set(px4_logs, tmp_path) -> None:
    model, params = tmp_path / "m.json", tmp_path / "tc.params"
    _ok(["fit", px4_logs["plain"], "--instance", "1", "--method", "px4", "--out", model])
    _ok(["export", model, "--format", "px4", "--out", params])
    rows = {
        line.split("\t")[2]: line.split("\t")[3]
        for line in params.read_text().splitlines()
        if not line.startswith("#")
    }
    assert rows["TC_G1_ID"] == "2293768" and rows["TC_A1_ID"] == "2294024"
    assert rows["TC_G_ENABLE"] == "1" and not any(k.startswith("TC_G0") for k in rows)


def test_old_px4_calibration_offsets_in_the_drivers_output_are_told(tmp_path) -> None:
    # PX4 up to v1.10 applied CAL_GYRO*/CAL_ACC* offsets and scales in the driver, before
    # publishing sensor_gyro/sensor_accel (process_sensor_caldata.py: "Set all CAL_GYR and
    # CAL_ACC parameters to defaults"); the version is the ver_sw_release info message
    # (0xAABBCCTT: major AA, minor BB, patch CC, type TT)
    t = 1.0 + np.arange(400) / 50.0
    temp = (25.0 + t).astype(np.float32)
    zero = np.zeros((t.size, 3), np.float32)
    topics = px4_topics(t, zero, zero, temp, 0, 7, 8)
    cal = {"CAL_GYRO0_ID": 7, "CAL_GYRO0_XOFF": 0.01, "CAL_GYRO0_YOFF": 0.0,
           "CAL_GYRO0_XSCALE": 1.0, "CAL_ACC0_ID": 8, "CAL_ACC0_ZSCALE": 1.02,
           "CAL_GYRO1_ID": 99, "CAL_GYRO1_XOFF": 0.5}  # fmt: skip
    versions = {"v1.10.0": 0x010A00FF, "v1.11.0": 0x010B00FF, None: None}
    said = {}
    for name, release in versions.items():
        info: dict[str, str | int] = {"sys_name": "PX4"}
        if release is not None:
            info["ver_sw_release"] = release
        path = write_ulog(tmp_path / f"cal_{name}.ulg", topics, cal, info=info)
        said[name] = " ".join(scan_flight_log(path).notes)
        if name == "v1.10.0":  # as the user meets it
            res = runner.invoke(app, ["plot", str(path), "--out", str(tmp_path / "cal.png")])
            assert res.exit_code == 0, res.output
            assert f"note: {path}: {said[name]}" in " ".join(res.output.split())
    for name in ("v1.10.0", None):
        text = said[name]
        assert "IMU instance 0: CAL_GYRO0_XOFF, CAL_ACC0_ZSCALE not at" in text, text
        assert "CAL_GYRO0_YOFF" not in text and "CAL_GYRO0_XSCALE" not in text
        assert "CAL_GYRO1" not in text  # another device's
        assert "reset" in text and "nothing is undone" in text
    assert "PX4 v1.10.0 applied them in the driver" in said["v1.10.0"]
    assert "does not say its PX4 version" in said[None]
    assert said["v1.11.0"] == ""  # the drivers publish raw output since v1.11


def test_ulog_join_interpolates_accel_onto_gyro_times(tmp_path) -> None:
    # accel at its own times (offset 0.4 ms, 200 Hz vs gyro 400 Hz), linear in time: the
    # interpolated value is exact; a 50 ms accel dropout gives NaN accel, not made-up values
    tg = 1.0 + np.arange(4000) / 400.0
    ta = 1.0004 + np.arange(1999) / 200.0
    ta = np.delete(ta, np.arange(1000, 1010))
    lin = np.column_stack([0.5 * ta, -0.25 * ta, 9.0 + 0 * ta]).astype(np.float32)
    temp_g = (20 + tg).astype(np.float32)
    temp_a = (20 + ta).astype(np.float32)
    gyro = np.zeros((tg.size, 3), np.float32)
    topics = px4_topics(tg, gyro, None, temp_g, 0, 7, 8, ta, lin, temp_a)  # type: ignore[arg-type]
    path = write_ulog(tmp_path / "join.ulg", topics)
    log = read_flight_log(path).frame
    t = log["time_s"].to_numpy()
    assert t[0] >= ta[0] - 1e-9 and t[-1] <= ta[-1] + 1e-9  # gyro rows inside accel's span
    a_us = np.round(ta * 1e6)
    inside = ~np.isnan(log["accel_x"].to_numpy())
    expected = np.interp(t * 1e6, a_us, lin[:, 0].astype(np.float64))
    np.testing.assert_allclose(log["accel_x"].to_numpy()[inside], expected[inside], atol=1e-6)
    gap = (t > ta[999] + 1e-6) & (t < ta[1000] - 1e-6)
    assert gap.sum() >= 20 and (inside == ~gap).all()  # NaN exactly inside the gap
    assert np.isfinite(log["temp_accel_x"]).all()  # temperature bridges the gap
    # nearest: the value of the closest accel sample, NaN farther than 1.5 intervals
    near = read_flight_log(path, FlightLogOptions(join="nearest")).frame["accel_x"].to_numpy()
    j = np.abs(t[:, None] * 1e6 - a_us[None, :]).argmin(axis=1)
    far = np.abs(t * 1e6 - a_us[j]) > 1.5 * 5000
    np.testing.assert_array_equal(near[~far], lin[j[~far], 0].astype(np.float64))
    assert far.sum() >= 10 and np.isnan(near[far]).all()


def test_ulog_nan_temperature_and_a_timestamp_glitch_are_left_out_and_told(tmp_path) -> None:
    t = 1.0 + np.arange(500) / 100.0
    temp = (20 + t).astype(np.float32)
    temp[:3] = np.nan  # a driver before its first temperature reading
    topics = px4_topics(t, np.zeros((t.size, 3), np.float32), np.zeros((t.size, 3), np.float32),
                        temp, 0, 7, 8)  # fmt: skip
    topics[0].data["timestamp_sample"][200] += 10**9  # one gyro sample stamped 1000 s ahead
    path = write_ulog(tmp_path / "glitch.ulg", topics)
    fl = read_flight_log(path)
    assert len(fl.frame) == 500 - 3 - 1 and fl.frame["time_s"].is_monotonic_increasing
    notes = " ".join(fl.notes)
    assert "3 sensor_gyro sample(s) without a temperature" in notes
    assert "1 sensor_gyro sample(s) whose time does not increase" in notes


# ----------------------------------------------------------------------------- ArduPilot


def _ardupilot_logged(
    w: dict[str, np.ndarray],
    params: dict[str, float],
    until_s: float,
    tcal: str = "INS_TCAL1_",
    caltemp: tuple[str, str] = ("INS_GYR1_CALTEMP", "INS_ACC1_CALTEMP"),
):
    """IMU values as ArduPilot logs them: the ``tcal`` correction (until ``until_s``), then
    AHRS_ORIENTATION 2 (yaw 90: (x, y, z) -> (-y, x, z)). Written from ArduPilot's formula,
    independently of rinscal.firmware; ``tcal`` and ``caltemp`` name the instance's
    parameters as ``AP_InertialSensor.cpp`` does (IMU 1: ``INS_TCAL1_``; IMU 4: ``INS4_TCAL_``)."""
    temp = w["temp"].astype(np.float64)
    lo, hi = params[f"{tcal}TMIN"], params[f"{tcal}TMAX"]

    def poly(tag: str, d: np.ndarray) -> np.ndarray:
        cols = []
        for ax in "XYZ":
            c1, c2, c3 = (params[f"{tcal}{tag}{k}_{ax}"] * 1e-6 for k in (1, 2, 3))
            cols.append(c1 * d + c2 * d**2 + c3 * d**3)
        return np.column_stack(cols)

    out = {}
    for name, tag, cal in (("gyro", "GYR", caltemp[0]), ("accel", "ACC", caltemp[1])):
        d = np.clip(temp, lo, hi) - 35.0
        dc = np.full_like(d, min(max(params[cal], lo), hi) - 35.0)
        corr = poly(tag, d) - poly(tag, dc)
        corr[w["t"] >= until_s] = 0.0  # INS_TCAL1_ENABLE set to 0 at until_s
        v = w[name].astype(np.float64) - corr
        out[name] = np.column_stack([-v[:, 1], v[:, 0], v[:, 2]]).astype(np.float32)
        out[name + "_corr"] = corr
    return out


@pytest.fixture(scope="module")
def ardupilot_logs(tmp_path_factory) -> dict[str, object]:
    d = tmp_path_factory.mktemp("ardupilot")
    w = _warmup(3)
    params = {"INS_TCAL1_ENABLE": 1.0, "INS_TCAL1_TMIN": 10.0, "INS_TCAL1_TMAX": 45.0}
    params |= {f"INS_TCAL1_GYR{k}_{a}": [40.0, -3.0, 0.2][k - 1] for k in (1, 2, 3) for a in "XYZ"}
    params |= {
        f"INS_TCAL1_ACC{k}_{a}": [900.0, 20.0, -1.5][k - 1] for k in (1, 2, 3) for a in "XYZ"
    }
    params |= {"INS_GYR1_CALTEMP": 25.0, "INS_ACC1_CALTEMP": 25.0, "AHRS_ORIENTATION": 2.0}
    params |= {"INS_GYR_ID": 2752522.0, "INS_ACC_ID": 2753034.0}
    until = 1200.0
    logged = _ardupilot_logged(w, params, until)
    imu = DataFlashImu(0, w["t"], logged["gyro"], logged["accel"], w["temp"])
    changed = [(int(until * 1e6), "INS_TCAL1_ENABLE", 0.0)]
    return {
        "bin": write_dataflash(d / "warm.bin", [imu], params, changed),
        "csv": _csv(w, d / "raw.csv", shared_temp=True),
        "logged": logged,
        "w": w,
    }


def test_dataflash_correction_undone_and_fit_equals_raw(ardupilot_logs, tmp_path) -> None:
    fl = read_flight_log(ardupilot_logs["bin"])
    w, logged = ardupilot_logs["w"], ardupilot_logs["logged"]
    assert fl.info.autopilot == "ardupilot" and "undone" in fl.info.instance(0).correction
    # raw data back (float32 rounding of the logged values aside)
    for j, c in enumerate(CHANNELS):
        raw = (w["gyro"] if j < 3 else w["accel"])[:, j % 3].astype(np.float64)
        scale = np.abs(raw).max()
        np.testing.assert_allclose(fl.frame[c], raw, rtol=0, atol=2e-6 * scale)
    # the correction was large next to that: a reader that did not undo it would fail
    assert np.abs(logged["gyro_corr"]).max() > 1e-3 and np.abs(logged["accel_corr"]).max() > 0.01
    m_bin, m_csv = tmp_path / "bin.json", tmp_path / "csv.json"
    fit = ["--method", "poly-t", "--orders", "3"]
    _ok(["fit", ardupilot_logs["bin"], "--out", m_bin, *fit])
    _ok(["fit", ardupilot_logs["csv"], "--out", m_csv, *fit])
    temp = np.linspace(14.0, 49.0, 36)
    p_bin, p_csv = _predictions(m_bin, temp), _predictions(m_csv, temp)
    span = np.ptp(p_csv, axis=0)
    assert (np.abs(p_bin - p_csv).max(axis=0) < 1e-3 * np.maximum(span, 1e-6)).all()
    src = ThermalModelFile.load(m_bin).source
    assert src["device_ids"] == {"gyro": 2752522, "accel": 2753034} and src["instance"] == 0
    parm = tmp_path / "tcal.parm"
    _ok(["export", m_bin, "--format", "ardupilot", "--out", parm])
    text = parm.read_text()
    assert "INS_TCAL1_ENABLE 1" in text and "gyro 2752522" in text


def test_dataflash_imus_4_and_5_are_undone_with_their_ins4_ins5_parameters(tmp_path) -> None:
    # AP_InertialSensor.cpp: IMUs 4 and 5 keep their parameters in the groups "INS4_" and
    # "INS5_" (AP_InertialSensor_Params.cpp: TCAL_*, GYR_ID, ACC_ID, GYR_CALTEMP, ...), not
    # under INS_TCAL4_*; IMU 1 has an enabled INS_TCAL1 set of its own that must not be used
    w = _warmup(4)
    imu1 = {"INS_TCAL1_ENABLE": 1.0, "INS_TCAL1_TMIN": 0.0, "INS_TCAL1_TMAX": 60.0}
    imu1 |= {f"INS_TCAL1_{s}{k}_{a}": 5e3 for s in ("GYR", "ACC") for k in (1, 2, 3) for a in "XYZ"}
    params = imu1 | {"AHRS_ORIENTATION": 2.0, "INS_GYR_ID": 11.0, "INS_ACC_ID": 12.0}
    imus = [DataFlashImu(0, w["t"], w["gyro"], w["accel"], w["temp"])]
    logged = {}
    for instance, group in ((3, "INS4_"), (4, "INS5_")):
        tcal = {f"{group}TCAL_ENABLE": 1.0, f"{group}TCAL_TMIN": 10.0, f"{group}TCAL_TMAX": 45.0}
        tcal |= {
            f"{group}TCAL_GYR{k}_{a}": [40.0, -3.0, 0.2][k - 1] for k in (1, 2, 3) for a in "XYZ"
        }
        tcal |= {
            f"{group}TCAL_ACC{k}_{a}": [900.0, 20.0, -1.5][k - 1] for k in (1, 2, 3) for a in "XYZ"
        }
        tcal |= {f"{group}GYR_CALTEMP": 25.0 + instance, f"{group}ACC_CALTEMP": 20.0}
        tcal |= {f"{group}GYR_ID": 2752522.0 + instance, f"{group}ACC_ID": 2753034.0 + instance}
        params |= tcal
        logged[instance] = _ardupilot_logged(
            w, tcal, np.inf, f"{group}TCAL_", (f"{group}GYR_CALTEMP", f"{group}ACC_CALTEMP")
        )
        imus.append(DataFlashImu(instance, w["t"], logged[instance]["gyro"],
                                 logged[instance]["accel"], w["temp"]))  # fmt: skip
    # and a sixth, which ArduPilot has no parameters for: read as logged, and said so
    t6 = w["t"][:100]
    imus.append(DataFlashImu(5, t6, w["gyro"][:100], w["accel"][:100], w["temp"][:100]))
    path = write_dataflash(tmp_path / "five.bin", imus, params)
    info = scan_flight_log(path)
    assert {i.index: (i.gyro_id, i.accel_id) for i in info.instances if i.index > 2} == {
        3: (2752525, 2753037),
        4: (2752526, 2753038),
        5: (None, None),
    }
    assert "no parameters for IMU instance 5" in info.instance(5).correction
    sixth = read_flight_log(path, FlightLogOptions(instance=5)).frame
    logged_y = w["gyro"][:100, 1].astype(np.float64)  # yaw 90 taken out: x = logged y
    np.testing.assert_allclose(sixth["gyro_x"], logged_y, rtol=1e-12)
    for instance, group in ((3, "INS4_"), (4, "INS5_")):
        assert f"{group}TCAL enabled" in info.instance(instance).correction
        frame = read_flight_log(path, FlightLogOptions(instance=instance)).frame
        for j, c in enumerate(CHANNELS):  # the raw data back, float32 rounding aside
            raw = (w["gyro"] if j < 3 else w["accel"])[:, j % 3].astype(np.float64)
            np.testing.assert_allclose(frame[c], raw, rtol=0, atol=2e-6 * np.abs(raw).max())
        assert np.abs(logged[instance]["gyro_corr"]).max() > 1e-3  # which was not small
    # through the command: the model of IMU 4 is the model of its raw data, ids and all
    m_bin, m_csv = tmp_path / "bin.json", tmp_path / "csv.json"
    fit = ["--method", "poly-t", "--orders", "3"]
    _ok(["fit", path, "--instance", "3", "--out", m_bin, *fit])
    _ok(["fit", _csv(w, tmp_path / "raw.csv", shared_temp=True), "--out", m_csv, *fit])
    temp = np.linspace(14.0, 49.0, 36)
    p_bin, p_csv = _predictions(m_bin, temp), _predictions(m_csv, temp)
    assert (
        np.abs(p_bin - p_csv).max(axis=0) < 1e-3 * np.maximum(np.ptp(p_csv, axis=0), 1e-6)
    ).all()
    src = ThermalModelFile.load(m_bin).source
    assert src["device_ids"] == {"gyro": 2752525, "accel": 2753037} and src["instance"] == 3
    assert "INS4_TCAL enabled" in src["autopilot_correction"]


def test_dataflash_of_arducopter_3_imu2_imu3_messages(tmp_path) -> None:
    # before ArduPilot 4.0, instances 1 and 2 were IMU2/IMU3 messages without an I field
    t = 1.0 + np.arange(300) / 50.0
    imus = [
        DataFlashImu(k, t, np.full((t.size, 3), k, np.float32), np.zeros((t.size, 3), np.float32),
                     np.full(t.size, 20.0 + k, np.float32))
        for k in range(3)
    ]  # fmt: skip
    path = write_dataflash(tmp_path / "old.bin", imus, legacy=True)
    info = scan_flight_log(path)
    assert [i.index for i in info.instances] == [0, 1, 2]
    log = read_flight_log(path, FlightLogOptions(instance=2)).frame
    assert (log["gyro_x"] == 2.0).all() and (log["temp_in"] == 22.0).all() and len(log) == 300


def test_ardupilot_tcal_follows_the_firmware_for_an_unset_caltemp() -> None:
    # TCal::correct_sensor clamps CALTEMP (default -300 °C: not set) to TMIN
    from rinscal.firmware import ardupilot_tcal

    params = {"INS_TCAL1_ENABLE": 1, "INS_TCAL1_TMIN": 10.0, "INS_TCAL1_TMAX": 50.0}
    params |= {"INS_TCAL1_GYR1_X": 100.0, "INS_TCAL1_GYR2_X": 10.0, "INS_TCAL1_GYR3_X": 1.0}
    temp = np.array([0.0, 10.0, 35.0, 60.0])
    d, d_cal = np.clip(temp, 10, 50) - 35.0, 10.0 - 35.0

    def p(x: np.ndarray | float) -> np.ndarray | float:
        return (100 * x + 10 * x**2 + 1 * x**3) * 1e-6

    np.testing.assert_allclose(ardupilot_tcal(params, 0, "gyro", temp)[:, 0], p(d) - p(d_cal))
    assert (ardupilot_tcal(params | {"INS_TCAL1_ENABLE": 2}, 0, "gyro", temp) == 0).all()


# ----------------------------------------------------------------------------- bad files


def test_bad_flight_logs_get_clear_errors(tmp_path, px4_logs) -> None:
    csv = tmp_path / "table.csv"
    csv.write_text("a,b\n1,2\n")
    fake = tmp_path / "fake.ulg"
    fake.write_bytes(csv.read_bytes())
    with pytest.raises(LogError, match=r"not a ULog .*starts with b'a,b"):
        scan_flight_log(fake)
    fake_bin = tmp_path / "fake.bin"
    fake_bin.write_bytes(b"\x00" * 64)
    with pytest.raises(LogError, match="not a DataFlash log"):
        scan_flight_log(fake_bin)
    head = tmp_path / "head.ulg"
    head.write_bytes(b"ULog\x01\x12\x35\x01\x00")
    with pytest.raises(LogError, match="ULog"):
        scan_flight_log(head)
    # a cut end: read, and told
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(px4_logs["plain"].read_bytes()[:-17])
    with warnings.catch_warnings(record=True) as told:
        warnings.simplefilter("always")
        log = read_log(cut, FlightLogOptions(instance=1))
    notes = " ".join(str(w.message) for w in told if issubclass(w.category, LogNoteWarning))
    assert "truncated: the last" in notes and "outside the accelerometer's time span" in notes
    assert len(log) > 30_000
    # no IMU topic; no temperature field
    other = [Topic("vehicle_status", 0, (("uint64_t", "timestamp"),), {"timestamp": np.arange(5)})]
    with pytest.raises(LogError, match="no IMU data: the log has no sensor_gyro"):
        scan_flight_log(write_ulog(tmp_path / "none.ulg", other))
    fields = (("uint64_t", "timestamp"), ("uint32_t", "device_id"), ("float", "x"),
              ("float", "y"), ("float", "z"))  # fmt: skip
    data = {"timestamp": np.arange(1, 6) * 1000, "device_id": np.full(5, 9)}
    no_temp = [Topic("sensor_gyro", 0, fields, data), Topic("sensor_accel", 0, fields, data)]
    with pytest.raises(LogError, match="sensor_gyro has no temperature field"):
        read_flight_log(write_ulog(tmp_path / "notemp.ulg", no_temp))
    with pytest.raises(LogError, match="never written"):
        write_log(pd.DataFrame({"a": [1]}), tmp_path / "out.ulg")


def test_compensate_a_ulog_writes_a_table_and_refuses_a_ulog_out(px4_logs, tmp_path) -> None:
    model, out = tmp_path / "m.json", tmp_path / "comp.parquet"
    _ok(["fit", px4_logs["plain"], "--instance", "1", "--method", "poly-t", "--out", model])
    _ok(["compensate", px4_logs["plain"], "--instance", "1", "--model", model, "--out", out])
    comp = read_log(out)
    raw = read_flight_log(px4_logs["plain"], FlightLogOptions(instance=1)).frame
    assert len(comp) == len(raw) and (comp["time_s"].to_numpy() == raw["time_s"].to_numpy()).all()
    # the thermal drift is gone: what is left is about the white noise (2e-4 rad/s)
    assert np.std(raw["gyro_x"]) > 10 * np.std(comp["gyro_x"]) and np.std(comp["gyro_x"]) < 3e-4
    text = _fails(["compensate", px4_logs["plain"], "--instance", "1", "--model", model,
                   "--out", tmp_path / "back.ulg"])  # fmt: skip
    assert "never written" in text


def test_corrupt_ulog_is_read_by_pyulog_and_told(px4_logs, tmp_path) -> None:
    data = bytearray(px4_logs["plain"].read_bytes())
    # break one message header in the middle (type byte 0): the fast scan gives way to pyulog
    pos = len(data) // 2
    while not (data[pos + 2] == ord("D") and data[pos] == 42 and data[pos + 1] == 0):
        pos += 1
    data[pos + 2] = 0
    bad = tmp_path / "corrupt.ulg"
    bad.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match="corrupt message at byte"):
        log = read_log(bad, FlightLogOptions(instance=1))
    good = read_flight_log(px4_logs["plain"], FlightLogOptions(instance=1)).frame
    assert 0.9 * len(good) < len(log) <= len(good)
    common = np.isin(log["time_s"], good["time_s"])
    assert common.mean() > 0.99


def test_a_ulog_whose_data_section_is_garbage_is_refused_in_one_line(px4_logs, tmp_path):
    # a valid header and definitions, then random bytes: no message pyulog can recover
    model = tmp_path / "m.json"
    _ok(["fit", px4_logs["csv"], "--method", "poly-t", "--out", model])
    raw = px4_logs["plain"].read_bytes()
    out = tmp_path / "out"
    out.mkdir()
    for seed in range(4):
        noise = np.random.default_rng(seed).integers(0, 256, 20_000, dtype=np.uint8).tobytes()
        bad = tmp_path / f"garbage{seed}.ulg"
        bad.write_bytes(raw[: ulog_data_start(raw)] + noise)
        for args in (
            ["plot", bad, "--out", out / "g.png"],
            ["fit", bad, "--instance", "1", "--out", out / "m.json"],
            ["compensate", bad, "--instance", "1", "--model", model, "--out", out / "c.csv"],
        ):
            res = runner.invoke(app, [str(a) for a in args])
            assert res.exit_code == 2, (args[0], res.output, res.exception)
            text = " ".join(res.output.split())
            assert text.startswith(f"error: {bad}: unreadable ULog: "), text
            assert "pyulog's parser cannot read past" in text
            assert "Traceback" not in res.output and len(res.output.strip().splitlines()) <= 3
    assert list(out.iterdir()) == []

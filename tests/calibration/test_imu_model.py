"""One model of the whole sensor: a model file holding an IMU calibration beside its thermal
bias model, applied in one order (pulses → SI → inverse sensor model → deg/h, µg → thermal
bias) by every compensator, and fitted behind it (``fit(imu_calibration=...)``)."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest

from rinscal.calibration.compensate import StreamingCompensator, compensate
from rinscal.calibration.export import to_c_header
from rinscal.calibration.imustage import ImuStage
from rinscal.calibration.modelfile import SCHEMA_VERSION, ChannelModel, ThermalModelFile
from rinscal.calibration.workflow import compensate_file, fit
from rinscal.earth import static_outputs_r
from rinscal.errors import ConfigError, LogError, ModelFileError
from rinscal.io.imucal import read_imu_calibration
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log
from rinscal.schema import CHANNELS
from tests.calibration._imucal import PHYSICAL, calibration, forward, pulse_meta

RATE_HZ = 10.0
#: The thermal bias of the test, in the calibrated frame: β = β0 + β1 (T − 20) [deg/h, µg].
BETA0 = np.array([0.8, -0.5, 0.3, 120.0, -80.0, 45.0])
BETA1 = np.array([0.01, 0.02, -0.015, 1.5, -0.8, 2.0])
LAT, HEADING = 32.0, 30.0


def _static_reference() -> np.ndarray:
    w, f = static_outputs_r(np.radians(LAT), np.radians(HEADING), 0.0)
    return np.concatenate([w, f]) / PHYSICAL  # deg/h, µg


def _model(stage: ImuStage | None) -> ThermalModelFile:
    """A linear-in-T thermal model that removes β exactly, keeping the static output."""
    ref = _static_reference()
    models = {
        c: ChannelModel(
            params={"method": "poly-t", "t_ref": 20.0, "coef": [ref[j] + BETA0[j], BETA1[j]]},
            train_range=np.array([[0.0, 45.0]]),
            unit="deg/h" if c.startswith("gyro") else "ug",
            unit_to_si=float(PHYSICAL[j]),
            static_reference=float(ref[j]),
            metrics={
                "rms_train": 0.0,
                "rms_train_about_run_mean": 0.0,
                "n_train": 1.0,
                "n_outliers": 0.0,
                "n_runs": 1.0,
            },
        )
        for j, c in enumerate(CHANNELS)
    }
    mf = ThermalModelFile(method="poly-t", channels=CHANNELS, models=models, use_gradient=False)
    return mf.with_imu(stage)


def _signal_log(seed: int = 1, n: int = 600, runs: int = 2):
    """Pulses of a unit turning and tilting at channel temperatures 2-43 °C, and the truth.

    The true input ``s`` (deg/h, µg) is the static Earth rate and gravity plus rates up to
    ±150 °/s and forces up to ±1.5 g; the bias β(T) is added in the calibrated frame, so the
    exact inverse gives ``s + β`` and the thermal model removes β."""
    rng = np.random.default_rng(seed)
    frames, truth = [], []
    ref = _static_reference()
    for r in range(runs):
        t = (np.arange(n) + 1.0) / RATE_HZ
        temp = np.column_stack(
            [2.0 + 41.0 * (0.5 + 0.5 * np.sin(t / 9.0 + j + r)) for j in range(6)]
        )
        s = ref + np.column_stack(
            [150 * 3600 * np.sin(t * (0.7 + 0.2 * j) + r) for j in range(3)]
            + [1.5e6 * np.cos(t * (0.5 + 0.1 * j) + 2 * r) for j in range(3)]
        )
        s += rng.normal(0, 1.0, s.shape) * np.array([1.0] * 3 + [50.0] * 3)
        beta = BETA0 + BETA1 * (temp - 20.0)
        y_si = forward((s + beta) * PHYSICAL, temp)
        meta = pulse_meta(RATE_HZ)
        k = np.array([meta["unit_to_si"][c] for c in CHANNELS])
        cols = {"time_s": t, "run": f"run{r}"}
        cols |= {c: y_si[:, j] / k[j] for j, c in enumerate(CHANNELS)}
        cols |= {f"temp_{c}": temp[:, j] for j, c in enumerate(CHANNELS)}
        frames.append(pd.DataFrame(cols))
        truth.append(s)
    return pd.concat(frames, ignore_index=True), np.concatenate(truth), pulse_meta(RATE_HZ)


def test_forward_then_file_then_compensate_recovers_the_true_signal(tmp_path) -> None:
    log, s, meta = _signal_log()
    stage = ImuStage(calibration(), meta["units"], meta["unit_to_si"])
    mf = _model(stage)
    path = mf.save(tmp_path / "model.json")
    doc = json.loads(path.read_text())
    assert doc["schema_version"] == SCHEMA_VERSION == 4
    held = doc["payload"]["imu_calibration"]
    assert held["output_units"] == {"gyro": "deg/h", "accel": "ug"}
    assert held["input"]["units"]["gyro_x"] == "pulse" and "misalignment" in held["order"][1]
    loaded = ThermalModelFile.load(path)
    assert loaded.imu_calibration == calibration()
    scale = np.abs(s).max(axis=0)
    # in memory
    out = compensate(log, loaded, policy="extrapolate")
    got = out[list(CHANNELS)].to_numpy()
    np.testing.assert_allclose(got, s, rtol=0, atol=1e-9 * scale.max())
    assert np.abs(got - s).max(axis=0).max() / scale.min() < 1e-9  # every channel
    # file to file, with the output's metadata saying what the numbers are
    write_log(log, tmp_path / "log.csv")
    write_meta(meta, tmp_path / "log.csv")
    done = compensate_file(tmp_path / "log.csv", path, tmp_path / "out.csv", policy="clamp")
    back = pd.read_csv(tmp_path / "out.csv")[list(CHANNELS)].to_numpy()
    np.testing.assert_allclose(back, s, rtol=0, atol=1e-9 * scale.max())
    assert done.meta is not None and done.meta["units"]["gyro_z"] == "deg/h"
    assert done.meta["units"]["accel_x"] == "ug" and "pulse_scale" not in done.meta
    assert done.meta["compensated"]["imu_calibration"] is True
    # sample by sample: the one streaming compensator (the thermal model has no rate term)
    comp = StreamingCompensator(loaded, policy="extrapolate")
    one = log[log["run"] == "run0"]
    temps = one[[f"temp_{c}" for c in CHANNELS]].to_numpy()
    rows = [
        comp.update(t, r, tt)[0]
        for t, r, tt in zip(one["time_s"], one[list(CHANNELS)].to_numpy(), temps, strict=True)
    ]
    np.testing.assert_allclose(np.array(rows), s[: len(one)], rtol=0, atol=1e-9 * scale.max())


def test_without_the_imu_calibration_the_errors_stay() -> None:
    """Control: the same log through the thermal model alone is off by the scale factors."""
    log, s, meta = _signal_log(n=200, runs=1)
    k = np.array([meta["unit_to_si"][c] for c in CHANNELS])
    y = log[list(CHANNELS)].to_numpy() * k / PHYSICAL
    worst = np.abs(y - s).max(axis=0)
    assert worst[0] > 50.0  # 150 ppm of 150 °/s: ~80 deg/h
    assert worst[3] > 300.0  # 300 ppm of 1.5 g: 450 µg


def test_compensate_refuses_missing_channel_temperatures() -> None:
    log, _, meta = _signal_log(n=50, runs=1)
    mf = _model(ImuStage(calibration(), meta["units"], meta["unit_to_si"]))
    with pytest.raises(LogError, match=r"IMU calibration.*'temp_accel_y'.*'temp_in'"):
        compensate(log.drop(columns=["temp_accel_y"]), mf)
    shared = log.drop(columns=[f"temp_{c}" for c in CHANNELS]).assign(temp_in=20.0)
    assert np.isfinite(compensate(shared, mf)[list(CHANNELS)].to_numpy()).all()
    with pytest.raises(LogError, match=r"all six sensor channels.*gyro_z"):
        compensate(log.drop(columns=["gyro_z"]), mf.subset(("gyro_x",)))


def test_a_thermal_model_in_log_units_cannot_stand_behind_an_imu_calibration() -> None:
    mf = _model(None)
    bad = {c: ChannelModel(**{**vars(cm), "unit": "pulse"}) for c, cm in mf.models.items()}
    stage = ImuStage(calibration(), pulse_meta(1.0)["units"], pulse_meta(1.0)["unit_to_si"])
    with pytest.raises(ModelFileError, match=r"gyro_x is in 'pulse'.*deg/h"):
        ThermalModelFile(method="poly-t", channels=CHANNELS, models=bad).with_imu(stage)


def test_read_imu_calibration_reads_every_layout(tmp_path) -> None:
    cal = calibration()
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps(cal.to_dict()))
    wrapped = tmp_path / "imu.json"
    wrapped.write_text(
        json.dumps({"schema": "rinscal.imu-calibration-file/1", "imu_calibration": cal.to_dict()})
    )
    meta = pulse_meta(1.0)
    model = _model(ImuStage(cal, meta["units"], meta["unit_to_si"])).save(tmp_path / "m.json")
    for p in (bare, wrapped, model):
        assert read_imu_calibration(p) == cal
    plain = _model(None).save(tmp_path / "plain.json")
    with pytest.raises(ConfigError, match=r"plain\.json: a thermal model file without an IMU"):
        read_imu_calibration(plain)
    (tmp_path / "other.json").write_text('{"schema": "something/1"}')
    with pytest.raises(ConfigError, match=r"other\.json: not an IMU calibration"):
        read_imu_calibration(tmp_path / "other.json")
    with pytest.raises(ConfigError, match=r"nope\.json: no such"):
        read_imu_calibration(tmp_path / "nope.json")
    d = cal.to_dict()
    d["units"]["gyro_sf_x"] = "ppb"
    bare.write_text(json.dumps(d))
    with pytest.raises(ConfigError, match=r"bare\.json: gyro_sf_x is in 'ppb'"):
        read_imu_calibration(bare)


def _with_errors(log: pd.DataFrame, meta: dict) -> tuple[pd.DataFrame, dict]:
    """The soak log as the calibration's sensor would read it, in pulses."""
    temp = log[[f"temp_{c}" for c in CHANNELS]].to_numpy()
    k_in = np.array([meta["unit_to_si"][c] for c in CHANNELS])
    y_si = forward(log[list(CHANNELS)].to_numpy() * k_in, temp)
    pulses = pulse_meta(float(meta["rate_hz"]))
    k = np.array([pulses["unit_to_si"][c] for c in CHANNELS])
    out = log.copy()
    out[list(CHANNELS)] = y_si / k
    return out, {**meta, **pulses}


def test_fit_behind_the_imu_calibration_gives_the_error_free_thermal_model(soak_small) -> None:
    log, _, meta = soak_small
    bad, bad_meta = _with_errors(log, meta)
    clean = fit(log, "poly-t", meta=meta, orders=(3,))
    behind = fit(bad, "poly-t", meta=bad_meta, orders=(3,), imu_calibration=calibration())
    blind = fit(bad.assign(**{c: bad[c] * bad_meta["unit_to_si"][c] / PHYSICAL[j]
                              for j, c in enumerate(CHANNELS)}),
                "poly-t", meta=meta, orders=(3,))  # fmt: skip
    assert behind.model.imu_calibration == calibration()
    assert clean.model.imu_stage is None
    temp = np.linspace(5.0, 40.0, 30)
    for c in CHANNELS:
        want = clean.model.predict_channel(c, temp[:, None])[0]
        got = behind.model.predict_channel(c, temp[:, None])[0]
        off = blind.model.predict_channel(c, temp[:, None])[0]
        span = np.ptp(want)
        assert behind.model.models[c].unit == clean.model.models[c].unit
        assert np.abs(got - want).max() < 1e-6 * max(span, np.abs(want).max()), c
        if c == "accel_z":  # 1 g on z: 100 ppm + 1 ppm/°C + ... of it, ~100 µg off unchecked
            assert np.abs(off - want).max() > 50.0
    with pytest.raises(ConfigError, match=r"unit_to_si.*gyro_x"):
        fit(bad, "poly-t", meta={}, imu_calibration=calibration())


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_export_applies_the_imu_calibration_as_python_does(tmp_path) -> None:
    log, _, meta = _signal_log(n=40, runs=1)
    rate_cal = dataclasses.replace(  # a ramp law too, so that Tdot reaches the C
        calibration(), rate_coefs={"gyro_sf_x": (3.0, 0.5), "accel_mis_yz": (-2.0,)}
    )
    mf = _model(ImuStage(rate_cal, meta["units"], meta["unit_to_si"]))
    raw = log[list(CHANNELS)].to_numpy()
    rng = np.random.default_rng(5)
    temp = rng.uniform(-10.0, 55.0, raw.shape)  # beyond the range too: clamped
    tdot = rng.uniform(-1.0, 1.0, raw.shape)
    (tmp_path / "model.h").write_text(to_c_header(mf, prefix="imu"))
    rows = ",\n".join(
        "{" + ", ".join(repr(float(v)) for v in np.concatenate([a, b, c])) + "}"
        for a, b, c in zip(raw, temp, tdot, strict=True)
    )
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "model.h"\n'
        f"static const double X[][18] = {{{rows}}};\n"
        "int main(void) {\n"
        f"  for (int i = 0; i < {len(raw)}; i++) {{\n"
        "    double a[6], b[6], dT[6] = {0};\n"
        "    imu_imu_correct(X[i], X[i] + 6, X[i] + 12, a);\n"
        "    imu_compensate(X[i], X[i] + 6, X[i] + 12, dT, b);\n"
        '    for (int j = 0; j < 6; j++) printf("%.17g %.17g\\n", a[j], b[j]);\n'
        "  }\n  return 0;\n}\n"
    )
    exe = tmp_path / "main"
    subprocess.run(
        ["cc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-o", str(exe),
         str(tmp_path / "main.c"), "-lm"],
        check=True, capture_output=True,
    )  # fmt: skip
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    got = np.array(out.split(), dtype=float).reshape(len(raw), 6, 2)
    want = mf.imu_stage.physical(raw, temp, tdot)
    np.testing.assert_allclose(got[:, :, 0], want, rtol=1e-12, atol=0)
    thermal = np.column_stack(
        [
            mf.predict_channel(c, np.column_stack([temp[:, j], tdot[:, j]]))[0]
            - mf.models[c].static_reference
            for j, c in enumerate(CHANNELS)
        ]
    )
    np.testing.assert_allclose(got[:, :, 1], want - thermal, rtol=1e-12, atol=0)
    assert (
        np.abs(want - raw * np.array([meta["unit_to_si"][c] for c in CHANNELS]) / PHYSICAL).max()
        > 1.0
    )

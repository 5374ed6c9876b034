"""Exports: PX4 and ArduPilot parameters reproduce the model; C headers compile and agree."""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
import warnings
from decimal import Decimal

import numpy as np
import pytest
from typer.testing import CliRunner

import rinscal.calibration.inference
from rinscal.calibration.export import (
    SmallCoefficientWarning,
    to_ardupilot_parm,
    to_c_header,
    to_px4_params,
)
from rinscal.calibration.modelfile import ChannelModel, ThermalModelFile
from rinscal.calibration.thermal.model import ThermalModel
from rinscal.errors import ConfigError

METHODS = ("poly-t", "sectional", "regression", "neural")
AXES = ("x", "y", "z")
CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: px4/ardupilot model methods known to the inference module (another change adds them)
needs_clamped_methods = pytest.mark.skipif(
    "px4" not in rinscal.calibration.inference.METHODS,
    reason="px4/ardupilot model methods not in rinscal.calibration.inference yet",
)


def _c_outputs(mf, x: np.ndarray, tmp_path) -> np.ndarray:
    """Compile the model's C header with a driver and evaluate every channel at ``x``."""
    (tmp_path / "model.h").write_text(to_c_header(mf, prefix="imu"))
    rows = ",\n".join("{" + ", ".join(repr(float(v)) for v in r) + "}" for r in x)
    calls = "".join(f'printf("%.17g\\n", imu_{c}(X[i][0], X[i][1], X[i][2]));' for c in mf.channels)
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "model.h"\n'
        f"static const double X[][3] = {{{rows}}};\n"
        f"int main(void) {{ for (int i = 0; i < {len(x)}; i++) {{ {calls} }} return 0; }}\n"
    )
    exe = tmp_path / "main"
    subprocess.run(
        [
            "cc",
            "-std=c99",
            "-O2",
            "-Wall",
            "-Werror",
            "-o",
            str(exe),
            str(tmp_path / "main.c"),
            "-lm",
        ],
        check=True,
        capture_output=True,
    )
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    return np.array(out.split(), dtype=float).reshape(len(x), len(mf.channels))


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("method", METHODS)
def test_c_header_compiles_and_matches_numpy(method, fitted_models, tmp_path) -> None:
    mf = fitted_models[method]
    rng = np.random.default_rng(3)
    x = np.column_stack(
        [rng.uniform(-5, 55, 200), rng.uniform(-0.5, 1.5, 200), rng.uniform(-1, 3, 200)]
    )
    got = _c_outputs(mf, x, tmp_path)
    want = np.column_stack([mf.predict_channel(c, x)[0] for c in mf.channels])
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=0)


def _params(text: str, sep: str | None) -> dict[str, float]:
    out = {}
    for line in text.splitlines():
        if not line or line.startswith("#"):
            continue
        parts = line.split(sep)
        name, value = (parts[2], parts[3]) if sep == "\t" else (parts[0], parts[1])
        out[name] = float(value)
    return out


def _si_bias(mf, channel: str, temp: np.ndarray) -> np.ndarray:
    cm = mf.models[channel]
    f = mf.predict_channel(channel, temp[:, None])[0]
    return (f - cm.static_reference) * cm.unit_to_si


def assert_px4_offsets_are_the_models(p: dict[str, float], mf, rel: float = 1e-7) -> None:
    """PX4's ``calc_thermal_offsets_3D`` on the written set 0 gives the model's ``f − r``."""
    for sensor, tag in (("gyro", "G"), ("accel", "A")):
        lo, hi = p[f"TC_{tag}0_TMIN"], p[f"TC_{tag}0_TMAX"]
        temp = np.linspace(lo, hi, 50)
        d = temp - p[f"TC_{tag}0_TREF"]
        for i, a in enumerate(AXES):
            # PX4 temperature_compensation: offset = X0 + X1 d + X2 d² + X3 d³, SI
            offset = sum(p[f"TC_{tag}0_X{k}_{i}"] * d**k for k in range(4))
            want = _si_bias(mf, f"{sensor}_{a}", temp)
            np.testing.assert_allclose(offset, want, rtol=0, atol=rel * np.abs(want).max())


def assert_ardupilot_correction_is_the_models(
    p: dict[str, float], mf, n: int = 1, rel: float = 1e-7
) -> None:
    """``TCal::correct_sensor`` on ``INS_TCALn_*`` gives the model's change from CALTEMP."""
    lo, hi = p[f"INS_TCAL{n}_TMIN"], p[f"INS_TCAL{n}_TMAX"]
    temp = np.linspace(lo, hi, 50)
    cal_temp = 0.5 * (lo + hi)  # INS_ACC1_CALTEMP: where the offsets were calibrated
    for sensor, tag in (("accel", "ACC"), ("gyro", "GYR")):
        for a in AXES:

            def poly(d: np.ndarray, a: str = a, tag: str = tag) -> np.ndarray:
                c = [p[f"INS_TCAL{n}_{tag}{k}_{a.upper()}"] for k in (1, 2, 3)]
                return (c[0] + (c[1] + c[2] * d) * d) * d * 1e-6  # AP_InertialSensor_tempcal

            # v -= P(T − 35) − P(CALTEMP − 35): ArduPilot keeps the level
            correction = poly(temp - 35.0) - poly(np.full(1, cal_temp - 35.0))
            ch = f"{sensor}_{a}"
            want = _si_bias(mf, ch, temp) - _si_bias(mf, ch, np.array([cal_temp]))
            np.testing.assert_allclose(
                correction, want, rtol=0, atol=rel * np.abs(_si_bias(mf, ch, temp)).max()
            )


def test_px4_params_reproduce_the_poly_t_offset(fitted_models) -> None:
    mf = fitted_models["poly-t"]
    p = _params(to_px4_params(mf, gyro_id=2293768, accel_id=2294024), "\t")
    assert p["TC_G_ENABLE"] == 1 and p["TC_A0_ID"] == 2294024
    assert_px4_offsets_are_the_models(p, mf)


@pytest.mark.filterwarnings("ignore::rinscal.calibration.export.SmallCoefficientWarning")
def test_ardupilot_parm_reproduces_the_thermal_change(fitted_models) -> None:
    mf = fitted_models["poly-t"]
    p = _params(to_ardupilot_parm(mf, instance=1), None)
    assert p["INS_TCAL2_ENABLE"] == 1
    assert_ardupilot_correction_is_the_models(p, mf, n=2)


def test_flight_exports_need_a_poly_t_model_with_units(fitted_models, soak_small) -> None:
    with pytest.raises(ConfigError, match=r"gyro_x is a regression model.*poly-t.*C header"):
        to_px4_params(fitted_models["regression"], gyro_id=1, accel_id=2)
    with pytest.raises(ConfigError, match="accel_x is a neural model"):
        to_ardupilot_parm(fitted_models["neural"])
    no_units = ThermalModel("poly-t").fit(soak_small[0]).to_file()
    with pytest.raises(ConfigError, match="unit unknown"):
        to_ardupilot_parm(no_units)
    with pytest.raises(ConfigError, match="identifier"):
        to_c_header(fitted_models["poly-t"], prefix="1bad")


# ------------------------------------------------------------------ hand-built models

_METRICS = {
    "rms_train": 0.0,
    "rms_train_about_run_mean": 0.0,
    "n_train": 100.0,
    "n_outliers": 0.0,
    "n_runs": 1.0,
}


def _poly(coef: list[float], t_ref: float = 35.0) -> dict:
    return {"method": "poly-t", "t_ref": t_ref, "coef": coef}


def _clamped(method: str, coef: list[float], t_ref: float, lo: float, hi: float) -> dict:
    return {"method": method, "t_ref": t_ref, "t_min": lo, "t_max": hi, "coef": coef}


def _hand_model(
    params: dict[str, dict],
    ranges: dict[str, tuple[float, float]] | None = None,
    *,
    method: str = "poly-t",
    source: dict | None = None,
    unit_to_si: float = 1.0,
    static_reference: float = 0.0,
) -> ThermalModelFile:
    """A model file of the six channels built from plain parameters (T-only methods)."""
    ranges = ranges or {}
    models = {
        c: ChannelModel(
            params=params[c],
            train_range=np.array([ranges.get(c, (5.0, 45.0))], dtype=np.float64),
            unit="SI",
            unit_to_si=unit_to_si,
            static_reference=static_reference,
            metrics=dict(_METRICS),
        )
        for c in CHANNELS
    }
    return ThermalModelFile(method=method, channels=CHANNELS, models=models, source=source or {})


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SmallCoefficientWarning)
        return fn(*args, **kwargs)


# ------------------------------------------------------------------ PX4 device ids


def test_px4_refuses_without_device_ids(fitted_models) -> None:
    mf = fitted_models["poly-t"]
    assert "device_ids" not in mf.source
    with pytest.raises(ConfigError) as gyro:
        to_px4_params(mf)
    msg = str(gyro.value)
    for needle in (
        "--gyro-id",
        "TC_G0_ID = 0 means the file is never applied",
        "device_id of sensor_gyro in a ULog",
        "CAL_GYRO0_ID",
    ):
        assert needle in msg, msg
    with pytest.raises(ConfigError) as accel:
        to_px4_params(mf, gyro_id=2293768)
    msg = str(accel.value)
    for needle in (
        "--accel-id",
        "TC_A0_ID = 0 means the file is never applied",
        "device_id of sensor_accel",
        "CAL_ACC0_ID",
    ):
        assert needle in msg, msg
    # an explicit 0, a bool, a non-integer and an id beyond uint32 are refused too
    with pytest.raises(ConfigError, match="--gyro-id: the gyro device id is 0"):
        to_px4_params(mf, gyro_id=0, accel_id=2294024)
    for bad in (True, 1.5, 2**32, -(2**31) - 1):
        with pytest.raises(ConfigError, match="--accel-id"):
            to_px4_params(mf, gyro_id=2293768, accel_id=bad)


def test_px4_device_ids_come_from_the_model_source(fitted_models) -> None:
    mf = fitted_models["poly-t"]
    ids = {"gyro": 2293768, "accel": 2294024}
    with_ids = dataclasses.replace(mf, source={**mf.source, "device_ids": ids})
    p = _params(to_px4_params(with_ids), "\t")
    assert p["TC_G0_ID"] == 2293768 and p["TC_A0_ID"] == 2294024
    # an explicit option wins over the model
    p = _params(to_px4_params(with_ids, accel_id=1311768), "\t")
    assert p["TC_G0_ID"] == 2293768 and p["TC_A0_ID"] == 1311768
    # a ULog device_id >= 2^31 (uint32, e.g. a DroneCAN IMU) is written as PX4's int32
    p = _params(to_px4_params(with_ids, gyro_id=0x87_00_01_0A), "\t")
    assert p["TC_G0_ID"] == 0x87_00_01_0A - 2**32
    # an unusable id in the model is refused naming where it came from
    bad = dataclasses.replace(mf, source={"device_ids": {"gyro": 0, "accel": 5}})
    with pytest.raises(ConfigError, match=r'source\["device_ids"\]\["gyro"\].*--gyro-id'):
        to_px4_params(bad)


# ------------------------------------------------------------------ TMIN/TMAX rounded inwards


def _text_values(text: str, sep: str | None) -> dict[str, str]:
    out = {}
    for line in text.splitlines():
        if line and not line.startswith("#"):
            parts = line.split(sep)
            name, value = (parts[2], parts[3]) if sep == "\t" else (parts[0], parts[1])
            out[name] = value
    return out


def test_flight_temperature_ranges_are_rounded_inwards(fitted_models) -> None:
    coef = {c: _poly([0.0, 1e-3, 1e-5, 1e-7]) for c in CHANNELS}
    ranges = {c: (12.3412, 73.9668) for c in CHANNELS}
    ranges["gyro_z"] = (10.0, 74.0)  # wider: the common range is the others'
    mf = _hand_model(coef, ranges, source={"device_ids": {"gyro": 1, "accel": 2}})
    px4 = _text_values(to_px4_params(mf), "\t")
    ap = _text_values(to_ardupilot_parm(mf), None)
    for tmin, tmax in (
        (px4["TC_G0_TMIN"], px4["TC_G0_TMAX"]),
        (px4["TC_A0_TMIN"], px4["TC_A0_TMAX"]),
        (ap["INS_TCAL1_TMIN"], ap["INS_TCAL1_TMAX"]),
    ):
        # 73.9668 was written 73.97 (outside the training range) before
        assert (tmin, tmax) == ("12.35", "73.96")
        lo, hi = ranges["gyro_x"]  # Decimal(float) is exact: the stored bounds
        assert Decimal(tmin) >= Decimal(lo) and Decimal(tmax) <= Decimal(hi)
    # a bound already on the 0.01 degC grid is kept
    on_grid = _hand_model(coef, {c: (-5.0, 74.0) for c in CHANNELS})
    ap = _text_values(to_ardupilot_parm(on_grid), None)
    assert (ap["INS_TCAL1_TMIN"], ap["INS_TCAL1_TMAX"]) == ("-5.00", "74.00")
    # a fitted model: written ranges inside every axis's training range
    fitted = fitted_models["poly-t"]
    px4 = _params(to_px4_params(fitted, gyro_id=1, accel_id=2), "\t")
    ap = _params(_quiet(to_ardupilot_parm, fitted), None)
    for c in CHANNELS:
        lo, hi = fitted.models[c].train_range[0]
        tag = "G" if c.startswith("gyro") else "A"
        assert lo <= px4[f"TC_{tag}0_TMIN"] <= px4[f"TC_{tag}0_TMAX"] <= hi
        assert lo <= ap["INS_TCAL1_TMIN"] <= ap["INS_TCAL1_TMAX"] <= hi
    # axes without a common 0.01 degC step are refused
    apart = _hand_model(coef, {**ranges, "accel_y": (73.961, 80.0), "accel_z": (0.0, 73.969)})
    with pytest.raises(ConfigError, match=r"TC_A0_TMIN/TMAX.*overlap"):
        to_px4_params(apart, gyro_id=1, accel_id=2)


# ------------------------------------------------------------------ small ArduPilot coefficients


def _independent_lost_share(v: list[float], k: int, tmin: float, tmax: float) -> float:
    """max |P − P without term k| / span of P on a fine grid (P: ArduPilot's cubic about 35)."""
    d = np.linspace(tmin, tmax, 400_001) - 35.0
    full = v[0] * d + v[1] * d**2 + v[2] * d**3
    return float(np.abs(v[k - 1] * d**k).max() / (full.max() - full.min()))


def test_ardupilot_warns_of_coefficients_mavproxy_would_not_load() -> None:
    coef = {
        # SI about 35 degC; x 1e6 -> [0.02, 1e-4, 5e-7]: GYR3_X under MAVProxy's 1e-6
        "gyro_x": _poly([0.0, 2e-8, 1e-10, 5e-13]),
        # -> [1e-3, 1e-4, 1e-6]: exactly 1e-6 is still skipped (|old - new| <= mindelta);
        # its cubic has an extremum inside the range
        "gyro_y": _poly([0.0, 1e-9, 1e-10, 1e-12]),
        # -> [1e-2, 0, 1.01e-6]: a zero is not warned of, 1.01e-6 loads
        "gyro_z": _poly([0.0, 1e-8, 0.0, 1.01e-12]),
        **{f"accel_{a}": _poly([0.0, 1e-4, 1e-6, 1e-8]) for a in AXES},
    }
    mf = _hand_model(coef, {c: (5.0, 45.0) for c in CHANNELS})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        text = to_ardupilot_parm(mf)
    p = _params(text, None)
    assert (p["INS_TCAL1_TMIN"], p["INS_TCAL1_TMAX"]) == (5.0, 45.0)
    small = [w for w in caught if issubclass(w.category, SmallCoefficientWarning)]
    assert [w.message.parameter for w in small] == ["INS_TCAL1_GYR3_X", "INS_TCAL1_GYR3_Y"]
    assert len(caught) == len(small)
    for w, axis, channel in zip(small, "XY", ("gyro_x", "gyro_y"), strict=True):
        msg = str(w.message)
        v = [p[f"INS_TCAL1_GYR{k}_{axis}"] for k in (1, 2, 3)]
        share = _independent_lost_share(v, 3, 5.0, 45.0)
        assert w.message.value == v[2]
        assert w.message.lost_share == pytest.approx(share, rel=1e-6)
        assert f"INS_TCAL1_GYR3_{axis} = " in msg
        assert "MAVProxy's 1e-6 load threshold" in msg and "param forceload" in msg
        m = re.search(rf"{channel} loses ([0-9.]+) % of its thermal span over \[5.00, 45.00\]", msg)
        assert m is not None, msg
        assert float(m.group(1)) == pytest.approx(100 * share, abs=0.05)
    # the figures themselves: 1.8 % (monotone cubic) and 76 % (extremum at d = -5.5 degC)
    assert small[0].message.lost_share == pytest.approx(0.0135 / 0.734, rel=1e-3)
    assert 0.7 < small[1].message.lost_share < 0.8


def test_ardupilot_small_coefficient_on_a_fitted_navigation_grade_gyro(fitted_models) -> None:
    # the simulated navigation-grade gyros' cubic terms are about 1e-12 rad/s/degC^3
    with pytest.warns(SmallCoefficientWarning) as record:
        text = to_ardupilot_parm(fitted_models["poly-t"])
    p = _params(text, None)
    lo, hi = p["INS_TCAL1_TMIN"], p["INS_TCAL1_TMAX"]
    for w in record:
        name = w.message.parameter
        assert name.startswith("INS_TCAL1_GYR") and 0 < abs(p[name]) <= 1e-6
        tag, k, axis = name[10:13], int(name[13]), name[-1]
        v = [p[f"INS_TCAL1_{tag}{j}_{axis}"] for j in (1, 2, 3)]
        assert w.message.lost_share == pytest.approx(
            _independent_lost_share(v, k, lo, hi), rel=1e-6
        )


# ------------------------------------------------------------------ px4/ardupilot channel methods

_SI = 4.84813681109536e-06  # deg/h in rad/s
_REF = 7.3  # static reference [deg/h]


def _clamped_model() -> ThermalModelFile:
    """Gyros: px4 models (own t_ref and clamps); accelerometers: ardupilot models (35 degC)."""
    params = {
        "gyro_x": _clamped("px4", [8.0, 0.02, -3e-4, 2e-6], 24.0, -5.123, 60.0),
        "gyro_y": _clamped("px4", [6.5, -0.01, 2e-4, -1e-6], 26.0, 0.0, 55.555),
        "gyro_z": _clamped("px4", [7.0, 0.015, 1e-4, 3e-6], 25.0, 2.004, 58.0),
        "accel_x": _clamped("ardupilot", [7.4, 0.5, -2e-3, 1e-5], 35.0, 1.234, 50.0),
        "accel_y": _clamped("ardupilot", [7.2, -0.3, 1e-3, -2e-5], 35.0, 0.5, 52.0),
        "accel_z": _clamped("ardupilot", [7.3, 0.2, 3e-3, 4e-5], 35.0, 1.0, 49.876),
    }
    # training ranges wider than the clamps: the exports must use the models' own t_min/t_max
    ranges = {c: (-20.0, 80.0) for c in CHANNELS}
    return _hand_model(
        params,
        ranges,
        method="auto",
        source={"device_ids": {"gyro": 2293768, "accel": 2294024}},
        unit_to_si=_SI,
        static_reference=_REF,
    )


def _clamped_si(mf: ThermalModelFile, channel: str, temp: np.ndarray) -> np.ndarray:
    """Independent evaluation: (Σ coef_k (clip(T) − t_ref)^k − static reference) · SI."""
    p = mf.models[channel].params
    d = np.clip(temp, p["t_min"], p["t_max"]) - p["t_ref"]
    return (sum(c * d**k for k, c in enumerate(p["coef"])) - _REF) * _SI


def test_px4_params_of_px4_and_ardupilot_channel_models() -> None:
    mf = _clamped_model()
    text = to_px4_params(mf)
    raw = _text_values(text, "\t")
    # intersection of the axes' own clamps, rounded inwards
    assert (raw["TC_G0_TMIN"], raw["TC_G0_TMAX"]) == ("2.01", "55.55")
    assert (raw["TC_A0_TMIN"], raw["TC_A0_TMAX"]) == ("1.24", "49.87")
    p = _params(text, "\t")
    assert p["TC_G0_ID"] == 2293768 and p["TC_A0_ID"] == 2294024
    for sensor, tag in (("gyro", "G"), ("accel", "A")):
        temp = np.linspace(p[f"TC_{tag}0_TMIN"] - 5, p[f"TC_{tag}0_TMAX"] + 5, 80)
        clamped = np.clip(temp, p[f"TC_{tag}0_TMIN"], p[f"TC_{tag}0_TMAX"])
        d = clamped - p[f"TC_{tag}0_TREF"]
        for i, a in enumerate(AXES):
            offset = sum(p[f"TC_{tag}0_X{k}_{i}"] * d**k for k in range(4))
            want = _clamped_si(mf, f"{sensor}_{a}", clamped)
            np.testing.assert_allclose(offset, want, rtol=0, atol=1e-7 * np.abs(want).max())


def test_ardupilot_parm_of_px4_and_ardupilot_channel_models() -> None:
    mf = _clamped_model()
    text = _quiet(to_ardupilot_parm, mf, instance=2)
    raw = _text_values(text, None)
    assert (raw["INS_TCAL3_TMIN"], raw["INS_TCAL3_TMAX"]) == ("2.01", "49.87")
    p = _params(text, None)
    lo, hi = p["INS_TCAL3_TMIN"], p["INS_TCAL3_TMAX"]
    temp = np.linspace(lo, hi, 60)
    cal_temp = np.array([0.5 * (lo + hi)])
    for sensor, tag in (("accel", "ACC"), ("gyro", "GYR")):
        for a in AXES:
            c = [p[f"INS_TCAL3_{tag}{k}_{a.upper()}"] for k in (1, 2, 3)]

            def poly(d: np.ndarray, c: list[float] = c) -> np.ndarray:
                return (c[0] + (c[1] + c[2] * d) * d) * d * 1e-6

            ch = f"{sensor}_{a}"
            correction = poly(temp - 35.0) - poly(cal_temp - 35.0)
            want = _clamped_si(mf, ch, temp) - _clamped_si(mf, ch, cal_temp)
            scale = np.abs(_clamped_si(mf, ch, temp)).max()
            np.testing.assert_allclose(correction, want, rtol=0, atol=1e-7 * scale)


def test_auto_model_with_a_non_cubic_channel_is_refused() -> None:
    mf = _clamped_model()
    models = dict(mf.models)
    models["accel_y"] = dataclasses.replace(
        models["accel_y"], params={"method": "regression", "orders": [2]}
    )
    mixed = dataclasses.replace(mf, models=models)
    for export in (to_px4_params, to_ardupilot_parm):
        with pytest.raises(ConfigError) as exc:
            export(mixed)
        msg = str(exc.value)
        assert "accel_y is a regression model" in msg and "C header (--format c)" in msg
    # the gyro block alone is fine for PX4 up to the accelerometers
    models["accel_y"] = dataclasses.replace(models["accel_y"], params=_poly([7.0, 0.1]))
    assert "TC_A0_X3_1" in to_px4_params(dataclasses.replace(mf, models=models))


@needs_clamped_methods
def test_clamped_channel_models_predict_as_exported(tmp_path) -> None:
    mf = _clamped_model()
    temp = np.linspace(-15.0, 70.0, 120)
    for c in CHANNELS:
        got = (mf.predict_channel(c, temp[:, None])[0] - _REF) * _SI
        np.testing.assert_allclose(got, _clamped_si(mf, c, temp), rtol=1e-12, atol=1e-20)
    if shutil.which("cc") is not None:
        x = np.column_stack([temp, np.zeros_like(temp), np.zeros_like(temp)])
        want = np.column_stack([mf.predict_channel(c, x)[0] for c in mf.channels])
        np.testing.assert_allclose(_c_outputs(mf, x, tmp_path), want, rtol=1e-9, atol=0)


# ------------------------------------------------------------------ command line


def test_export_command_refuses_px4_without_ids_and_prints_warnings(fitted_models, tmp_path):
    from rinscal.cli import app

    runner = CliRunner()
    model = fitted_models["poly-t"].save(tmp_path / "p.json")
    res = runner.invoke(
        app, ["export", str(model), "--format", "px4", "--out", str(tmp_path / "a.params")]
    )
    assert res.exit_code == 2 and "--gyro-id" in res.output and "never applied" in res.output
    assert not (tmp_path / "a.params").exists()
    args = ["--gyro-id", "2293768", "--accel-id", "2294024"]
    out = tmp_path / "b.params"
    res = runner.invoke(app, ["export", str(model), "--format", "px4", "--out", str(out), *args])
    assert res.exit_code == 0, res.output
    assert _params(out.read_text(), "\t")["TC_A0_ID"] == 2294024
    out = tmp_path / "c.parm"
    res = runner.invoke(app, ["export", str(model), "--format", "ardupilot", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "warning:" in res.output and "INS_TCAL1_GYR3_" in res.output and out.exists()


@pytest.mark.filterwarnings("ignore::rinscal.calibration.export.SmallCoefficientWarning")
def test_export_instance_is_numbered_as_the_readers(fitted_models, tmp_path) -> None:
    """Issue 21, items 9 and 10: --instance (0-based, as fit --instance), not --imu."""
    from rinscal.cli import app

    runner = CliRunner()
    model = fitted_models["poly-t"].save(tmp_path / "m.json")

    def export(*args: str) -> tuple[int, str, str]:
        out = tmp_path / "out.txt"
        out.unlink(missing_ok=True)
        res = runner.invoke(app, ["export", str(model), *args, "--out", str(out)])
        return res.exit_code, res.output, out.read_text() if out.exists() else ""

    code, _, text = export("--format", "ardupilot", "--instance", "1")
    assert code == 0 and "INS_TCAL2_ENABLE 1" in text and "INS_TCAL1_" not in text
    for inst in (3, 4):  # ArduPilot IMUs 4 and 5 keep INS4_TCAL_*/INS5_TCAL_*: refused by name
        code, output, text = export("--format", "ardupilot", "--instance", str(inst))
        assert code == 2 and f"INS{inst + 1}_TCAL_*" in " ".join(output.split()), output
        assert text == ""
    code, output, _ = export("--format", "ardupilot", "--imu", "2")
    assert code == 2 and "--instance 1" in output
    code, _, text = export(
        "--format", "px4", "--gyro-id", "7", "--accel-id", "9", "--instance", "2"
    )
    assert code == 0 and "1\t1\tTC_G2_ID\t7\t6" in text and "TC_G0_" not in text
    header = " ".join(line for line in text.splitlines() if line.startswith("#"))
    assert "FIRST set" in header and "clears no other set" in header and "reboot" in header

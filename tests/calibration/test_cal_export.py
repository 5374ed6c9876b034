"""Exports: PX4 and ArduPilot parameters reproduce the model; C headers compile and agree."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

from rinscal.calibration.export import to_ardupilot_parm, to_c_header, to_px4_params
from rinscal.calibration.model import ThermalModel
from rinscal.errors import ConfigError

METHODS = ("poly-t", "sectional", "regression", "neural")
AXES = ("x", "y", "z")


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("method", METHODS)
def test_c_header_compiles_and_matches_numpy(method, fitted_models, tmp_path) -> None:
    mf = fitted_models[method]
    (tmp_path / "model.h").write_text(to_c_header(mf, prefix="imu"))
    rng = np.random.default_rng(3)
    x = np.column_stack(
        [rng.uniform(-5, 55, 200), rng.uniform(-0.5, 1.5, 200), rng.uniform(-1, 3, 200)]
    )
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
    got = np.array(out.split(), dtype=float).reshape(len(x), len(mf.channels))
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


def test_px4_params_reproduce_the_poly_t_offset(fitted_models) -> None:
    mf = fitted_models["poly-t"]
    p = _params(to_px4_params(mf, gyro_id=2293768, accel_id=2294024), "\t")
    assert p["TC_G_ENABLE"] == 1 and p["TC_A0_ID"] == 2294024
    for sensor, tag in (("gyro", "G"), ("accel", "A")):
        lo, hi = p[f"TC_{tag}0_TMIN"], p[f"TC_{tag}0_TMAX"]
        temp = np.linspace(lo, hi, 50)
        d = temp - p[f"TC_{tag}0_TREF"]
        for i, a in enumerate(AXES):
            # PX4 temperature_compensation: offset = X0 + X1 d + X2 d² + X3 d³, SI
            offset = sum(p[f"TC_{tag}0_X{k}_{i}"] * d**k for k in range(4))
            want = _si_bias(mf, f"{sensor}_{a}", temp)
            np.testing.assert_allclose(offset, want, rtol=0, atol=1e-7 * np.abs(want).max())


def test_ardupilot_parm_reproduces_the_thermal_change(fitted_models) -> None:
    mf = fitted_models["poly-t"]
    p = _params(to_ardupilot_parm(mf, imu=2), None)
    assert p["INS_TCAL2_ENABLE"] == 1
    lo, hi = p["INS_TCAL2_TMIN"], p["INS_TCAL2_TMAX"]
    temp = np.linspace(lo, hi, 50)
    cal_temp = 0.5 * (lo + hi)  # INS_ACC1_CALTEMP: where the offsets were calibrated
    for sensor, tag in (("accel", "ACC"), ("gyro", "GYR")):
        for a in AXES:

            def poly(d: np.ndarray, a: str = a, tag: str = tag) -> np.ndarray:
                c = [p[f"INS_TCAL2_{tag}{k}_{a.upper()}"] for k in (1, 2, 3)]
                return (c[0] + (c[1] + c[2] * d) * d) * d * 1e-6  # AP_InertialSensor_tempcal

            correction = poly(temp - 35.0) - poly(np.full(1, cal_temp - 35.0))
            ch = f"{sensor}_{a}"
            want = _si_bias(mf, ch, temp) - _si_bias(mf, ch, np.array([cal_temp]))
            np.testing.assert_allclose(
                correction, want, rtol=0, atol=1e-7 * np.abs(_si_bias(mf, ch, temp)).max()
            )


def test_flight_exports_need_a_poly_t_model_with_units(fitted_models, soak_small) -> None:
    with pytest.raises(ConfigError, match="poly-t"):
        to_px4_params(fitted_models["regression"])
    no_units = ThermalModel("poly-t").fit(soak_small[0]).to_file()
    with pytest.raises(ConfigError, match="unit unknown"):
        to_ardupilot_parm(no_units)
    with pytest.raises(ConfigError, match="identifier"):
        to_c_header(fitted_models["poly-t"], prefix="1bad")

"""Model files: identical predictions after a round trip, numpy-only inference, clear errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rinscal.calibration.compensate import model_features
from rinscal.calibration.modelfile import (
    SCHEMA_VERSION,
    ThermalModelFile,
    payload_sha256,
)
from rinscal.calibration.thermal.model import ThermalModel
from rinscal.earth import static_outputs_r
from rinscal.errors import ModelFileError
from rinscal.units import DEG_TO_RAD, DPH_TO_RPS, UG_TO_MPS2

METHODS = ("poly-t", "sectional", "regression", "neural")


def _rewrite(doc: dict, fix_checksum: bool = True) -> str:
    if fix_checksum:
        doc["sha256"] = payload_sha256(doc["payload"])
    return json.dumps(doc)


@pytest.mark.parametrize("method", METHODS)
def test_round_trip_predicts_bit_for_bit(method, fitted_models, repeat_small, tmp_path) -> None:
    mf = fitted_models[method]
    path = mf.save(tmp_path / f"{method}.json")
    back = ThermalModelFile.load(path)
    feats = model_features(repeat_small[0], mf)
    for j, c in enumerate(mf.channels):
        a = mf.predict_channel(c, feats.matrix(j))[0]
        b = back.predict_channel(c, feats.matrix(j))[0]
        np.testing.assert_array_equal(a, b)
    assert back.to_dict() == mf.to_dict()
    assert back.derivative_window_s == 60.0 and back.derivative_kind == "centred"


def test_inference_needs_numpy_only(fitted_models, tmp_path) -> None:
    path = fitted_models["neural"].save(tmp_path / "m.json")
    code = (
        "import sys, numpy as np\n"
        "from rinscal.calibration.modelfile import ThermalModelFile\n"
        f"m = ThermalModelFile.load({str(path)!r})\n"
        "t = np.linspace(5, 40, 50)\n"
        "b = m.predict_bias_si(t, np.full(50, 0.3), t - 1.0)\n"
        "assert b.shape == (50, 6) and np.all(np.isfinite(b))\n"
        "bad = [k for k in sys.modules if k.split('.')[0] in ('sklearn', 'pandas', 'numba')]\n"
        "assert not bad, bad\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


def test_static_reference_is_earth_rate_and_gravity_in_log_units(fitted_models, soak_small):
    _, _, meta = soak_small
    mf = fitted_models["regression"]
    omega, f = static_outputs_r(
        meta["latitude_deg"] * DEG_TO_RAD, meta["heading_deg"] * DEG_TO_RAD, meta["altitude_m"]
    )
    want = np.r_[omega / DPH_TO_RPS, f / UG_TO_MPS2]
    got = np.array([mf.models[c].static_reference for c in mf.channels])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    # the simulator wrote the same static output in its metadata
    np.testing.assert_allclose(got, [meta["static_output"][c] for c in mf.channels], atol=1e-9)
    assert [mf.models[c].unit for c in mf.channels] == ["deg/h"] * 3 + ["ug"] * 3


def test_predict_bias_si_is_the_thermal_bias(fitted_models, soak_quiet):
    # on the noise-free plant the regression model's bias follows the true thermal bias
    log, truth, meta = soak_quiet
    mf = ThermalModel("regression").fit(log, meta).to_file()
    feats = model_features(log, mf)
    bias = mf.predict_bias_si(feats.temp, feats.rate, log["temp_out"].to_numpy())
    k = np.array([DPH_TO_RPS] * 3 + [UG_TO_MPS2] * 3)
    true = truth[[f"bias_{c}" for c in mf.channels]].to_numpy() * k
    offsets = np.array([list(meta["turn_on_offset"][r].values()) for r in feats.runs]) * k
    resid = bias - true - offsets[feats.run_codes]  # the quiet plant has zero offsets
    resid -= resid.mean(axis=0)
    spread = true - true.mean(axis=0)
    rms = np.sqrt(np.mean(resid**2, axis=0))
    # gyros carry a first-order model only (Table 6): looser than the cubic accelerometers
    assert np.all(rms < np.r_[[0.3] * 3, [0.05] * 3] * np.sqrt(np.mean(spread**2, axis=0)))
    # and it is (f - static_reference) * unit, exactly
    f = mf.predict(feats.temp, feats.rate, log["temp_out"].to_numpy())
    ref = np.array([mf.models[c].static_reference for c in mf.channels])
    np.testing.assert_array_equal(bias, (f - ref) * k)


def test_predict_bias_si_needs_units_and_site(soak_small) -> None:
    log, _, _ = soak_small
    mf = ThermalModel("poly-t").fit(log).to_file()  # no metadata
    assert all(mf.models[c].static_reference is None for c in mf.channels)
    with pytest.raises(ModelFileError, match=r"static_reference|unit"):
        mf.predict_bias_si(np.full(3, 20.0), np.zeros(3))
    assert mf.predict(np.full(3, 20.0), np.zeros(3)).shape == (3, 6)


def test_gradient_model_needs_the_outer_temperature(fitted_models) -> None:
    with pytest.raises(ModelFileError, match="temp_out"):
        fitted_models["regression"].predict(np.full(3, 20.0), np.zeros(3))


@pytest.fixture()
def saved(fitted_models, tmp_path) -> tuple[Path, dict]:
    path = fitted_models["sectional"].save(tmp_path / "m.json")
    return path, json.loads(path.read_text())


def test_missing_file_and_not_json(tmp_path) -> None:
    with pytest.raises(ModelFileError, match="no such model file"):
        ThermalModelFile.load(tmp_path / "nope.json")
    (tmp_path / "x.json").write_text("name,value\n1,2\n")
    with pytest.raises(ModelFileError, match="not valid JSON"):
        ThermalModelFile.load(tmp_path / "x.json")
    (tmp_path / "y.json").write_text("[1, 2]")
    with pytest.raises(ModelFileError, match="top level is a JSON list"):
        ThermalModelFile.load(tmp_path / "y.json")


def test_truncated_file(saved) -> None:
    path, _ = saved
    text = path.read_bytes()
    path.write_bytes(text[: len(text) // 2])
    with pytest.raises(ModelFileError, match=rf"{path.name}: not valid JSON .*truncated"):
        ThermalModelFile.load(path)


def test_wrong_schema_version(saved) -> None:
    path, doc = saved
    doc["schema_version"] = SCHEMA_VERSION + 1
    path.write_text(_rewrite(doc))
    with pytest.raises(ModelFileError, match=f"unsupported schema_version {SCHEMA_VERSION + 1}"):
        ThermalModelFile.load(path)


def test_tampered_coefficient_breaks_the_checksum(saved) -> None:
    path, doc = saved
    doc["payload"]["channel_models"]["accel_x"]["params"]["intercept"][3] += 1e-9
    path.write_text(_rewrite(doc, fix_checksum=False))
    with pytest.raises(ModelFileError, match="checksum mismatch"):
        ThermalModelFile.load(path)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda p: p["channel_models"]["gyro_y"].pop("train_range"), r"missing key.*train_range"),
        (lambda p: p.pop("method"), r"missing key\(s\) payload.method"),
        (lambda p: p["channel_models"]["gyro_y"]["params"]["coef"].pop(), "coef"),
        (
            lambda p: p["channel_models"]["gyro_y"]["params"].__setitem__("edges", [5.0, 1.0]),
            "edges",
        ),
        (lambda p: p["features"]["derivative"].__setitem__("window_s", -1), "window_s"),
        (lambda p: p["channel_models"].pop("accel_z"), "one entry per channel"),
        (lambda p: p.__setitem__("method", "spline"), "unknown method 'spline'"),
        (lambda p: p["channel_models"]["gyro_x"]["train_range"]["T"].reverse(), "min > max"),
        (lambda p: p["channel_models"]["gyro_x"].__setitem__("unit_to_si", 0.0), "positive"),
    ],
)
def test_invalid_content_with_a_valid_checksum(saved, edit, message) -> None:
    # someone edits the file and recomputes the checksum: validation still catches it
    path, doc = saved
    edit(doc["payload"])
    path.write_text(_rewrite(doc))
    with pytest.raises(ModelFileError, match=message):
        ThermalModelFile.load(path)


def test_non_finite_numbers_are_refused(saved) -> None:
    path, doc = saved
    payload = json.loads(_rewrite(doc))
    payload["payload"]["channel_models"]["gyro_x"]["params"]["intercept"][0] = float("nan")
    path.write_text(json.dumps(payload))  # writes NaN, which is not JSON
    with pytest.raises(ModelFileError, match=r"non-finite|NaN"):
        ThermalModelFile.load(path)
    path.write_text(path.read_text().replace("NaN", "1e999"))  # parses as inf
    with pytest.raises(ModelFileError, match=r"checksummed|finite"):
        ThermalModelFile.load(path)

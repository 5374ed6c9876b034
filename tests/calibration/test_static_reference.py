"""Compensation keeps the static output, for every fit method and every export (issue 21, 1).

``--method px4`` once removed gravity twice from accelerometers: its fit subtracted each
accelerometer's median (as PX4's script does), so the model's constant held no gravity, while
compensation ``N − (f − r)``, the PX4 export (``X0 = coef[0] − r``) and the C header
subtracted the static reference ``r`` again: ``accel_z`` went from 1 g to 2 g. No test
caught it because the export tests built their models by hand or fitted only ``poly-t`` and
``regression``, and no test looked at the *level* of a compensated static log.

Here a simulated soak at a known site (latitude, heading, height in its metadata) is fitted
with every method through the CLI and compensated three ways: by ``rinscal compensate``, by
the PX4 firmware's formula on the exported ``.params`` and by the exported C header. Each time
the mean static output must be the Earth rate and gravity of a level IMU at the site,
computed here independently of the package (WGS84 normal gravity, the Earth's sidereal rate),
within the spread of the compensated output itself.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.calibration.compensate import model_features
from rinscal.calibration.export import flight_model
from rinscal.calibration.modelfile import ThermalModelFile, payload_sha256
from rinscal.cli import app
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log
from rinscal.schema import CHANNELS
from tests.calibration.test_cal_export import (
    _c_outputs,
    _params,
    assert_ardupilot_correction_is_the_models,
    assert_px4_offsets_are_the_models,
)

runner = CliRunner()

#: Every fit method of ``rinscal fit --method``.
METHODS = ("auto", "poly-t", "sectional", "regression", "neural", "px4", "ardupilot")
#: Model methods a flight-software export takes (a cubic in T).
CUBIC_IN_T = {"poly-t", "px4", "ardupilot"}
AXES = ("x", "y", "z")
US_G = 9.80665e-6  # [m/s² per µg]
DEG_H = math.pi / 180.0 / 3600.0  # [rad/s per deg/h]


def _site_outputs(lat_deg: float, heading_deg: float, h_m: float) -> dict[str, float]:
    """Static output of a level IMU (x right, y forward, z up) at rest: deg/h and µg.

    Independent of the package: WGS84 normal gravity (Somigliana, with the free-air
    correction to second order) and the sidereal Earth rate 7.292115e-5 rad/s.
    """
    a, b, e2 = 6378137.0, 6356752.3142, 6.69437999014e-3
    ge, gp = 9.7803253359, 9.8321849378
    k = (b * gp - a * ge) / (a * ge)
    s2 = math.sin(math.radians(lat_deg)) ** 2
    g0 = ge * (1 + k * s2) / math.sqrt(1 - e2 * s2)
    f, m = 1 / 298.257223563, 0.00344978650684
    g = g0 * (1 - 2 / a * (1 + f + m - 2 * f * s2) * h_m + 3 / a**2 * h_m**2)
    w = 7.292115e-5
    lat, psi = math.radians(lat_deg), math.radians(heading_deg)
    # Earth rate in ENU is (0, w cos L, w sin L); the forward axis points at the heading
    east_n = w * math.cos(lat)
    gyro = (-east_n * math.sin(psi), east_n * math.cos(psi), w * math.sin(lat))
    return {
        **{f"gyro_{a}": v / DEG_H for a, v in zip(AXES, gyro, strict=True)},
        "accel_x": 0.0,
        "accel_y": 0.0,
        "accel_z": g / US_G,
    }


@pytest.fixture(scope="module")
def site_log(tmp_path_factory, soak_small) -> tuple[Path, pd.DataFrame, dict[str, float]]:
    log, _, meta = soak_small
    path = tmp_path_factory.mktemp("static") / "soak.parquet"
    write_log(log, path)
    write_meta(meta, path)
    ref = _site_outputs(meta["latitude_deg"], meta["heading_deg"], meta.get("altitude_m", 0.0))
    return path, log, ref


def _ok(args: list) -> str:
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return res.output


@pytest.fixture(scope="module")
def fitted(site_log, tmp_path_factory) -> dict[str, tuple[Path, ThermalModelFile]]:
    path, _, _ = site_log
    d = tmp_path_factory.mktemp("models")
    out = {}
    for method in METHODS:
        m = d / f"{method}.json"
        extra = ["--max-samples", "1500"] if method == "neural" else []
        _ok(["fit", path, "--method", method, "--out", m, *extra])
        out[method] = (m, ThermalModelFile.load(m))
    return out


def _assert_static(comp: dict[str, np.ndarray], ref: dict[str, float], what: str) -> None:
    """The mean of each compensated channel is its reference, within its own spread."""
    for c in CHANNELS:
        y = comp[c][np.isfinite(comp[c])]
        spread = float(np.std(y))
        # the model's own level is within a few residual spreads of the reference; a gravity
        # or Earth rate removed twice (or kept twice) is off by the whole reference
        tol = 3.0 * spread + 1e-3 * abs(ref[c]) + 1e-9
        assert abs(float(np.mean(y)) - ref[c]) < tol, (
            f"{what}: {c} static output {np.mean(y):.6g} against the reference {ref[c]:.6g} "
            f"(tolerance {tol:.3g}, spread {spread:.3g})"
        )


def test_the_models_reference_is_the_site(site_log, fitted) -> None:
    _, _, ref = site_log
    _, mf = fitted["poly-t"]
    for c in CHANNELS:
        r = mf.models[c].static_reference
        unit = 0.005 if c.startswith("gyro") else 5.0  # deg/h, µg: WGS84 and its models agree
        assert r == pytest.approx(ref[c], abs=unit), c


@pytest.mark.parametrize("method", METHODS)
def test_compensate_keeps_the_static_reference(method, site_log, fitted, tmp_path) -> None:
    path, _, ref = site_log
    m, _ = fitted[method]
    out = tmp_path / "comp.parquet"
    _ok(["compensate", path, "-m", m, "--out", out])
    comp = pd.read_parquet(out)
    _assert_static({c: comp[c].to_numpy() for c in CHANNELS}, ref, f"compensate ({method})")


def _px4_corrected(params: dict[str, float], log: pd.DataFrame, mf) -> dict[str, np.ndarray]:
    """The raw log corrected as PX4's ``calc_thermal_offsets_3D`` (raw − offset, SI), log units."""
    out = {}
    for sensor, tag in (("gyro", "G"), ("accel", "A")):
        slot = next(k for k in params if k.startswith(f"TC_{tag}") and k.endswith("_TREF"))
        s = slot[len(f"TC_{tag}") : -len("_TREF")]
        tref, lo, hi = (params[f"TC_{tag}{s}_{k}"] for k in ("TREF", "TMIN", "TMAX"))
        for i, a in enumerate(AXES):
            c = f"{sensor}_{a}"
            d = np.clip(log[f"temp_{c}"].to_numpy(), lo, hi) - tref
            offset = sum(params[f"TC_{tag}{s}_X{k}_{i}"] * d**k for k in range(4))
            k_si = mf.models[c].unit_to_si
            out[c] = log[c].to_numpy() - offset / k_si
    return out


def _is_cubic_in_t(mf) -> bool:
    return {mf.models[c].params["method"] for c in CHANNELS} <= CUBIC_IN_T


@pytest.mark.parametrize("method", METHODS)
def test_px4_export_applied_by_the_firmware_keeps_the_static_reference(
    method, site_log, fitted, tmp_path
) -> None:
    _, log, ref = site_log
    m, mf = fitted[method]
    out = tmp_path / "m.params"
    args = ["export", m, "--format", "px4", "--gyro-id", "1", "--accel-id", "2", "--out", out]
    res = runner.invoke(app, [str(a) for a in args])
    if method == "auto":  # issue 34.1: a choice PX4 cannot hold is written as its best cubic
        mf = flight_model(mf)[0]
    if not _is_cubic_in_t(mf):
        assert res.exit_code != 0 and "C header" in res.output, res.output
        return
    assert res.exit_code == 0, res.output
    params = _params(out.read_text(), "\t")
    _assert_static(_px4_corrected(params, log, mf), ref, f"PX4 firmware ({method})")
    assert_px4_offsets_are_the_models(params, mf, rel=1e-6)  # and f − r over the range


@pytest.mark.filterwarnings("ignore::rinscal.calibration.export.SmallCoefficientWarning")
@pytest.mark.parametrize("method", METHODS)
def test_ardupilot_export_applied_by_the_firmware_is_the_models_change(
    method, fitted, tmp_path
) -> None:
    m, mf = fitted[method]
    out = tmp_path / "m.parm"
    res = runner.invoke(app, [str(a) for a in ["export", m, "--format", "ardupilot", "--out", out]])
    if method == "auto":  # issue 34.1: a choice ArduPilot cannot hold is written as its best cubic
        mf = flight_model(mf)[0]
    if not _is_cubic_in_t(mf):
        assert res.exit_code != 0 and "C header" in res.output, res.output
        return
    assert res.exit_code == 0, res.output
    assert_ardupilot_correction_is_the_models(_params(out.read_text(), None), mf, rel=1e-6)


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("method", METHODS)
def test_c_header_applied_keeps_the_static_reference(method, site_log, fitted, tmp_path) -> None:
    _, log, ref = site_log
    _, mf = fitted[method]
    rows = slice(None, None, 20)  # every 20th row: the compiled table stays small
    blocks = []
    for c in CHANNELS:
        x = model_features(log, mf, channels=(c,)).matrix(c)[rows]
        x, _ = mf.apply_policy(c, x, "clamp")  # the header's training-range macros
        blocks.append(np.pad(x, ((0, 0), (0, 3 - x.shape[1]))))  # (T, Tdot, dT)
    f = _c_outputs(mf, np.vstack(blocks), tmp_path)  # one compilation, every channel
    n = len(blocks[0])
    comp = {
        c: log[c].to_numpy()[rows] - (f[j * n : (j + 1) * n, j] - mf.models[c].static_reference)
        for j, c in enumerate(CHANNELS)
    }
    _assert_static(comp, ref, f"C header ({method})")


def test_a_px4_model_written_before_the_fix_is_refused(fitted, tmp_path) -> None:
    # the old px4 accelerometer model: coef[0] without the training median (no gravity)
    m, _ = fitted["px4"]
    doc = json.loads(m.read_text())
    cm = doc["payload"]["channel_models"]["accel_z"]
    cm["params"]["coef"][0] -= cm["static_reference"]
    doc["sha256"] = payload_sha256(doc["payload"])
    old = tmp_path / "old.json"
    old.write_text(json.dumps(doc))
    res = runner.invoke(app, ["export", str(old), "--format", "c", "--out", str(tmp_path / "h")])
    assert res.exit_code == 2, res.output
    assert "channel_models.accel_z" in res.output and "refit it" in res.output

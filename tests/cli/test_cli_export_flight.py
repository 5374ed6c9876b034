"""Issue 34.1: the README's flight-log chain, `rinscal fit LOG --out m.json && rinscal export
m.json --format px4|ardupilot`, on the default (auto) fit.

Where auto chose a model PX4 and ArduPilot cannot hold (a regression), the export writes the
channel's best held-out candidate they can hold, fitted on all the data (the same as `fit
--method poly-t|px4|ardupilot` gives that channel), says so with the cost in held-out RMS, and
leaves the model file (what compensate and navigate apply) as it is. It refuses only where
the file keeps no such candidate, naming the channels.
"""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from rinscal.calibration.modelfile import ModelFileError, ThermalModelFile, payload_sha256
from rinscal.calibration.thermal.model import ThermalModel
from rinscal.cli import app
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log
from rinscal.schema import CHANNELS
from tests.calibration.test_cal_export import (
    _params,
    assert_ardupilot_correction_is_the_models,
    assert_px4_offsets_are_the_models,
)

pytestmark = pytest.mark.filterwarnings(
    "ignore::rinscal.calibration.export.SmallCoefficientWarning"
)

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT / "tests" / "data" / "real" / "tofupilot_imu_thermal_cycle.tsv"
MAPPING = ROOT / "examples" / "tofupilot_mapping.toml"
OLD_AUTO = ROOT / "tests" / "data" / "modelfile_v3_auto" / "model_v3_auto.json"
IDS = ["--gyro-id", "2293768", "--accel-id", "2294024"]
#: Candidates PX4 and ArduPilot can hold: clamped cubics in T.
FLIGHT = {"none", "poly-t 1", "poly-t 2", "poly-t 3", "px4", "ardupilot"}


def _run(args: list) -> tuple[int, str]:
    res = runner.invoke(app, [str(a) for a in args], env={"COLUMNS": "200"})
    return res.exit_code, res.output


def _ok(args: list) -> str:
    code, out = _run(args)
    assert code == 0, out
    return out


@pytest.fixture(scope="module")
def soak(tmp_path_factory, soak_small) -> tuple[Path, Path, dict]:
    """The small simulated soak, its default `rinscal fit` model and its metadata."""
    d = tmp_path_factory.mktemp("flight")
    log, _, meta = soak_small
    path = d / "soak.csv"
    write_log(log, path)
    write_meta(meta, path)
    model = d / "m.json"
    _ok(["fit", path, "--out", model])  # the default: --method auto
    return path, model, meta


def _fixed_fit(log, meta, channel: str, name: str) -> dict:
    """The candidate ``name`` of one channel as `fit --method poly-t|px4|ardupilot` fits it."""
    if name in ("px4", "ardupilot"):
        tm = ThermalModel(name, channels=(channel,))
    else:
        degree = 0 if name == "none" else int(name.split()[1])
        tm = ThermalModel("poly-t", orders=(degree,), channels=(channel,))
    return tm.fit(log, meta).to_file().models[channel].params


def _best_flight(selection: dict) -> str:
    """The candidate PX4/ArduPilot hold of least held-out RMS, from the selection table."""
    rows = [r for r in selection["table"] if r["name"] in FLIGHT and r["heldout_rms"] is not None]
    return min(rows, key=lambda r: (r["heldout_rms"], r["n_params"]))["name"]


def test_readme_chain_on_the_default_fit_of_a_simulated_soak(soak, soak_small, tmp_path) -> None:
    _, model, meta = soak
    before = model.read_bytes()
    mf = ThermalModelFile.load(model)
    assert mf.method == "auto"
    chosen = {c: mf.models[c].selection["chosen"] for c in CHANNELS}
    changed = [c for c in CHANNELS if chosen[c] not in FLIGHT]  # regression, poly-t 4
    assert changed, f"auto chose only cubics on this soak ({chosen}): nothing to show"
    params_out = tmp_path / "m.params"
    parm_out = tmp_path / "m.parm"
    text_px4 = _ok(["export", model, "--format", "px4", "--out", params_out, *IDS])
    text_ap = _ok(["export", model, "--format", "ardupilot", "--out", parm_out])
    # the model file, and so what compensate and navigate apply, is unchanged: its choice
    assert model.read_bytes() == before
    assert all(chosen[c].startswith(mf.models[c].params["method"]) for c in changed)
    # the expected export, built apart: per channel the model's own choice where the firmware
    # holds it, else the best held-out cubic, as `fit --method poly-t|px4|ardupilot` fits it
    log = soak_small[0]
    models = dict(mf.models)
    for c in changed:
        sel = mf.models[c].selection
        best = _best_flight(sel)
        params = _fixed_fit(log, meta, c, best)
        models[c] = dataclasses.replace(
            models[c], params=params, train_range=models[c].train_range[:1], domain=None
        )
        rows = {r["name"]: r for r in sel["table"]}
        for text in (text_px4, text_ap):  # the change and its cost, in the channel's unit
            line = next(ln for ln in text.splitlines() if ln.startswith(c + " "))
            got = re.split(r"\s{2,}", line.strip())
            assert got[1:4] == [
                chosen[c],
                f"{rows[chosen[c]]['heldout_rms']:.4g}",
                best,
            ], line
            assert got[4] == f"{rows[best]['heldout_rms']:.4g}", line
            cost = rows[best]["heldout_rms"] - rows[chosen[c]]["heldout_rms"]
            assert got[5].startswith(f"{cost:+.3g}"), line
    expected = dataclasses.replace(mf, models=models)
    # PX4's calc_thermal_offsets_3D and ArduPilot's TCal::correct_sensor on the written files
    assert_px4_offsets_are_the_models(_params(params_out.read_text(), "\t"), expected)
    assert_ardupilot_correction_is_the_models(_params(parm_out.read_text(), None), expected)
    # the files say which channels are not the model's choice
    for text in (params_out.read_text(), parm_out.read_text()):
        header = [ln for ln in text.splitlines() if ln.startswith("#   ")]
        assert [ln.split(":")[0].strip("# ") for ln in header] == changed


def test_readme_chain_on_the_default_fit_of_the_real_tofupilot_log(tmp_path) -> None:
    model = tmp_path / "real.json"
    _ok(["fit", REAL, "--map", MAPPING, "--out", model])
    mf = ThermalModelFile.load(model)
    params_out, parm_out = tmp_path / "real.params", tmp_path / "real.parm"
    _ok(["export", model, "--format", "px4", "--out", params_out, *IDS])
    _ok(["export", model, "--format", "ardupilot", "--out", parm_out])
    # what each written channel must be: the model's choice, or its best held-out cubic
    models = {}
    for c in CHANNELS:
        cm = mf.models[c]
        sel = cm.selection
        name = sel["chosen"] if sel["chosen"] in FLIGHT else _best_flight(sel)
        models[c] = dataclasses.replace(
            cm, params=sel["flight"][name], train_range=cm.train_range[:1], domain=None
        )
        assert sel["flight"][name]["method"] in ("poly-t", "px4", "ardupilot")
    want = dataclasses.replace(mf, models=models)
    p = _params(params_out.read_text(), "\t")
    a = _params(parm_out.read_text(), None)
    for sensor, tag, gtag in (("gyro", "G", "GYR"), ("accel", "A", "ACC")):
        lo, hi = a["INS_TCAL1_TMIN"], a["INS_TCAL1_TMAX"]
        temp = np.linspace(p[f"TC_{tag}0_TMIN"], p[f"TC_{tag}0_TMAX"], 40)
        ref = np.array([p[f"TC_{tag}0_TREF"]])
        for i, ax in enumerate("xyz"):
            c = f"{sensor}_{ax}"
            k = mf.models[c].unit_to_si
            f = want.predict_channel(c, temp[:, None])[0] * k
            f_ref = want.predict_channel(c, ref[:, None])[0] * k
            scale = max(np.abs(f - f_ref).max(), 1e-12)
            # PX4: offset = X0 + X1 d + X2 d² + X3 d³, d = T − TREF; its change from TREF
            d = temp - p[f"TC_{tag}0_TREF"]
            offset = sum(p[f"TC_{tag}0_X{j}_{i}"] * d**j for j in range(4))
            np.testing.assert_allclose(offset - offset[0] + (f[0] - f_ref[0]), f - f_ref,
                                       rtol=0, atol=1e-6 * scale)  # fmt: skip
            # ArduPilot: v −= P(T − 35) − P(CALTEMP − 35), P(d) = (c1 + (c2 + c3 d) d) d 1e−6
            t_ap = np.linspace(lo, hi, 40)
            co = [a[f"INS_TCAL1_{gtag}{j}_{ax.upper()}"] for j in (1, 2, 3)]

            def poly(x: np.ndarray, co: list[float] = co) -> np.ndarray:
                return (co[0] + (co[1] + co[2] * x) * x) * x * 1e-6

            g = want.predict_channel(c, t_ap[:, None])[0] * k
            np.testing.assert_allclose(
                poly(t_ap - 35.0) - poly(t_ap[:1] - 35.0), g - g[0], rtol=0, atol=1e-6 * scale
            )


def test_an_old_auto_file_without_cubics_is_refused_by_name(tmp_path) -> None:
    """A schema-3 auto file (regression choices, no cubics kept) loads; the flight exports
    refuse it naming every channel and what to do; the C header still works."""
    mf = ThermalModelFile.load(OLD_AUTO)
    assert mf.method == "auto" and all("flight" not in mf.models[c].selection for c in CHANNELS)
    for fmt, extra in (("px4", IDS), ("ardupilot", [])):
        out = tmp_path / f"old.{fmt}"
        code, text = _run(["export", OLD_AUTO, "--format", fmt, "--out", out, *extra])
        flat = " ".join(text.split())
        assert code == 2 and not out.exists(), text
        assert all(f"{c} is a regression model" in flat for c in CHANNELS), flat
        assert "--method auto" in flat and "--method poly-t" in flat and "--format c" in flat
        assert "schema version < 4" in flat and "Traceback" not in text
    _ok(["export", OLD_AUTO, "--format", "c", "--out", tmp_path / "old.h"])


def test_a_regression_fit_is_refused_by_name(soak, tmp_path) -> None:
    path, _, _ = soak
    model = tmp_path / "r.json"
    _ok(["fit", path, "--method", "regression", "--out", model])
    code, text = _run(["export", model, "--format", "ardupilot", "--out", tmp_path / "r.parm"])
    flat = " ".join(text.split())
    assert code == 2 and "gyro_x is a regression model" in flat and "accel_z" in flat
    assert "not fitted with --method auto" in flat and "--format c" in flat


def test_px4_instance_and_device_ids_travel_through_the_substitution(soak, tmp_path) -> None:
    """A model fitted on a ULog instance (source instance and device ids) exports into that
    instance's set with its ids, no option, its regression channels as their best cubics."""
    _, model, _ = soak
    mf = ThermalModelFile.load(model)
    source = {**mf.source, "instance": 1, "device_ids": {"gyro": 2293776, "accel": 3000000000}}
    moved = dataclasses.replace(mf, source=source).save(tmp_path / "ulog.json")
    out = tmp_path / "ulog.params"
    text = _ok(["export", moved, "--format", "px4", "--out", out])
    written = out.read_text()
    assert "1\t1\tTC_G1_ID\t2293776\t6" in written
    assert f"1\t1\tTC_A1_ID\t{3000000000 - 2**32}\t6" in written and "TC_G0_" not in written
    assert "in place of the model's regression" in written and "auto chose" in text
    parm = tmp_path / "ulog.parm"
    _ok(["export", moved, "--format", "ardupilot", "--out", parm])
    assert "INS_TCAL2_ENABLE 1" in parm.read_text()


def test_the_kept_cubics_are_checked_on_load(soak, tmp_path) -> None:
    """``selection.flight`` is part of the checksummed, validated file: a model there that
    the firmware cannot hold is refused on load, naming the key."""
    _, model, _ = soak
    doc = json.loads(model.read_text())
    assert doc["schema_version"] == 4
    sel = doc["payload"]["channel_models"]["gyro_x"]["selection"]
    assert set(sel["flight"]) <= FLIGHT and "poly-t 3" in sel["flight"]
    sel["flight"]["poly-t 3"] = {"method": "poly-t", "t_ref": 20.0, "coef": [1.0] * 6}
    doc["sha256"] = payload_sha256(doc["payload"])
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match=r"selection\.flight\.poly-t 3: a poly-t of degree"):
        ThermalModelFile.load(bad)


def test_the_kept_cubics_are_the_fixed_methods_fits(soak, soak_small) -> None:
    """Each kept cubic is what `fit --method poly-t|px4|ardupilot` gives the channel."""
    _, model, meta = soak
    mf = ThermalModelFile.load(model)
    for c in ("gyro_x", "accel_z"):
        flight = mf.models[c].selection["flight"]
        assert {"px4", "ardupilot", "poly-t 3", "none"} <= set(flight)
        for name, got in flight.items():
            want = _fixed_fit(soak_small[0], meta, c, name)
            assert got["method"] == want["method"], name
            for key in ("t_ref", "t_min", "t_max"):  # a poly-t has no clamp of its own
                if want.get(key) is None:
                    assert got.get(key) is None, (name, key)
                else:
                    assert got.get(key) == pytest.approx(want[key], rel=1e-12), (name, key)
            scale = np.abs(want["coef"]).max()
            np.testing.assert_allclose(got["coef"], want["coef"], rtol=1e-9, atol=1e-12 * scale)

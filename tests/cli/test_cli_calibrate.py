"""`rinscal fit/select/compensate/evaluate/export`: end to end on small simulated logs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from rinscal.calibration.modelfile import ThermalModelFile, payload_sha256
from rinscal.cli import app
from rinscal.io.metadata import write_meta
from rinscal.io.tables import read_log, write_log
from rinscal.schema import CHANNELS

runner = CliRunner()


@pytest.fixture(scope="module")
def logs(tmp_path_factory, soak_small, repeat_small) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("cli")
    out = {}
    for name, (log, _, meta) in (("soak", soak_small), ("repeat", repeat_small)):
        path = d / f"{name}.csv"
        write_log(log, path)
        write_meta(meta, path)
        out[name] = path
    return out


def _ok(args: list[str]) -> str:
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return res.output


@pytest.mark.parametrize(
    "method", ["poly-t", "sectional", "regression", pytest.param("neural", marks=pytest.mark.slow)]
)
def test_fit_writes_a_valid_model(method, logs, tmp_path) -> None:
    out = tmp_path / "m.json"
    extra = ["--max-samples", "1500"] if method == "neural" else []
    text = _ok(["fit", logs["soak"], "--method", method, "--out", out, *extra])
    assert "wrote" in text and "accel_z" in text
    mf = ThermalModelFile.load(out)
    assert mf.method == method and mf.channels == CHANNELS
    assert mf.models["gyro_x"].unit == "deg/h" and mf.source["log"] == "soak.csv"


def test_fit_options_reach_the_model(logs, tmp_path) -> None:
    out = tmp_path / "m.json"
    _ok(
        [
            "fit",
            logs["soak"],
            "--method",
            "regression",
            "--orders",
            "2,1,0",
            "--out",
            out,
            "--window",
            "90",
            "--causal",
        ]
    )
    mf = ThermalModelFile.load(out)
    assert mf.models["accel_x"].params["orders"] == [2, 1, 0]
    assert mf.derivative_window_s == 90.0 and mf.derivative_kind == "causal"
    _ok(["fit", logs["soak"], "--method", "sectional", "--edges", "10,20,30", "--out", out])
    assert ThermalModelFile.load(out).models["gyro_y"].params["edges"] == [10.0, 20.0, 30.0]


def test_fit_refuses_bad_options_and_its_input(logs, tmp_path) -> None:
    for args, msg in [
        (["--method", "spline", "--out", tmp_path / "m.json"], "--method"),
        (["--method", "regression", "--orders", "3,3", "--out", tmp_path / "m.json"], "orders"),
        (["--method", "neural", "--orders", "a,b", "--out", tmp_path / "m.json"], "--orders"),
        (["--method", "poly-t", "--out", logs["soak"]], "refusing to overwrite"),
    ]:
        res = runner.invoke(app, ["fit", str(logs["soak"]), *map(str, args)])
        assert res.exit_code == 2 and msg in res.output, res.output


def test_compensate_then_evaluate(logs, tmp_path) -> None:
    model = tmp_path / "reg.json"
    _ok(["fit", logs["soak"], "--method", "regression", "--out", model])
    out = tmp_path / "comp.parquet"
    text = _ok(["compensate", logs["repeat"], "--model", model, "--out", out])
    assert "rows" in text
    raw, comp = read_log(logs["repeat"]), read_log(out)
    assert len(comp) == len(raw) and list(comp.columns) == [*raw.columns, "out_of_range"]
    np.testing.assert_array_equal(comp["time_s"], raw["time_s"])
    meta = json.loads(Path(str(out) + ".meta.json").read_text())
    assert meta["compensated"]["method"] == "regression"
    # compensated accelerometers still read gravity on z (static reference kept): the
    # thermal drift (1.3 mg of scale factor × g on z) is gone, gravity is not
    g = json.loads(Path(str(logs["repeat"]) + ".meta.json").read_text())["static_output"]
    assert abs(comp["accel_z"].mean() - g["accel_z"]) < 100.0  # µg
    assert abs(raw["accel_z"].mean() - g["accel_z"]) > 500.0
    doc = json.loads(_ok(["evaluate", logs["repeat"], "--model", model, "--json"]))
    rows = {r["channel"]: r for r in doc["rows"]}
    assert set(rows) == set(CHANNELS) and "about each run's mean" in doc["rms"]
    assert rows["accel_x"]["rms_after"] < rows["accel_x"]["rms_before"] * 1.2
    assert "RMS" in _ok(["evaluate", logs["repeat"], "--model", model])


def test_compensate_refuses_to_overwrite_inputs(logs, tmp_path) -> None:
    model = tmp_path / "p.json"
    _ok(["fit", logs["soak"], "--method", "poly-t", "--out", model])
    for target in (logs["repeat"], model):
        before = Path(target).read_bytes()
        res = runner.invoke(
            app, ["compensate", str(logs["repeat"]), "--model", str(model), "--out", str(target)]
        )
        assert res.exit_code == 2 and "refusing to overwrite" in res.output
        assert Path(target).read_bytes() == before
    # a model of the 25 °C run only, applied to the soak runs from 0 to 42 °C
    narrow = tmp_path / "narrow.json"
    _ok(["fit", logs["repeat"], "--method", "poly-t", "--out", narrow])
    res = runner.invoke(
        app,
        [
            "compensate",
            str(logs["soak"]),
            "--model",
            str(narrow),
            "--out",
            str(tmp_path / "x.csv"),
            "--policy",
            "error",
        ],
    )
    assert res.exit_code == 2 and "outside [" in res.output and "training data" in res.output
    assert not (tmp_path / "x.csv").exists()


def test_corrupt_model_file_is_a_clear_error(logs, tmp_path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "rinscal-thermal-model", "schema_version": 1, "sha')
    res = runner.invoke(app, ["evaluate", str(logs["repeat"]), "--model", str(bad)])
    assert res.exit_code == 2 and "bad.json: not valid JSON" in res.output


@pytest.mark.parametrize(
    ("channel", "unit", "unit_to_si", "message"),
    [
        (
            "gyro_z",
            "furlong/fortnight",
            None,
            "'furlong/fortnight' is not one rinscal knows for gyro",
        ),
        ("gyro_x", "ug", None, "'ug' is not one rinscal knows for gyro"),
        ("accel_y", "deg/h", None, "'deg/h' is not one rinscal knows for accel"),
        ("accel_z", "ug", 1.0, "1.0 is not the SI value of one ug"),
    ],
)
def test_a_model_file_with_an_unknown_unit_is_refused(
    channel, unit, unit_to_si, message, logs, tmp_path
) -> None:
    # issue 21, item 5: a unit edited in (checksum recomputed) was applied without a word
    m = tmp_path / "m.json"
    _ok(["fit", logs["soak"], "--method", "poly-t", "--out", m])
    doc = json.loads(m.read_text())
    cm = doc["payload"]["channel_models"][channel]
    cm["unit"] = unit
    if unit_to_si is not None:
        cm["unit_to_si"] = unit_to_si
    doc["sha256"] = payload_sha256(doc["payload"])
    m.write_text(json.dumps(doc))
    for cmd in (
        ["compensate", logs["soak"], "--model", m, "--out", tmp_path / "c.csv"],
        ["evaluate", logs["soak"], "--model", m],
        ["export", m, "--format", "c", "--out", tmp_path / "m.h"],
    ):
        res = runner.invoke(app, [str(a) for a in cmd])
        assert res.exit_code == 2, res.output
        assert f"channel_models.{channel}" in res.output and message in res.output, res.output
        assert "Traceback" not in res.output
    assert not (tmp_path / "c.csv").exists() and not (tmp_path / "m.h").exists()


def test_fit_refuses_a_log_whose_metadata_names_an_unknown_unit(logs, tmp_path) -> None:
    log = tmp_path / "soak.csv"
    log.write_bytes(logs["soak"].read_bytes())
    meta = json.loads(Path(f"{logs['soak']}.meta.json").read_text())
    meta["units"]["gyro_z"] = "furlong/fortnight"
    Path(f"{log}.meta.json").write_text(json.dumps(meta))
    res = runner.invoke(
        app, ["fit", str(log), "--method", "poly-t", "--out", str(tmp_path / "m.json")]
    )
    assert res.exit_code == 2, res.output
    assert "gyro_z" in res.output and "furlong/fortnight" in res.output, res.output
    assert not (tmp_path / "m.json").exists()


def test_select_json(logs) -> None:
    doc = json.loads(
        _ok(["select", logs["soak"], "--method", "regression", "--settings", "1,2", "--json"])
    )
    assert doc["method"] == "regression" and set(doc["recommended"]) == set(CHANNELS)
    assert len(doc["table"]) == 12 and doc["units"]["accel_x"] == "ug"
    assert "recommended" in _ok(
        ["select", logs["soak"], "--method", "regression", "--settings", "1,2"]
    )


def test_export_formats(logs, tmp_path) -> None:
    model = tmp_path / "p.json"
    _ok(["fit", logs["soak"], "--method", "poly-t", "--out", model])
    ids = ["--gyro-id", "2293768", "--accel-id", "2294024"]
    for fmt, name, needle in (
        ("px4", "t.params", "TC_A0_X3_2"),
        ("ardupilot", "t.parm", "INS_TCAL1_GYR3_Z"),
        ("c", "t.h", "static inline double rinscal_accel_z"),
    ):
        _ok(
            [
                "export",
                model,
                "--format",
                fmt,
                "--out",
                tmp_path / name,
                *(ids if fmt == "px4" else []),
            ]
        )
        assert needle in (tmp_path / name).read_text()
    res = runner.invoke(app, ["export", str(model), "--format", "c", "--out", str(model)])
    assert res.exit_code == 2 and "refusing to overwrite" in res.output


def test_foreign_log_through_options(tmp_path) -> None:
    # the real log's layout: µs timestamps, dotted names, one temperature, tab separated
    rng = np.random.default_rng(0)
    n = 600
    t_us = 256551281491968 + np.arange(n) * 500_000
    temp = 20 + 30 * np.sin(np.arange(n) / 200)
    lines = [
        "timestamp\timu.acc.x\timu.acc.y\timu.acc.z\timu.gyro.x\timu.gyro.y\timu.gyro.z"
        "\timu.temperature"
    ]
    for i in range(n):
        vals = [0.1 + 1e-3 * temp[i], -0.05, -9.5, 0.01 * temp[i] / 50, 0.0, 0.02]
        vals = [v + rng.normal(0, 1e-4) for v in vals]
        lines.append(
            "\t".join([str(t_us[i]), *(repr(float(v)) for v in vals), repr(float(temp[i]))])
        )
    path = tmp_path / "imu.tsv"
    path.write_text("\n".join(lines) + "\n")
    cols = [
        "imu.acc.x=accel_x",
        "imu.acc.y=accel_y",
        "imu.acc.z=accel_z",
        "imu.gyro.x=gyro_x",
        "imu.gyro.y=gyro_y",
        "imu.gyro.z=gyro_z",
    ]
    opts = [x for c in cols for x in ("--col", c)]
    opts += ["--time-col", "timestamp", "--time-unit", "us", "--temp-col", "imu.temperature"]
    out = tmp_path / "m.json"
    res = runner.invoke(app, ["fit", str(path), "--method", "regression", "--out", str(out), *opts])
    assert res.exit_code == 0, res.output
    assert "temp_out" in res.output  # the gradient drops out, with a warning
    mf = ThermalModelFile.load(out)
    assert not mf.use_gradient and mf.models["accel_x"].static_reference is None


def test_auto_is_the_default_and_every_command_shows_its_choice(logs, tmp_path) -> None:
    model = tmp_path / "auto.json"
    text = _ok(["fit", logs["soak"], "--out", model])
    mf = ThermalModelFile.load(model)
    assert mf.method == "auto"
    chosen = {c: mf.models[c].selection["chosen"] for c in CHANNELS}
    assert "leave-one-run-out over 7 folds" in " ".join(text.split())
    # select --method auto: every candidate with its held-out RMS, the choice marked
    text = _ok(["select", logs["soak"], "--json"])
    doc = json.loads(text)
    assert doc["channels"]["accel_z"]["chosen"] == chosen["accel_z"]
    assert {r["name"] for r in doc["channels"]["gyro_x"]["table"]} >= {"none", "px4", "ardupilot"}
    # evaluate: the model per channel, the flagged share, the Allan table and plot
    fig = tmp_path / "allan.png"
    text = _ok(["evaluate", logs["repeat"], "--model", model, "--allan-plot", fig])
    flat = " ".join(text.split())
    assert "Allan deviation (overlapping)" in flat and "outside the training data" in flat
    assert fig.stat().st_size > 20_000
    doc = json.loads(_ok(["evaluate", logs["repeat"], "--model", model, "--json"]))
    assert doc["channel_models"] == chosen
    assert {r["output"] for r in doc["allan"]} == {"raw", "compensated"}
    # compensate --policy fallback: the share of flagged rows per run
    out = tmp_path / "comp.csv"
    text = _ok(
        ["compensate", logs["repeat"], "--model", model, "--out", out, "--policy", "fallback"]
    )
    assert "repeat_+25C:" in text and "% of rows flagged" in text


def test_fit_guard_messages_name_the_file(logs, tmp_path) -> None:
    bad = tmp_path / "hot.csv"
    log = read_log(logs["soak"])
    log.loc[5, "temp_out"] = 1e300
    write_log(log, bad)
    res = runner.invoke(
        app, ["fit", str(bad), "--method", "poly-t", "--out", str(tmp_path / "m.json")]
    )
    assert res.exit_code == 2
    assert f"{bad}: column 'temp_out'" in res.output and "data row 6" in res.output
    # the range is an option
    res = runner.invoke(
        app,
        [
            "fit",
            str(bad),
            "--method",
            "poly-t",
            "--temp-range",
            "-60,1e301",
            "--out",
            str(tmp_path / "m.json"),
        ],
    )
    assert res.exit_code == 0, res.output

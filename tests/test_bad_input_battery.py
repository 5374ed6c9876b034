"""Bad input, as a hostile new user gives it, answered at the boundary (issue 34, item 4).

Each case was found by a battery of about 450 bad inputs run against the CLI and the Python
API (wrong types, empty tables, edited sidecars, conflicting options, outputs onto inputs),
and each failed before its fix: a traceback, an error from deep inside (``KeyError: 'run'``,
``AttributeError``, numpy's ``could not convert``, a ``MemoryError``), a message naming the
wrong thing, an input overwritten, or a silent success that ignored what the user gave.
Every answer must now be one of the project's errors (the CLI: exit code 2, no traceback)
naming the argument, option, file or key, and leave the inputs as they were.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from typer.testing import CliRunner

import rinscal
from rinscal.cli import app
from rinscal.errors import ArgumentTypeError, ConfigError, LogError, RinscalError
from rinscal.io.mapping import ColumnMapping

runner = CliRunner()


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Any]:
    """A tiny simulated soak (CSV + sidecar metadata) and a model fitted on it."""
    d = tmp_path_factory.mktemp("battery")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log, _, meta = rinscal.simulate("soak", hours=0.05, rate_hz=1.0, seed=0)
        model = rinscal.fit(log, "poly-t", meta=meta).model
    src = d / "soak.csv"
    rinscal.write_log(log, src)
    rinscal.write_meta(meta, src)
    model.save(d / "m.json")
    return {"dir": d, "log": log, "meta": meta, "model": model}


def _digest(folder: Path) -> dict[str, str]:
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir() if p.is_file()
    }


# ----------------------------------------------------------------------------------- CLI
#: (id, command line with {d} for the folder, words the message must hold, a file the
#: command must not leave behind). Every command must exit 2 with no traceback and leave
#: every file of the folder as it was.
CLI_CASES: list[tuple[str, list[str], list[str], str | None]] = [
    (
        "fit --out onto the log's sidecar metadata",
        ["fit", "{d}/soak.csv", "--method", "poly-t", "--out", "{d}/soak.csv.meta.json"],
        ["refusing to overwrite", "soak.csv.meta.json"],
        None,
    ),
    (
        "calibrate-imu --out onto the log's sidecar metadata",
        ["calibrate-imu", "{d}/soak.csv", "--out", "{d}/soak.csv.meta.json"],
        ["refusing to overwrite", "soak.csv.meta.json"],
        None,
    ),
    (
        "fit --out a model file named as a log",
        ["fit", "{d}/soak.csv", "--method", "poly-t", "--out", "{d}/model.csv"],
        ["model.csv", ".json"],
        "model.csv",
    ),
    (
        "calibrate-imu --out a text file",
        ["calibrate-imu", "{d}/soak.csv", "--out", "{d}/imu.txt"],
        ["imu.txt", ".json"],
        "imu.txt",
    ),
    (
        "fit with two static references (--latitude/--heading and --static-ref)",
        [
            "fit",
            "{d}/soak.csv",
            "--method",
            "poly-t",
            "--out",
            "{d}/o.json",
            "--latitude",
            "30",
            "--heading",
            "0",
            "--static-ref",
            "mean",
        ],
        ["--static-ref", "--latitude"],
        "o.json",
    ),
    (
        "select --settings with --method auto (ignored before)",
        ["select", "{d}/soak.csv", "--settings", "1,2"],
        ["--settings", "auto"],
        None,
    ),
    (
        "evaluate --allan-plot with a suffix matplotlib would write PNG bytes into",
        ["evaluate", "{d}/soak.csv", "--model", "{d}/m.json", "--allan-plot", "{d}/a.gif"],
        ["--allan-plot", "a.gif", ".png, .pdf or .svg"],
        "a.gif",
    ),
    (
        "simulate soak with a multiposition option (ignored before)",
        [
            "simulate",
            "soak",
            "--hours",
            "0.01",
            "--rate",
            "1",
            "--out",
            "{d}/o.csv",
            "--set-points",
            "10",
        ],
        ["--set-points", "multiposition only"],
        "o.csv",
    ),
    (
        "simulate soak --ramp (ignored before)",
        ["simulate", "soak", "--hours", "0.01", "--rate", "1", "--out", "{d}/o.csv", "--ramp"],
        ["--ramp", "multiposition only"],
        "o.csv",
    ),
    (
        "simulate multiposition --rates -10 (the message said 'rate', as --rate)",
        ["simulate", "multiposition", "--rate", "1", "--rates", "-10", "--out", "{d}/o.csv"],
        ["--rates", "-10"],
        "o.csv",
    ),
    (
        "navigate --track-utc-start without a track (ignored before)",
        [
            "navigate",
            "--log",
            "{d}/soak.csv",
            "--site",
            "30,100,0",
            "--out",
            "{d}/nav",
            "--track-utc-start",
            "yesterday",
        ],
        ["--track-utc-start", "--track"],
        "nav",
    ),
    (
        "navigate --log a folder",
        ["navigate", "--log", "{d}", "--site", "30,100,0", "--out", "{d}/nav"],
        ["is a folder, not a file"],
        "nav",
    ),
    (
        "navigate --model a folder",
        ["navigate", "-s", "quasi-static", "--model", "{d}", "--out", "{d}/nav"],
        ["is a folder, not a file"],
        "nav",
    ),
    (
        "simulate --out into a missing folder",
        ["simulate", "soak", "--hours", "0.05", "--rate", "1", "--out", "{d}/nodir/s.csv"],
        ["nodir", "does not exist"],
        "nodir",
    ),
]


@pytest.mark.parametrize(
    ("case", "argv", "words", "absent"), CLI_CASES, ids=[c[0] for c in CLI_CASES]
)
def test_cli_refuses_at_the_boundary(files, case, argv, words, absent) -> None:
    d = files["dir"]
    before = _digest(d)
    res = runner.invoke(app, [a.format(d=d) for a in argv])
    assert res.exit_code == 2, (case, res.output, res.exception)
    assert "Traceback" not in res.output
    for w in words:
        assert w in res.output, (case, w, res.output)
    assert _digest(d) == before, case  # no input changed, nothing written
    if absent is not None:
        assert not (d / absent).exists(), case


@pytest.mark.parametrize("name", ["nope.parquet", "folder"])
def test_calibrate_imu_names_a_missing_log_once(tmp_path, monkeypatch, name) -> None:
    """Before: 'nope.parquet: nope.parquet: no such file'."""
    monkeypatch.chdir(tmp_path)  # short relative paths: the message is not wrapped
    (tmp_path / "folder").mkdir()
    res = runner.invoke(app, ["calibrate-imu", name, "--out", "i.json"])
    assert res.exit_code == 2, res.output
    assert res.output.count(f"{name}:") == 1, res.output


@pytest.mark.parametrize(
    ("sidecar", "words"),
    [
        ({"units": [1]}, ["units", "must be an object"]),  # was AttributeError, a traceback
        ({"units": "deg/h"}, ["units", "must be an object"]),  # the same
        ({"units": {"gyro_x": 42}}, ["units.gyro_x", "42"]),  # the file was not named
        ({"unit_to_si": {"gyro_x": "big"}}, ["unit_to_si.gyro_x", "'big'"]),  # ignored
        ({"latitude_deg": "north", "heading_deg": 0.0}, ["latitude_deg", "'north'"]),  # ignored
        ({"rate_hz": "fast"}, ["rate_hz", "'fast'"]),  # ignored
    ],
    ids=[
        "units-list",
        "units-text",
        "unit-number",
        "unit_to_si-text",
        "latitude-text",
        "rate-text",
    ],
)
def test_an_edited_sidecar_is_refused_naming_file_and_key(files, tmp_path, sidecar, words) -> None:
    src = tmp_path / "L.csv"
    src.write_bytes((files["dir"] / "soak.csv").read_bytes())
    (tmp_path / "L.csv.meta.json").write_text(json.dumps(sidecar))
    res = runner.invoke(
        app, ["fit", str(src), "--method", "poly-t", "--out", str(tmp_path / "m.json")]
    )
    assert res.exit_code == 2, (res.output, res.exception)
    assert "L.csv.meta.json" in res.output
    for w in words:
        assert w in res.output, (w, res.output)
    assert not (tmp_path / "m.json").exists()


def test_allan_plot_is_written_in_the_format_its_suffix_names(files, tmp_path) -> None:
    """Before, --allan-plot a.svg (or .pdf) held PNG bytes under that name."""
    d = files["dir"]
    for name, head in (("a.svg", b"<?xml"), ("a.pdf", b"%PDF"), ("a.png", b"\x89PNG")):
        out = tmp_path / name
        res = runner.invoke(
            app,
            [
                "evaluate",
                str(d / "soak.csv"),
                "--model",
                str(d / "m.json"),
                "--allan-plot",
                str(out),
            ],
        )
        assert res.exit_code == 0, res.output
        assert out.read_bytes().startswith(head), name


# ----------------------------------------------------------------------------------- API
def _api_cases(f: dict[str, Any]) -> list[tuple[str, Callable[[], Any], type, list[str]]]:
    d, log, meta, model = f["dir"], f["log"], f["meta"], f["model"]
    r = rinscal
    return [
        # ThermalModel, a public class: its fit took any table (pandas KeyError: 'run')
        (
            "ThermalModel.fit(empty table)",
            lambda: r.ThermalModel("regression").fit(pd.DataFrame()),
            LogError,
            ["log", "no rows"],
        ),
        (
            "ThermalModel.fit(a path)",
            lambda: r.ThermalModel("regression").fit(str(d / "soak.csv")),
            ArgumentTypeError,
            ["log"],
        ),
        (
            "ThermalModel.fit(no run column)",
            lambda: r.ThermalModel("regression").fit(log.drop(columns="run")),
            LogError,
            ["run"],
        ),
        (
            "ThermalModel(orders='1,1,0')",
            lambda: r.ThermalModel("regression", orders="1,1,0"),
            ArgumentTypeError,
            ["orders"],
        ),
        (
            "ThermalModel(estimator_params='x')",
            lambda: r.ThermalModel("regression", estimator_params="x"),
            ArgumentTypeError,
            ["estimator_params"],
        ),
        (
            "select(estimator_params='x')",
            lambda: r.select(log, "regression", estimator_params="x"),
            ArgumentTypeError,
            ["estimator_params"],
        ),
        (
            "select(on_fit='print')",
            lambda: r.select(log, "regression", on_fit="print"),
            ArgumentTypeError,
            ["on_fit"],
        ),
        # callbacks: a string was accepted and never called (or failed where first called)
        (
            "fit(on_run='print')",
            lambda: r.fit(log, "poly-t", on_run="print"),
            ArgumentTypeError,
            ["on_run"],
        ),
        # mapping=: a TOML path given as is read as --instance, or ignored with a table
        (
            "read_log(path, 'map.toml')",
            lambda: r.read_log(d / "soak.csv", "map.toml"),
            ArgumentTypeError,
            ["mapping"],
        ),
        (
            "fit(path, mapping='x.toml')",
            lambda: r.fit(d / "soak.csv", "poly-t", mapping="x.toml"),
            ArgumentTypeError,
            ["mapping"],
        ),
        (
            "fit(table, mapping=ColumnMapping())",
            lambda: r.fit(log, "poly-t", mapping=ColumnMapping()),
            ConfigError,
            ["mapping", "DataFrame"],
        ),
        (
            "compensate(table, mapping='x.toml')",
            lambda: r.compensate(log, model, mapping="x.toml"),
            ArgumentTypeError,
            ["mapping"],
        ),
        (
            "evaluate(path, mapping=42)",
            lambda: r.evaluate(d / "soak.csv", model, mapping=42),
            ArgumentTypeError,
            ["mapping"],
        ),
        (
            "navigate(log=, mapping='m.toml')",
            lambda: r.navigate(log=d / "soak.csv", mapping="m.toml"),
            ArgumentTypeError,
            ["mapping"],
        ),
        # compensate_file wrote over its own input
        (
            "compensate_file(out=the log)",
            lambda: r.compensate_file(d / "soak.csv", model, d / "soak.csv"),
            ConfigError,
            ["out", "refusing to overwrite"],
        ),
        (
            "compensate_file(out=the log's sidecar)",
            lambda: r.compensate_file(d / "soak.csv", model, d / "soak.csv.meta.json"),
            ConfigError,
            ["refusing to overwrite"],
        ),
        (
            "compensate_file(out=the model)",
            lambda: r.compensate_file(d / "soak.csv", d / "m.json", d / "m.json"),
            ConfigError,
            ["refusing to overwrite"],
        ),
        # ranges the CLI has and the API had not
        (
            "calibrate_imu(max_degree=9)",
            lambda: r.calibrate_imu(log, meta, max_degree=9),
            ConfigError,
            ["max_degree"],
        ),
        (
            "simulate(hours=1e9)",
            lambda: r.simulate("soak", hours=1e9, rate_hz=1.0),
            ConfigError,
            ["hours", "72"],
        ),  # MemoryError
        (
            "simulate(rate_hz=1e9)",
            lambda: r.simulate("soak", hours=0.01, rate_hz=1e9),
            ConfigError,
            ["rate_hz", "2000"],
        ),
        (
            "navigate(hours=1e9)",
            lambda: r.navigate("quasi-static", hours=1e9),
            ConfigError,
            ["hours", "72"],
        ),
        (
            "simulate_multiposition(rates_dps=[-1])",
            lambda: r.simulate_multiposition(rates_dps=[-1.0], rate_hz=1.0),
            ConfigError,
            ["rates_dps"],
        ),
        # classes built in code: checked as a file read is
        (
            "ImuConfig(latitude_deg='30')",
            lambda: r.ImuConfig(latitude_deg="30"),
            ArgumentTypeError,
            ["latitude_deg"],
        ),
        (
            "ThermalModelFile(method='bogus')",
            lambda: r.ThermalModelFile("bogus", ("gyro_x",), {}),
            ConfigError,
            ["method", "bogus"],
        ),
        (
            "ThermalModelFile(no model for a channel)",
            lambda: r.ThermalModelFile("poly-t", ("gyro_x",), {}),
            ConfigError,
            ["gyro_x"],
        ),
        (
            "ThermalModelFile.predict('hot', 'fast')",
            lambda: model.predict("hot", "fast"),
            ArgumentTypeError,
            ["temp"],
        ),
    ]


API_IDS = [c[0] for c in _api_cases({"dir": Path(), "log": None, "meta": None, "model": None})]


@pytest.mark.parametrize("case", API_IDS)
def test_api_refuses_at_the_boundary(files, case) -> None:
    _, call, error, words = next(c for c in _api_cases(files) if c[0] == case)
    before = _digest(files["dir"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(RinscalError) as info:
            call()
    assert isinstance(info.value, error), (case, type(info.value), info.value)
    for w in words:
        assert w in str(info.value), (case, w, str(info.value))
    assert _digest(files["dir"]) == before, case

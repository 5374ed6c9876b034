"""``rinscal fleet fit``: every unit fitted as its own Dask task, resumable, checked against limits.

Six simulated units: one log is corrupt (reported as failed with its error), one has ten times
the gyro noise (flagged by the noise-density limit), the other four pass; a fleet interrupted
after two units resumes without refitting them.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner, Result

from rinscal.calibration.modelfile import ThermalModelFile
from rinscal.cli import app
from rinscal.errors import ConfigError
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log
from rinscal.production.fleet import (
    FleetLimits,
    FleetStore,
    _noise_density,
    fleet_report,
    run_fleet,
    unit_names,
)
from rinscal.sim.protocols import simulate_protocol

LIMITS = "[limits.gyro]\nmax_noise_density = {gyro}\n"


@pytest.fixture(scope="module")
def units(tmp_path_factory) -> dict[str, Path]:
    """Six units' soak logs (0.5 h, 0.5 Hz): u5 noisy, u6 corrupt."""
    d = tmp_path_factory.mktemp("fleet")
    out = {}
    for k in range(1, 6):
        log, _, meta = simulate_protocol(
            "soak", hours=0.5, rate_hz=0.5, seed=k, imu="navigation_grade"
        )
        if k == 5:  # ten times the white noise on every gyro
            rng = np.random.default_rng(5)
            for c in ("gyro_x", "gyro_y", "gyro_z"):
                log[c] = log[c] + rng.normal(0, 10 * 0.25, len(log))
        path = d / f"u{k}.csv"
        write_log(log, path)
        write_meta(meta, path)
        out[f"u{k}"] = path
    bad = d / "u6.csv"
    bad.write_text("time_s,run,gyro_x\n0,a,1\n0,a,2\n", encoding="utf-8")
    out["u6"] = bad
    return out


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0"
        ) as cl,
        Client(cl) as c,
    ):
        yield c


def test_noise_density_of_white_noise_is_sigma_sqrt_dt() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(20000) * 0.5  # 2 Hz
    y = rng.normal(0, 3.0, t.size) + 0.001 * t  # σ 3 plus a slow drift
    # white noise of σ per sample at interval dt: density σ·√dt
    assert _noise_density(y, t, np.zeros(t.size, int)) == pytest.approx(
        3.0 * np.sqrt(0.5), rel=0.03
    )


def test_fleet_fits_flags_and_reports(units, client, tmp_path) -> None:
    store = FleetStore(tmp_path / "fleet")
    run = run_fleet(list(units.values()), store, method="poly-t", client=client)
    assert (run.units, run.fitted, run.failed, run.skipped) == (6, 5, 1, 0)
    # every fitted unit: a model file that loads, an export, a summary
    for name in ("u1", "u2", "u3", "u4", "u5"):
        mf = ThermalModelFile.load(store.model_path(name))
        assert mf.method == "poly-t" and mf.source["log"] == f"{name}.csv"
        assert "static inline double" in store.export_path(name, "c").read_text()
    # noise limit between the normal units' gyro density and the noisy one's
    dens = {
        u: max(s["channels"][c]["noise_density"] for c in ("gyro_x", "gyro_y", "gyro_z"))
        for u, s in store.summaries().items()
    }
    # physics: the simulated white noise recovered (ARW [deg/√h] · 60 = [deg/h·√s]; VRW)
    from rinscal.sim.config import load_imu

    noise = load_imu("navigation_grade").noise  # the plant the logs were simulated on
    for u, summ in store.summaries().items():
        if u == "u5":
            continue
        for c, ch in summ["channels"].items():
            want = noise.gyro_arw_deg_rth * 60 if c.startswith("gyro") else noise.accel_vrw_ug_rthz
            assert ch["noise_density"] == pytest.approx(want, rel=0.1), (u, c)
    limit = 3 * max(v for u, v in dens.items() if u != "u5")
    assert dens["u5"] > limit
    (tmp_path / "lim.toml").write_text(LIMITS.format(gyro=limit), encoding="utf-8")
    report = fleet_report(store, FleetLimits.from_toml(tmp_path / "lim.toml"))
    verdict = dict(zip(report.verdicts["unit"], report.verdicts["verdict"], strict=True))
    assert verdict == {
        "u1": "pass",
        "u2": "pass",
        "u3": "pass",
        "u4": "pass",
        "u5": "fail",
        "u6": "failed",
    }
    why = report.verdicts.set_index("unit")["why"]
    assert "gyro_x noise density" in why["u5"] and "u6.csv" in why["u6"]
    # the distribution across units: every channel's figures and coefficients over 5 units
    dist = report.distribution.set_index(["channel", "name"])
    assert (dist.xs("noise_density", level="name")["n"] == 5).all()
    # the coefficients in physical units, named by their term (no internal coef[1])
    assert (dist.xs("T¹", level="name")["n"] == 5).all()
    assert not any("[" in str(n) for n in report.distribution["name"])
    t1 = report.distribution.set_index(["channel", "name"]).loc[("gyro_x", "T¹"), "unit_of"]
    assert t1 == "°/h/°C"
    span = dist.loc[("accel_z", "thermal_span")]
    assert span["min"] <= span["median"] <= span["max"] and span["sd"] > 0


def test_an_interrupted_fleet_resumes_without_refitting(units, client, tmp_path) -> None:
    store = FleetStore(tmp_path / "fleet")
    logs = [units[f"u{k}"] for k in range(1, 4)]
    done: list[str] = []

    def stop_after_one(unit: str, status: str) -> None:
        done.append(unit)
        raise KeyboardInterrupt  # as a Ctrl-C would, mid-fleet

    with pytest.raises(KeyboardInterrupt):
        run_fleet(logs, store, method="poly-t", client=client, on_unit=stop_after_one)
    stamp = store.model_path(done[0]).stat().st_mtime_ns
    run = run_fleet(logs, store, method="poly-t", client=client)
    assert (run.skipped, run.fitted) == (1, 2)
    assert store.model_path(done[0]).stat().st_mtime_ns == stamp  # not fitted again
    # a log that changed is fitted again
    before = store.summary_path("u1").read_text()
    units["u1"].touch()
    run = run_fleet(logs, store, method="poly-t", client=client)
    assert (run.skipped, run.fitted) == (2, 1) and store.summary_path("u1").read_text() != before


def test_a_folder_keeps_one_setting_and_limits_are_checked(units, tmp_path) -> None:
    store = FleetStore(tmp_path / "f")
    store.open({"method": "auto", "export": "c"})
    with pytest.raises(ConfigError, match="holds a fleet fitted with"):
        store.open({"method": "poly-t", "export": "c"})
    bad = tmp_path / "bad.toml"
    bad.write_text("[limits.gyro]\nmax_noise = 1\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"\[limits.gyro\]: unknown key 'max_noise'"):
        FleetLimits.from_toml(bad)
    bad.write_text("[limits.accel_z]\nmax_thermal_span = -1\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="max_thermal_span must be a positive number"):
        FleetLimits.from_toml(bad)


def test_fleet_cli_end_to_end(units, tmp_path) -> None:
    out = tmp_path / "cli"
    res = CliRunner().invoke(
        app,
        ["fleet", "fit", str(units["u1"]), str(units["u6"]), "--out", str(out), "--workers", "1"],
    )
    assert res.exit_code == 0, res.output
    assert "1 fitted, 1 failed" in res.output
    rows = (out / "verdicts.csv").read_text().splitlines()
    assert (
        rows[0] == "unit,verdict,why" and rows[1].startswith("u1,pass") and "u6,failed" in rows[2]
    )
    assert json.loads((out / "failed" / "u6.json").read_text())["error"].startswith(
        str(units["u6"])
    )
    page = (out / "report.html").read_text()
    assert 'data-table="verdicts"' in page and 'data-figure="fleet"' in page
    assert "2 unit(s): 1 pass, 0 fail, 1 failed to fit" in page


# --------------------------------------------------------------------------- unit names
def _place(src: Path, dst: Path) -> Path:
    """Copy a log and its sidecar metadata to ``dst`` (a production line's folder layout)."""
    from rinscal.io.metadata import meta_path

    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src, dst)
    if meta_path(src).exists():
        shutil.copy2(meta_path(src), meta_path(dst))
    return dst


def _fleet(*args: str) -> Result:
    return CliRunner().invoke(app, ["fleet", "fit", *args])


def test_unit_names_from_the_shortest_distinct_end_of_the_path(tmp_path) -> None:
    # unique file names: the file name without its suffix, as always
    assert unit_names([tmp_path / "a" / "u1.csv", tmp_path / "b" / "u2.parquet"]) == ["u1", "u2"]
    # a production line: one folder per serial number, the same file name in each
    logs = [tmp_path / "SN001" / "imu.csv", tmp_path / "SN002" / "imu.csv"]
    assert unit_names(logs) == ["SN001", "SN002"]
    # two lines with the same serial numbers: line and serial, joined by a '+'
    logs = [tmp_path / line / sn / "imu.csv" for line in ("lineA", "lineB") for sn in ("1", "2")]
    assert unit_names(logs) == ["lineA+1", "lineA+2", "lineB+1", "lineB+2"]
    # file names that differ but repeat: the folder and the file name
    logs = [tmp_path / "SN1" / "imu.csv", tmp_path / "SN1" / "imu_retest.csv"]
    logs.append(tmp_path / "SN2" / "imu.csv")
    assert unit_names(logs) == ["SN1+imu", "SN1+imu_retest", "SN2+imu"]
    # the same path, relative or absolute, is the same unit name
    assert unit_names([Path("SN3/imu.csv"), Path.cwd().parent / "SN4/imu.csv"]) == ["SN3", "SN4"]


def test_unit_names_refuse_logs_nothing_tells_apart(tmp_path) -> None:
    with pytest.raises(ConfigError, match=r"SN1/imu.csv is given twice"):
        unit_names([tmp_path / "SN1" / "imu.csv", tmp_path / "SN1" / ".." / "SN1" / "imu.csv"])
    with pytest.raises(ConfigError, match=r"SN1/imu.csv and .*SN1/imu.parquet both give"):
        unit_names([tmp_path / "SN1" / "imu.csv", tmp_path / "SN1" / "imu.parquet"])
    # folder names holding the separator: never two units under one name
    logs = [tmp_path / "r" / "a+b" / "c" / "imu.csv", tmp_path / "r" / "a" / "b+c" / "imu.csv"]
    assert unit_names(logs) == ["c", "b+c"]
    logs.append(tmp_path / "s" / "a+b" / "c" / "imu.csv")
    with pytest.raises(ConfigError, match=r"r/a\+b/c/imu.csv and .*r/a/b\+c/imu.csv both give"):
        unit_names(logs)


@pytest.fixture(scope="module")
def address():
    """An in-process cluster the CLI reaches by its address (no worker processes to start)."""
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cl:
        yield cl.scheduler_address


def test_fleet_cli_names_a_production_line_by_its_folders(
    units, address, tmp_path, monkeypatch
) -> None:
    line = tmp_path / "line"
    logs = [_place(units[f"u{k}"], line / f"SN00{k}" / "imu.csv") for k in (1, 2)]
    out = tmp_path / "out"
    res = _fleet(*map(str, logs), "--out", str(out), "--scheduler", address)
    assert res.exit_code == 0, res.output
    assert "2 fitted, 0 failed" in res.output
    # every output named after the unit: model, summary, export, report rows
    for sn in ("SN001", "SN002"):
        mf = ThermalModelFile.load(out / "units" / f"{sn}.json")
        assert (mf.source["log"], mf.source["unit"]) == ("imu.csv", sn)
        assert (out / "units" / f"{sn}.summary.json").is_file()
        assert (out / "exports" / f"{sn}.h").is_file()
    rows = (out / "verdicts.csv").read_text().splitlines()
    assert [r.split(",")[:2] for r in rows[1:]] == [["SN001", "pass"], ["SN002", "pass"]]
    # resumed from another folder, the logs given by other relative paths: the same units
    monkeypatch.chdir(line)
    res = _fleet("SN001/imu.csv", "SN002/imu.csv", "--out", str(out), "--scheduler", address)
    assert res.exit_code == 0, res.output
    assert "0 fitted, 0 failed, 2 already done" in res.output
    # one unit alone (its file name would do): the folder still knows it as SN002
    res = _fleet("SN002/imu.csv", "--out", str(out), "--scheduler", address)
    assert res.exit_code == 0 and "0 fitted, 0 failed, 1 already done" in res.output
    assert sorted(p.name for p in (out / "units").iterdir()) == [
        "SN001.json",
        "SN001.summary.json",
        "SN002.json",
        "SN002.summary.json",
    ]


def test_fleet_cli_two_lines_with_the_same_serials(address, tmp_path) -> None:
    """Units that fail to read are named, and remembered, as fitted ones (and fail fast)."""
    logs = [tmp_path / line / "SN001" / "imu.csv" for line in ("lineA", "lineB")]
    for p in logs:
        p.parent.mkdir(parents=True)
        p.write_text("time_s,run,gyro_x\n0,a,1\n0,a,2\n", encoding="utf-8")
    out = tmp_path / "out"
    res = _fleet(*map(str, logs), "--out", str(out), "--scheduler", address)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (out / "failed").iterdir()) == [
        "lineA+SN001.json",
        "lineB+SN001.json",
    ]
    verdicts = (out / "verdicts.csv").read_text()
    assert "lineA+SN001,failed" in verdicts and "lineB+SN001,failed" in verdicts
    # a third log named SN001-as-file beside them: the folder's lineA+SN001 is not taken
    other = tmp_path / "lineC" / "lineA+SN001.csv"
    other.parent.mkdir()
    other.write_text("time_s\n", encoding="utf-8")
    res = _fleet(str(logs[0]), str(other), "--out", str(out), "--scheduler", address)
    assert res.exit_code == 2, res.output
    text = " ".join(res.output.split())
    assert f"{other} would be unit 'lineA+SN001', but {out} holds unit 'lineA+SN001'" in text
    assert f"fitted from {logs[0]}" in text and "Traceback" not in res.output


def test_fleet_cli_refuses_logs_that_name_one_unit(tmp_path) -> None:
    logs = [tmp_path / "SN1" / "imu.csv", tmp_path / "SN1" / "imu.parquet"]
    for p in logs:
        p.parent.mkdir(exist_ok=True)
        p.write_text("time_s\n", encoding="utf-8")
    res = _fleet(*map(str, logs), "--out", str(tmp_path / "out"))
    assert res.exit_code == 2, res.output
    assert f"{logs[0]} and {logs[1]} both give the unit name 'SN1'" in " ".join(res.output.split())
    assert "Traceback" not in res.output and not (tmp_path / "out").exists()


def test_fleet_help_says_how_units_are_named() -> None:
    res = CliRunner().invoke(app, ["fleet", "fit", "--help"], terminal_width=200)
    assert res.exit_code == 0
    text = " ".join(res.output.split())
    assert "SN001/imu.csv" in text and "lineA/SN001/imu.csv" in text and "lineA+SN001" in text


def test_fleet_fit_with_a_method_other_than_auto_finishes(units, tmp_path) -> None:
    # a warning once sent the CLI's warning replay into an endless loop (the fleet figure's
    # all-NaN held-out RMS raised one): run in a process that a hang cannot stall
    out = tmp_path / "poly"
    code = "import sys; from rinscal.cli import main; sys.argv[0] = 'rinscal'; main()"
    args = ["fleet", "fit", str(units["u1"]), "--method", "poly-t", "--workers", "1"]
    res = subprocess.run(
        [sys.executable, "-c", code, *args, "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert res.returncode == 0, res.stderr
    assert "1 fitted, 0 failed" in res.stdout and "All-NaN" not in res.stderr
    assert (out / "report.html").stat().st_size > 0

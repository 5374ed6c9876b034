"""`rinscal plot` and the Figure-3 drawing of a calibration log (rinscal.report.logplot)."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure
from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.io.metadata import write_meta
from rinscal.io.tables import read_log, write_log
from rinscal.report.logplot import decimate, plot_log, pretty_unit, units_from_meta
from rinscal.schema import CHANNELS, TEMP_CHANNELS
from tests._flightlogs import px4_topics, write_ulog
from tests._shared import real_log_path

REPO = Path(__file__).resolve().parents[1]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def invoke(*args: str):
    """Run `rinscal plot ARGS` (Typer collapses a one-command app to that command)."""
    n = len(app.registered_commands) + len(app.registered_groups)
    single = n == 1 and app.registered_callback is None
    argv = list(args) if single else ["plot", *args]
    return CliRunner().invoke(app, argv)


def soak_log(n: int = 300, set_points=(0.0, 21.0, 42.0)) -> pd.DataFrame:
    """Small soak-like log: inner temperatures warm after power-on, outputs follow them."""
    rng = np.random.default_rng(11)
    frames = []
    for T in set_points:
        t = np.arange(n) * 10.0
        warm = T + 12.0 * (1.0 - np.exp(-t / 900.0))
        d: dict[str, object] = {"time_s": t, "run": f"soak_{T:+03.0f}C"}
        for j, ch in enumerate(CHANNELS):
            base = 10.0 if ch.startswith("gyro") else 1000.0 * (j - 2)
            d[ch] = base + 0.5 * warm + rng.standard_normal(n)
        for col in TEMP_CHANNELS:
            d[col] = np.round(warm + 0.1 * rng.standard_normal(n), 2)
        d["temp_out"] = T + 8.0 * (1.0 - np.exp(-t / 1500.0))
        d["chamber_temp"] = np.full(n, T)
        frames.append(pd.DataFrame(d))
    return pd.concat(frames, ignore_index=True)


UNITS = {ch: ("deg/h" if ch.startswith("gyro") else "ug") for ch in CHANNELS}


# ------------------------------------------------------------------ decimation


def test_decimate_keeps_every_extreme_and_the_trend():
    n = 100_000
    t = np.arange(n) * 0.01
    rng = np.random.default_rng(0)
    trend = 3.0 * t / t[-1]
    y = trend + 0.5 * rng.standard_normal(n)
    y[31_337] = 40.0  # a vibration outlier
    y[77_000] = -25.0
    y[5000:5010] = np.nan  # dropped samples
    d = decimate(t, y, max_bins=500)
    assert d.step == 200 and len(d.t) == 500
    assert np.nanmax(d.hi) == 40.0 and np.nanmin(d.lo) == -25.0  # nothing hidden
    assert np.all(d.lo <= d.mean) and np.all(d.mean <= d.hi)
    # bin means follow the trend through noise of 0.5/sqrt(200) ≈ 0.035 (outlier bins aside)
    resid = d.mean - 3.0 * d.t / t[-1]
    ok = (d.hi < 30) & (d.lo > -20)
    assert np.max(np.abs(resid[ok])) < 0.2
    assert np.all(np.isfinite(d.mean))  # NaN ignored inside a bin
    assert d.t[0] == pytest.approx(0.5 * (t[0] + t[199]))


def test_decimate_all_nan_bin_stays_nan_and_short_signals_untouched():
    t = np.arange(10.0)
    y = np.arange(10.0)
    y[4:6] = np.nan
    d = decimate(t, y, max_bins=5)
    assert d.step == 2
    np.testing.assert_array_equal(d.mean, [0.5, 2.5, np.nan, 6.5, 8.5])
    np.testing.assert_array_equal(d.lo, [0, 2, np.nan, 6, 8])
    np.testing.assert_array_equal(d.hi, [1, 3, np.nan, 7, 9])
    same = decimate(t, y, max_bins=10)
    assert same.step == 1 and same.mean is not None
    np.testing.assert_array_equal(same.mean, y)


# ------------------------------------------------------------------ the figure


def test_plot_log_draws_every_run_with_units_and_temperatures():
    df = soak_log()
    fig = plot_log(df, units=UNITS, max_bins=1000)
    assert isinstance(fig, Figure)
    axes = [ax for ax in fig.axes if ax.axison]
    assert len(axes) == 9  # 3 accels, 3 gyros, 3 temperature panels
    labels = [ax.get_ylabel() for ax in axes]
    assert "accel_x output [µg]" in labels and "gyro_z output [°/h]" in labels
    assert labels.count("temperature [°C]") == 3
    assert all("time since power-on [min]" == ax.get_xlabel() for ax in axes[-3:])
    # one colour per run, the same in every panel
    accel_x = axes[0]
    colors = [tuple(line.get_color()) for line in accel_x.get_lines()]
    assert len(colors) == 3 and len(set(colors)) == 3
    gyro_x = axes[3]
    assert [tuple(line.get_color()) for line in gyro_x.get_lines()] == colors
    # the drawn data are the log's (no decimation at this size)
    np.testing.assert_array_equal(accel_x.get_lines()[1].get_ydata(), df["accel_x"][300:600])
    legend_texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend_texts == ["soak_+00C", "soak_+21C", "soak_+42C"]
    assert "decimated" not in accel_x.get_title()


def test_plot_log_says_when_it_decimates():
    df = soak_log(n=3000)
    fig = plot_log(df, units=UNITS, max_bins=200)
    accel_x = fig.axes[0]
    assert "decimated" in accel_x.get_title() and "15 samples" in accel_x.get_title()
    line = accel_x.get_lines()[0]
    assert len(line.get_xdata()) == 200
    # the min/max band of the first run spans its true extremes
    band = accel_x.collections[0].get_paths()[0].vertices[:, 1]
    first = df["accel_x"][:3000]
    assert band.max() == pytest.approx(first.max()) and band.min() == pytest.approx(first.min())


def test_shared_temperature_and_unknown_units():
    df = soak_log().drop(columns=[*TEMP_CHANNELS, "temp_out", "chamber_temp"])
    df["temp_in"] = 20.0 + df["time_s"] / 1000.0
    fig = plot_log(df)
    shown = [ax for ax in fig.axes if ax.axison]
    assert len(shown) == 7
    assert shown[-1].get_title().startswith("inner temperature (shared)")
    assert shown[0].get_ylabel() == "accel_x output [log units]"
    assert pretty_unit("m/s^2") == "m/s²" and units_from_meta(None) == {}
    assert units_from_meta({"units": UNITS})["gyro_x"] == "deg/h"


# ------------------------------------------------------------------ the command


@pytest.fixture
def log_file(tmp_path) -> Path:
    path = tmp_path / "soak.parquet"
    write_log(soak_log(), path)
    write_meta({"units": UNITS, "rate_hz": 0.1}, path)
    return path


def test_plot_command_writes_a_png(tmp_path, log_file):
    out = tmp_path / "fig" / "soak.png"
    out.parent.mkdir()
    res = invoke(str(log_file), "--out", str(out))
    assert res.exit_code == 0, res.output
    data = out.read_bytes()
    assert data.startswith(PNG_MAGIC) and len(data) > 20_000
    assert "3 run(s)" in res.output
    assert sorted(p.name for p in out.parent.iterdir()) == ["soak.png"]  # no temp left


def test_plot_command_never_overwrites_its_input(tmp_path, log_file, monkeypatch):
    before = log_file.read_bytes()
    for target in (log_file, log_file.parent / "." / log_file.name):
        res = invoke(str(log_file), "--out", str(target))
        assert res.exit_code != 0
    # same file through a relative path and through a hard link
    monkeypatch.chdir(tmp_path)
    res = invoke("soak.parquet", "--out", "./soak.parquet")
    assert res.exit_code == 2
    link = tmp_path / "link.png"
    os.link(log_file, link)
    res = invoke(str(log_file), "--out", str(link))
    assert res.exit_code == 2 and "refusing to overwrite the input" in res.output
    assert log_file.read_bytes() == before == link.read_bytes()
    meta = tmp_path / "soak.parquet.meta.json"
    meta_text = meta.read_text()
    res = invoke(str(log_file), "--out", str(meta))
    assert res.exit_code == 2 and meta.read_text() == meta_text


def test_plot_command_reports_bad_input_cleanly(tmp_path, log_file):
    res = invoke(str(log_file), "--out", str(tmp_path / "fig.jpgx"))
    assert res.exit_code == 2 and "unknown figure suffix" in res.output
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,run,gyro_x\n0,a,1\n")
    res = invoke(str(bad), "--out", str(tmp_path / "bad.png"))
    assert res.exit_code == 2
    assert "bad.csv" in res.output and "missing required column" in res.output
    assert not (tmp_path / "bad.png").exists()


def test_plot_command_reads_a_foreign_log_through_options(tmp_path):
    df = read_log(_write_canonical(tmp_path))
    foreign = pd.DataFrame(
        {
            "t_ms": (df["time_s"] * 1000).astype(np.int64) + 10**12,
            **{f"imu.{ch}": df[ch] for ch in CHANNELS},
            "T": df["temp_in"],
        }
    )
    path = tmp_path / "foreign.tsv"
    foreign.to_csv(path, sep="\t", index=False)
    args = [str(path), "--out", str(tmp_path / "f.png"), "--time-col", "t_ms"]
    args += ["--time-unit", "ms", "--temp-col", "T"]
    for ch in CHANNELS:
        args += ["--col", f"imu.{ch}={ch}"]
    res = invoke(*args)
    assert res.exit_code == 0, res.output
    assert "1 run(s), 40 samples" in res.output


def _write_canonical(tmp_path: Path) -> Path:
    df = soak_log(n=40, set_points=(25.0,)).drop(columns=[*TEMP_CHANNELS])
    df["temp_in"] = 25.0 + df["time_s"] / 100.0
    path = tmp_path / "one.csv"
    write_log(df, path)
    return path


def svg_texts(path: Path) -> list[str]:
    """The texts of a figure saved as SVG (matplotlib draws text as paths, each after a
    comment holding the text)."""
    return re.findall(r"<!-- (.*?) -->", path.read_text(encoding="utf-8"))


def test_plot_of_a_flight_log_labels_its_known_units(tmp_path):
    t = 1.0 + np.arange(200) / 50.0
    temp = (30.0 + t).astype(np.float32)
    gyro = np.full((t.size, 3), 0.01, np.float32)
    accel = np.tile(np.float32([0.0, 0.0, -9.81]), (t.size, 1))
    path = write_ulog(tmp_path / "warm.ulg", px4_topics(t, gyro, accel, temp, 0, 7, 8))
    out = tmp_path / "warm.svg"
    res = invoke(str(path), "--out", str(out))
    assert res.exit_code == 0, res.output
    texts = svg_texts(out)
    assert "gyro_z output [rad/s]" in texts and "accel_x output [m/s²]" in texts
    assert not [x for x in texts if "log units" in x]
    # a sidecar may give the units per sensor ("gyro", "accel") as well as per channel
    units = units_from_meta({"units": {"gyro": "deg/h", "accel_z": "ug", "accel": "m/s^2"}})
    assert units == {"gyro_x": "deg/h", "gyro_y": "deg/h", "gyro_z": "deg/h",
                     "accel_x": "m/s^2", "accel_y": "m/s^2", "accel_z": "ug"}  # fmt: skip
    assert "accel_x" not in units_from_meta({"units": {"gyro": "deg/h"}})  # not made up


def test_plot_command_on_the_real_log(tmp_path):
    real = real_log_path()
    out = tmp_path / "real.png"
    res = invoke(
        str(real), "--map", str(REPO / "examples" / "tofupilot_mapping.toml"), "--out", str(out)
    )
    assert res.exit_code == 0, res.output
    assert out.read_bytes().startswith(PNG_MAGIC)
    assert "1 run(s), 8,400 samples" in res.output

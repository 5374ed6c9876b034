"""`rinscal navigate --log`: a recording goes through the same reader as a real one and
navigates as the run it recorded; a foreign layout in pulse counts through a mapping; the
window found after people moved around; wrong units, gaps and a missing site refused."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal import units
from rinscal.cli import app

runner = CliRunner()
ARGS = ["navigate", "--scenario", "quasi-static", "--hours", "0.25", "--rate", "10", "--seed", "3"]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> dict:  # type: ignore[no-untyped-def]
    d = tmp_path_factory.mktemp("rec")
    out = {}
    for kind in ("rates", "increments"):
        extra = ["--increments"] if kind == "increments" else []
        res = runner.invoke(
            app,
            [
                *ARGS,
                "--no-oracle",
                "--out",
                str(d / f"sim_{kind}"),
                "--record",
                str(d / f"run_{kind}.parquet"),
                *extra,
            ],
        )
        assert res.exit_code == 0, res.output
        out[kind] = d
    return {"dir": d}


def _errors(folder) -> pd.DataFrame:  # type: ignore[no-untyped-def]
    e = pd.read_csv(folder / "errors.csv")
    return e[e["variant"] == "none"].reset_index(drop=True)


@pytest.mark.parametrize("kind", ["rates", "increments"])
def test_a_recorded_run_navigated_from_its_file_is_the_simulated_run(recorded, kind) -> None:  # type: ignore[no-untyped-def]
    d = recorded["dir"]
    res = runner.invoke(
        app,
        [
            "navigate",
            "--log",
            str(d / f"run_{kind}.parquet"),
            "--align-start-s",
            "0",
            "--out",
            str(d / f"log_{kind}"),
        ],
    )
    assert res.exit_code == 0, res.output
    a, b = _errors(d / f"sim_{kind}"), _errors(d / f"log_{kind}")
    np.testing.assert_array_equal(a["time_s"], b["time_s"])
    scale = a["horizontal_m"].max()
    for col in ("east_m", "north_m", "horizontal_m"):
        assert np.max(np.abs(a[col] - b[col])) <= 1e-6 * scale, col
    s = json.loads((d / f"log_{kind}" / "summary.json").read_text())
    sim = json.loads((d / f"sim_{kind}" / "summary.json").read_text())
    assert s["duration_s"] == pytest.approx(sim["duration_s"])
    assert s["navigation_start_s"] == pytest.approx(sim["navigation_start_s"]) == 600.0
    v, w = s["variants"]["none"], sim["variants"]["none"]
    assert v["max_error_m"] == pytest.approx(w["max_error_m"], rel=1e-6)
    assert v["max_error_nmi"] == pytest.approx(v["max_error_m"] / units.NMI_TO_M)
    # the metadata holds the true heading: the heading error is there and is the simulation's
    head = v["attitude_error_at_nav_start"]["heading_arcsec"]
    assert head == pytest.approx(w["attitude_error_at_nav_start"]["heading_arcsec"], abs=1e-4)
    rec = s["recording"]
    assert rec["window"]["how"] == "given" and rec["noise"]["source"] == "metadata of the log"
    assert sorted(rec["rotation"]["positions_deg"]) == [-135, -45, 45, 135]
    assert "alignment window 0-600 s" in res.output and "turntable (encoder)" in res.output


def test_pulse_counts_in_front_right_down_through_a_mapping(recorded, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Integer counts of 0.1″ and 125 µg·s, axes front-right-down, µs time, an encoder with
    sign −1 and a 12.5° zero, one shared thermometer: navigates as the rates did, within
    what the quantisation explains (each count carries its remainder, so the angle and
    velocity are never more than one count off: 0.1″ of attitude, 1.2 mm/s of velocity)."""
    d = recorded["dir"]
    rec = pd.read_parquet(d / "run_increments.parquet")
    w_g = 0.1 * units.ARCSEC_TO_RAD
    w_a = 125 * units.UG_TO_MPS2
    th = rec[["dtheta_x", "dtheta_y", "dtheta_z"]].to_numpy()
    dv = rec[["dvel_x", "dvel_y", "dvel_z"]].to_numpy()

    def counts(x: np.ndarray, w: float) -> np.ndarray:  # cumulative, remainder carried
        c = np.floor(np.cumsum(x, axis=0) / w).astype(np.int64)
        return np.diff(c, axis=0, prepend=np.zeros((1, 3), dtype=np.int64))

    cg, ca = counts(th, w_g), counts(dv, w_a)
    frd = np.array([1, 0, 2])  # file x = our y (front), file y = our x (right), z = -up
    flip = np.array([1, 1, -1])
    foreign = pd.DataFrame(
        {
            "stamp_us": np.round(rec["time_s"].to_numpy() * 1e6).astype(np.int64),
            **{f"g{a}": cg[:, frd[j]] * flip[j] for j, a in enumerate("xyz")},
            **{f"a{a}": ca[:, frd[j]] * flip[j] for j, a in enumerate("xyz")},
            "enc": -(rec["table_deg"].to_numpy() + 12.5),
            "t_imu": rec["temp_gyro_x"].to_numpy(),
            "status": "ok",
        }
    )
    path = tmp_path / "car.csv"
    foreign.to_csv(path, index=False)
    mapping = tmp_path / "car.toml"
    mapping.write_text(
        'time = "stamp_us"\ntime_unit = "us"\ntemperature = "t_imu"\n'
        'axes = ["y", "x", "-z"]\ntable_sign = -1\ntable_zero_deg = 12.5\n'
        '[columns]\ngx = "gyro_x"\ngy = "gyro_y"\ngz = "gyro_z"\n'
        'ax = "accel_x"\nay = "accel_y"\naz = "accel_z"\nenc = "table_deg"\n'
        '[weights]\ngyro = "0.1 arcsec"\naccel = "125 ug*s"\n'
    )
    res = runner.invoke(
        app,
        [
            "navigate",
            "--log",
            str(path),
            "--map",
            str(mapping),
            "--site",
            "32.06,118.78,10",
            "--heading",
            "45",
            "--align-start-s",
            "0",
            "--imu",
            "paper",
            "--out",
            str(tmp_path / "out"),
        ],
    )
    assert res.exit_code == 0, res.output
    a, b = _errors(d / "sim_increments"), _errors(tmp_path / "out")
    np.testing.assert_array_equal(a["time_s"], b["time_s"])
    diff = np.max(np.abs(a["horizontal_m"] - b["horizontal_m"]))
    # what the quantisation explains: at most one count of attitude (0.1″ of tilt, g·θ·t²/2)
    # and one count of velocity (w_a·t) carried through the navigated time t (300 s):
    # 0.21 m + 0.37 m; measured 0.10 m of a 7.8 m error
    t_nav = float(a["time_s"].iloc[-1] - a["time_s"].iloc[0])
    bound = 0.5 * units.G0 * w_g * t_nav**2 + w_a * t_nav
    assert 0.0 < diff <= bound, (diff, bound)
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert sorted(s["recording"]["rotation"]["positions_deg"]) == [-135, -45, 45, 135]
    assert s["recording"]["noise"]["source"] == "--imu paper"
    # the heading given equals the simulated truth's: the same heading error to quantisation
    h_sim = json.loads((d / "sim_increments" / "summary.json").read_text())
    h0 = h_sim["variants"]["none"]["attitude_error_at_nav_start"]["heading_arcsec"]
    assert s["variants"]["none"]["attitude_error_at_nav_start"]["heading_arcsec"] == (
        pytest.approx(h0, abs=2.0)
    )


def test_the_window_is_found_after_people_moved_around_the_vehicle(tmp_path) -> None:  # type: ignore[no-untyped-def]
    run = tmp_path / "run.parquet"
    res = runner.invoke(
        app,
        [
            "navigate",
            "--scenario",
            "quasi-static",
            "--hours",
            "0.4",
            "--rate",
            "10",
            "--no-oracle",
            "--out",
            str(tmp_path / "sim"),
            "--record",
            str(run),
        ],
    )
    assert res.exit_code == 0, res.output
    rec = pd.read_parquet(run)
    rng = np.random.default_rng(1)
    busy = rec["time_s"].to_numpy() <= 420.0  # 7 minutes of people at the car: mg, 0.01°/s
    n = int(busy.sum())
    for c in ("accel_x", "accel_y", "accel_z"):
        rec.loc[busy, c] += rng.normal(0, 3000.0, n)  # µg
    for c in ("gyro_x", "gyro_y", "gyro_z"):
        rec.loc[busy, c] += rng.normal(0, 36.0, n)  # deg/h
    disturbed = tmp_path / "disturbed.parquet"
    rec.to_parquet(disturbed)
    meta = json.loads((tmp_path / "run.parquet.meta.json").read_text())
    (tmp_path / "disturbed.parquet.meta.json").write_text(json.dumps(meta))
    res = runner.invoke(app, ["navigate", "--log", str(disturbed), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    w = json.loads((tmp_path / "o" / "summary.json").read_text())["recording"]["window"]
    assert w["how"] == "found" and 420.0 <= w["start_s"] <= 423.0 and w["length_s"] == 600.0
    assert w["quiet_fraction"] == 1.0
    # aligned on the footsteps instead (by hand), the heading handed over is far worse
    res2 = runner.invoke(
        app,
        [
            "navigate",
            "--log",
            str(disturbed),
            "--align-start-s",
            "0",
            "--out",
            str(tmp_path / "o2"),
        ],
    )
    assert res2.exit_code == 0, res2.output
    good = json.loads((tmp_path / "o" / "summary.json").read_text())["variants"]["none"]
    bad = json.loads((tmp_path / "o2" / "summary.json").read_text())["variants"]["none"]
    assert abs(bad["attitude_error_at_nav_start"]["heading_arcsec"]) > 2 * abs(
        good["attitude_error_at_nav_start"]["heading_arcsec"]
    )
    # too short a recording to find 300 quiet seconds: refused, naming the quietest stretch
    short = rec[rec["time_s"] <= 650.0]
    short.to_parquet(tmp_path / "short.parquet")
    (tmp_path / "short.parquet.meta.json").write_text(json.dumps(meta))
    res3 = runner.invoke(
        app, ["navigate", "--log", str(tmp_path / "short.parquet"), "--out", str(tmp_path / "o3")]
    )
    assert res3.exit_code != 0
    assert "no static window of at least 300 s" in res3.output and "longest quiet" in res3.output
    assert not (tmp_path / "o3").exists()  # a refused command leaves nothing


def test_wrong_units_gaps_and_no_site_are_refused_with_what_was_measured(
    recorded, tmp_path
) -> None:  # type: ignore[no-untyped-def]
    d = recorded["dir"]
    rec = pd.read_parquet(d / "run_rates.parquet")
    meta = json.loads((d / "run_rates.parquet.meta.json").read_text())

    def write(df: pd.DataFrame, name: str, m: dict | None) -> str:
        p = tmp_path / name
        df.to_parquet(p)
        if m is not None:
            (tmp_path / f"{name}.meta.json").write_text(json.dumps(m))
        return str(p)

    # deg/h declared as rad/s: the Earth rate reads 2e5 times too fast
    wrong = write(rec, "wrong.parquet", {**meta, "units": {"gyro": "rad/s", "accel": "ug"}})
    res = runner.invoke(
        app, ["navigate", "--log", wrong, "--align-start-s", "0", "--out", str(tmp_path / "o1")]
    )
    assert res.exit_code != 0
    assert "wrong gyro units" in res.output and "°/h where the Earth turns at 15.04" in res.output
    assert not (tmp_path / "o1").exists()
    # 2 s of samples lost while the table dwells: refused unless --allow-gaps, then
    # integrated over its own length and reported
    t = rec["time_s"].to_numpy()
    enc = rec["table_deg"].to_numpy()
    still = pd.Series(np.abs(np.diff(enc, prepend=enc[0])) < 1e-9).rolling(50).min().to_numpy()
    t0 = float(t[np.flatnonzero((still == 1) & (t > 700))[0]]) - 3.0  # 5 s of table at rest
    gap = write(rec[(t < t0) | (t > t0 + 2.0)], "gap.parquet", meta)
    res = runner.invoke(app, ["navigate", "--log", gap, "--out", str(tmp_path / "o2")])
    assert res.exit_code != 0 and "--allow-gaps" in res.output
    res = runner.invoke(
        app,
        [
            "navigate",
            "--log",
            gap,
            "--allow-gaps",
            "--align-start-s",
            "0",
            "--out",
            str(tmp_path / "o3"),
        ],
    )
    assert res.exit_code == 0, res.output
    s = json.loads((tmp_path / "o3" / "summary.json").read_text())
    assert s["recording"]["gaps"]["count"] == 1
    assert s["recording"]["gaps"]["longest_s"] == pytest.approx(2.1, abs=0.11)
    # a standing IMU on a still table: the rate held over the gap costs the noise of the one
    # sample held, σ_f √rate × 2.2 s of velocity (5 mm/s), carried on to the end (200 s);
    # integrated as one nominal step instead, the gap's Earth rate and gravity are left
    # unbalanced: 8.1 m against this bound of 5.4 m (measured by breaking it)
    a, b = _errors(d / "sim_rates"), _errors(tmp_path / "o3")
    h = np.interp(b["time_s"], a["time_s"], a["horizontal_m"])
    sigma_v = meta["noise"]["accel_noise_density"] * np.sqrt(10.0) * 2.2
    assert np.max(np.abs(h - b["horizontal_m"])) < 5 * sigma_v * (900.0 - t0)
    # no site anywhere: say what to give
    nosite = {k: v for k, v in meta.items() if k != "site"}
    ns = write(rec, "nosite.parquet", nosite)
    res = runner.invoke(app, ["navigate", "--log", ns, "--out", str(tmp_path / "o4")])
    assert res.exit_code != 0 and "--site: latitude, longitude, height" in res.output
    res = runner.invoke(
        app, ["navigate", "--log", ns, "--site", "95,0,0", "--out", str(tmp_path / "o5")]
    )
    assert res.exit_code != 0 and "latitude 95° lies outside ±90°" in res.output
    # --scenario and --log together, or scenario options with --log: one clear line
    res = runner.invoke(app, ["navigate", "--log", ns, "--scenario", "swing", "--out", "x"])
    assert res.exit_code != 0 and "either --scenario" in res.output
    res = runner.invoke(app, ["navigate", "--log", ns, "--hours", "1", "--out", "x"])
    assert res.exit_code != 0 and "--hours: only with --scenario" in res.output


def test_a_clock_in_whole_ms_steps_by_the_mean_interval(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """16 Hz stamped in whole ms: intervals of 62 and 63 ms. The median (62 or 63 ms) as
    the step would tilt the gravity integration by 0.8 %; the mean is the true 62.5 ms."""
    run = tmp_path / "run.parquet"
    res = runner.invoke(
        app,
        [
            "navigate",
            "--scenario",
            "quasi-static",
            "--hours",
            "0.25",
            "--rate",
            "16",
            "--no-oracle",
            "--out",
            str(tmp_path / "sim"),
            "--increments",
            "--record",
            str(run),
        ],
    )
    assert res.exit_code == 0, res.output
    rec = pd.read_parquet(run)
    rec["time_s"] = np.floor(rec["time_s"] * 1000.0 + 1e-6) / 1000.0
    rec.to_parquet(tmp_path / "ms.parquet")
    meta = json.loads((tmp_path / "run.parquet.meta.json").read_text())
    meta.pop("rate_hz")  # the step from the data alone
    (tmp_path / "ms.parquet.meta.json").write_text(json.dumps(meta))
    res = runner.invoke(
        app,
        [
            "navigate",
            "--log",
            str(tmp_path / "ms.parquet"),
            "--align-start-s",
            "0",
            "--out",
            str(tmp_path / "o"),
        ],
    )
    assert res.exit_code == 0, res.output
    a, b = _errors(tmp_path / "sim"), _errors(tmp_path / "o")
    h = np.interp(b["time_s"], a["time_s"], a["horizontal_m"])
    assert np.max(np.abs(h - b["horizontal_m"])) < 0.02 * a["horizontal_m"].max()
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["rate_hz"] == pytest.approx(16.0, rel=1e-3)
    assert "scatter by 0.8 %" in res.output  # the coarse clock is said


def test_record_never_lands_on_an_output_and_scenario_options_are_refused_with_log(
    recorded, tmp_path
) -> None:  # type: ignore[no-untyped-def]
    res = runner.invoke(
        app, [*ARGS, "--out", str(tmp_path / "o"), "--record", str(tmp_path / "o" / "errors.csv")]
    )
    assert res.exit_code != 0 and "one of the outputs" in res.output
    assert not (tmp_path / "o").exists()
    run = str(recorded["dir"] / "run_rates.parquet")
    for opt in (["--rate", "50"], ["--seed", "2"], ["--rotation", "none"], ["--no-oracle"]):
        res = runner.invoke(app, ["navigate", "--log", run, *opt, "--out", str(tmp_path / "x")])
        assert res.exit_code != 0 and "only with --scenario" in res.output, opt
    res = runner.invoke(app, ["navigate", "--out", str(tmp_path / "x")])
    assert res.exit_code != 0 and "give --scenario (a simulated run) or --log" in res.output

"""Navigating a recording (rinscal.nav.recorded): the same numbers as the simulated run it
recorded, the window a person would choose, and a clear refusal of wrong units.

The recording is converted to NavSamples here by hand (an oracle independent of the
reader in rinscal.io.navopen, which has its own tests)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from rinscal import earth, units
from rinscal.errors import ConfigError, LogError
from rinscal.nav.recorded.blocks import BlockStats, TableUnwrap
from rinscal.nav.recorded.compensation import CausalModelCompensator
from rinscal.nav.recorded.frame import recording_frame
from rinscal.nav.recorded.navigate import Reference, navigate_recording
from rinscal.nav.recorded.window import (
    Noise,
    align_config,
    check_at_rest,
    estimate_noise,
    find_window,
    seen_schedule,
)
from rinscal.schema import CHANNELS, DTHETA, DVEL, NavSamples
from rinscal.sim.config import load_imu
from rinscal.sim.scenario import ThermalPlant, align_for, preset, run_scenario
from tests.calibration._helpers import linear_model


def _record(scenario: str, hours: float, rate: float, increments: bool, seed: int = 2):
    imu = load_imu("paper")
    cfg = preset(scenario, hours=hours, rate_hz=rate, align=align_for(imu, total_s=600.0))
    plant = ThermalPlant.for_scenario(imu, cfg, seed=seed)
    grid = np.arange(0.0, float(plant.field.t[-1]) + 1e-9, 1.0)
    inner, outer = plant.measured_temperatures(grid)
    frames: list[pd.DataFrame] = []

    def rec(ch, dth, dv) -> None:  # type: ignore[no-untyped-def]
        frames.append(
            recording_frame(
                ch,
                dth,
                dv,
                increments=increments,
                readings=(grid, inner, outer),
                track=scenario == "vehicle",
            )
        )

    result = run_scenario(cfg, plant, {"none": None}, recorder=rec)
    return cfg, imu, result, pd.concat(frames, ignore_index=True)


def _pieces(d: pd.DataFrame, rate: float, size: int = 7001):
    t = d["time_s"].to_numpy()
    dt = np.diff(t, prepend=t[0] - 1.0 / rate)
    if "dtheta_x" in d:
        th, dv = d[list(DTHETA)].to_numpy(), d[list(DVEL)].to_numpy()
    else:
        th = d[list(CHANNELS[:3])].to_numpy() * units.DPH_TO_RPS * dt[:, None]
        dv = d[list(CHANNELS[3:])].to_numpy() * units.UG_TO_MPS2 * dt[:, None]
    temps = d[[f"temp_{c}" for c in CHANNELS]].to_numpy()
    ref = None
    if "ref_lat_deg" in d:
        ref = np.column_stack(
            [np.deg2rad(d["ref_lat_deg"]), np.deg2rad(d["ref_lon_deg"]), d["ref_h_m"]]
        )
    table = np.deg2rad(d["table_deg"].to_numpy())
    head = np.deg2rad(d["ref_heading_deg"].to_numpy())
    for a in range(0, len(t), size):
        b = slice(a, a + size)
        yield NavSamples(
            t[b],
            dt[b],
            th[b],
            dv[b],
            a + 1,
            table[b],
            temps[b],
            d["temp_out"].to_numpy()[b],
            None if ref is None else ref[b],
            head[b],
        )


def _navigate(cfg, imu, d, comps=None, start_s=0.0):  # type: ignore[no-untyped-def]
    st = BlockStats()
    for s in _pieces(d, cfg.rate_hz):
        st.add(s)
    blocks = st.finish()
    win = find_window(blocks, 600.0, start_s=start_s)
    wd, rw = imu.noise.white_density_si(), imu.noise.bias_rw_si()
    noise = Noise(float(wd[0]), float(wd[3]), float(rw[0]), float(rw[3]))
    tr = cfg.trajectory
    ref = Reference(tr.lat0, tr.lon0, tr.alt0)
    res = navigate_recording(
        _pieces(d, cfg.rate_hz), ref, win, align_config(noise, win), cfg.dt, comps
    )
    assert st.n_jumps == 0  # the table turns as the gyros say, a vehicle's yaw included
    return res, blocks, win


@pytest.mark.parametrize(("scenario", "increments"), [("quasi-static", False), ("vehicle", True)])
def test_a_recorded_run_navigates_as_the_run_it_recorded(scenario, increments) -> None:  # type: ignore[no-untyped-def]
    """Same window, same filter noise: the uncompensated errors to 1e-6 of their size, for
    rates (deg/h, µg) and for increments, on a static base and on a driving vehicle."""
    cfg, imu, sim, rec = _record(scenario, 0.25, 10.0, increments)
    res, _, _ = _navigate(cfg, imu, rec)
    a, b = sim.errors["none"], res.errors["none"]
    assert len(a) == len(b) > 100
    np.testing.assert_array_equal(a["time_s"], b["time_s"])
    scale = a["horizontal_m"].max()
    assert scale > 1.0  # a real error to compare (the paper IMU drifts)
    for col in ("east_m", "north_m", "horizontal_m"):
        assert np.max(np.abs(a[col] - b[col])) <= 1e-6 * scale, col
    # the recording's true body heading gives the heading error, as in the simulation
    np.testing.assert_allclose(b["heading_err"], a["heading_err"], atol=1e-9)


def test_the_piece_wise_model_compensator_is_the_scenario_s(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A model run on the recorded 1-s thermometer readings navigates as the scenario's
    ModelCompensator on the plant's thermometers: the same readings, the same causal slope."""
    from typer.testing import CliRunner

    from rinscal.calibration.modelfile import ThermalModelFile
    from rinscal.cli import app
    from rinscal.sim.sensors import ModelCompensator

    runner = CliRunner()
    soak = tmp_path / "soak.parquet"
    assert (
        runner.invoke(
            app, ["simulate", "soak", "--rate", "1", "--hours", "1", "--out", str(soak)]
        ).exit_code
        == 0
    )
    res = runner.invoke(
        app, ["fit", str(soak), "--method", "regression", "--out", str(tmp_path / "m.json")]
    )
    assert res.exit_code == 0, res.output
    model = ThermalModelFile.load(tmp_path / "m.json")
    imu = load_imu("paper")
    cfg = preset("quasi-static", hours=0.25, rate_hz=10.0, align=align_for(imu))
    plant = ThermalPlant.for_scenario(imu, cfg, seed=5)
    grid = np.arange(0.0, float(plant.field.t[-1]) + 1e-9, 1.0)
    inner, outer = plant.measured_temperatures(grid)
    frames: list[pd.DataFrame] = []
    sim = run_scenario(
        cfg,
        plant,
        {"none": None, "m": ModelCompensator(model, plant)},
        recorder=lambda ch, a, b: frames.append(
            recording_frame(ch, a, b, readings=(grid, inner, outer))
        ),
    )
    rec = pd.concat(frames, ignore_index=True)
    got, _, _ = _navigate(cfg, imu, rec, {"none": None, "m": CausalModelCompensator(model)})
    a, b = sim.errors["m"]["horizontal_m"], got.errors["m"]["horizontal_m"]
    assert np.max(np.abs(a - b)) <= 1e-6 * a.max()
    # and the model changed something: it is not the uncompensated run
    assert np.max(np.abs(got.errors["none"]["horizontal_m"] - b)) > 1.0


def test_the_compensator_does_not_care_how_the_recording_is_cut() -> None:
    rng = np.random.default_rng(0)
    n = 5000
    t = np.arange(1, n + 1) * 0.1
    temps = 20 + np.cumsum(rng.normal(0, 0.01, (n, 6)), axis=0)
    temps[100:130, 2] = np.nan  # a thermometer missing for 3 s: the last reading holds

    def run(size: int) -> np.ndarray:
        comp = CausalModelCompensator(linear_model())
        out = []
        for a in range(0, n, size):
            b = slice(a, a + size)
            s = NavSamples(
                t[b],
                np.full(t[b].size, 0.1),
                np.zeros((t[b].size, 3)),
                np.zeros((t[b].size, 3)),
                temps=temps[b],
            )
            out.append(comp(s))
        return np.concatenate(out)

    whole, cut = run(n), run(37)
    np.testing.assert_array_equal(whole, cut)
    assert np.isfinite(whole).all()
    # one reading a second, held: 10 samples share each value
    assert np.unique(whole[:, 0]).size == pytest.approx(n / 10, abs=1)
    # the slope term is there: a pure temperature model would equal 1e-6 T at the readings
    k = np.arange(0, n, 10)
    assert np.max(np.abs(whole[k, 0] - 1e-6 * temps[k, 0])) > 1e-9


def test_an_encoder_wrapping_at_180_deg_unwraps_across_pieces() -> None:
    true = np.deg2rad(np.linspace(-170, 900, 4001))  # three turns through ±180
    wrapped = (true + np.pi) % (2 * np.pi) - np.pi
    un = TableUnwrap()
    got = np.concatenate([un(wrapped[a : a + 333]) for a in range(0, wrapped.size, 333)])
    np.testing.assert_allclose(got, true, atol=1e-12)


def _blocks_from(f_norm_sd: np.ndarray, rate: float = 50.0, lat: float = 0.6, seed: int = 0):
    """A static IMU (level, Earth rate on its axes) whose |f| is disturbed per second."""
    rng = np.random.default_rng(seed)
    st = BlockStats()
    g = float(earth.gravity(lat, 0.0))
    w_n = earth.RATE * np.array([0.0, math.cos(lat), math.sin(lat)])
    k0 = 0
    for sd in np.array_split(f_norm_sd, max(1, f_norm_sd.size // 97)):
        n = int(sd.size * rate)
        t = (k0 + np.arange(1, n + 1)) / rate
        k0 += n
        dt = np.full(n, 1 / rate)
        noise = np.repeat(sd, int(rate))[:, None] * rng.normal(size=(n, 3))
        f = np.array([0.0, 0.0, g]) + noise
        w = w_n + 1e-7 * rng.normal(size=(n, 3))
        st.add(NavSamples(t, dt, w * dt[:, None], f * dt[:, None]))
    return st.finish()


def test_the_window_is_the_first_quiet_stretch_after_people_moved_around() -> None:
    sd = np.full(2400, 1e-4)  # 10 µg-class noise floor
    sd[:420] = 5e-3  # 7 min of people at the vehicle (mg)
    sd[1500:1510] = 5e-3
    win = find_window(_blocks_from(sd), 600.0)
    assert win.how == "found"
    assert 419 <= win.start_s <= 421 and win.length_s == 600.0
    assert win.quality["quiet_fraction"] == 1.0
    # only 200 s of quiet: refused, naming the quietest stretch
    sd2 = np.full(1200, 5e-3)
    sd2[500:700] = 1e-4
    quietest = r"at least 300 s.*the longest quiet stretch is 19\d s from 50\d s"
    with pytest.raises(LogError, match=quietest):
        find_window(_blocks_from(sd2), 600.0)


def test_wrong_units_are_caught_at_rest_and_named() -> None:
    lat = 0.6
    sd = np.full(700, 1e-4)
    blocks = _blocks_from(sd, lat=lat)
    win = find_window(blocks, 600.0)
    vals, warn = check_at_rest(blocks, win, lat, 0.0)
    assert vals["f_over_g"] == pytest.approx(1.0, abs=1e-4) and not warn
    assert vals["omega_over_earth_rate"] == pytest.approx(1.0, abs=0.01)
    from dataclasses import replace

    deg_s_as_rad_s = replace(blocks, w_mean=blocks.w_mean * 180 / math.pi)
    with pytest.raises(LogError, match="gyro units"):
        check_at_rest(deg_s_as_rad_s, win, lat, 0.0)
    ug_as_mps2 = replace(blocks, fmag_mean=blocks.fmag_mean / units.UG_TO_MPS2)
    with pytest.raises(LogError, match=r"× 1\.02e\+05\): wrong accelerometer units"):
        check_at_rest(ug_as_mps2, win, lat, 0.0)
    increments_as_rates = replace(blocks, w_mean=blocks.w_mean / 50.0)
    with pytest.raises(LogError, match="gyro units"):
        check_at_rest(increments_as_rates, win, lat, 0.0)
    # the noise estimate finds the per-sample white noise it was given (1e-4 m/s² per axis)
    noise = estimate_noise(blocks, win)
    assert noise.accel_density == pytest.approx(1e-4 / math.sqrt(50.0), rel=0.05)


def test_the_schedule_seen_in_the_encoder_is_the_four_position_one() -> None:
    _, _, _, rec = _record("quasi-static", 0.2, 5.0, False)
    st = BlockStats()
    for s in _pieces(rec, 5.0):
        st.add(s)
    sched = seen_schedule(st.finish())
    assert sorted(sched["positions_deg"]) == [-135, -45, 45, 135]
    assert sched["dwell_s_median"] == pytest.approx(60.0, abs=1.5)
    assert sched["turning_rate_dps_median"] == pytest.approx(10.0, rel=0.2)


def test_encoder_jumps_are_counted_and_placed() -> None:
    _, _, _, rec = _record("quasi-static", 0.2, 5.0, False)
    rec.loc[1000, "table_deg"] += 90.0  # one reading 90° off: a jump there and one back
    st = BlockStats()
    for s in _pieces(rec, 5.0):
        st.add(s)
    assert st.n_jumps == 2
    (t1, row1, d1), (_, row2, _) = st.jumps
    assert row1 == 1001 and row2 == 1002 and t1 == pytest.approx(rec["time_s"][1000])
    assert d1 == pytest.approx(90.0, abs=0.5)


def test_a_track_that_misses_the_navigated_part_is_refused() -> None:
    t = np.linspace(0.0, 100.0, 11)
    ref = Reference(0.5, 2.0, 10.0, track=(t, np.full(11, 0.5), np.full(11, 2.0), np.zeros(11)))
    ref.overlap(50.0, 500.0)  # overlaps: fine
    with pytest.raises(LogError, match=r"track \(0.0-100.0 s\) does not overlap.*200.0-500.0"):
        ref.overlap(200.0, 500.0)
    with pytest.raises(ConfigError, match="latitude must lie within ±90°"):
        Reference(math.radians(91.0), 0.0, 0.0)


def test_the_track_in_the_log_gives_the_vehicle_s_velocity_and_gaps_in_it_are_dropped() -> None:
    cfg, imu, sim, rec = _record("vehicle", 0.25, 10.0, True)
    res, _, _ = _navigate(cfg, imu, rec)
    a, b = sim.errors["none"], res.errors["none"]
    # the reference velocity comes from the track (not zero while the vehicle drives)
    assert np.abs(res.truth["v_e"]).max() > 5.0
    # to the accuracy of differentiating a 10 Hz track (mm/s where the acceleration changes)
    np.testing.assert_allclose(b["v_e_err"], a["v_e_err"], atol=5e-3)
    np.testing.assert_allclose(b["v_n_err"], a["v_n_err"], atol=5e-3)
    # empty reference cells: no error reported there, none turned NaN after them
    holed = rec.copy()
    holed.loc[(holed["time_s"] > 700) & (holed["time_s"] < 720), "ref_lat_deg"] = np.nan
    res2, _, _ = _navigate(cfg, imu, holed)
    e = res2.errors["none"]
    assert np.isfinite(e["horizontal_m"]).all() and len(e) == len(a) - 19
    assert res2.config.notes and "covers 881 of the 900" in res2.config.notes[0]
    kept = a[~a["time_s"].between(700, 720, inclusive="neither")].reset_index(drop=True)
    np.testing.assert_allclose(e["horizontal_m"], kept["horizontal_m"], rtol=1e-6, atol=1e-6)


def test_a_track_file_covering_part_of_the_run_reports_errors_there_only() -> None:
    cfg, imu, _, rec = _record("quasi-static", 0.25, 10.0, False)
    st = BlockStats()
    for s in _pieces(rec, 10.0):
        st.add(s)
    blocks = st.finish()
    win = find_window(blocks, 600.0, start_s=0.0)
    wd = imu.noise.white_density_si()
    noise = Noise(float(wd[0]), float(wd[3]))
    tr = cfg.trajectory
    t = np.arange(0.0, 800.0, 1.0)
    ref = Reference(
        tr.lat0,
        tr.lon0,
        tr.alt0,
        track=(t, np.full(t.size, tr.lat0), np.full(t.size, tr.lon0), np.full(t.size, tr.alt0)),
    )
    res = navigate_recording(_pieces(rec, 10.0), ref, win, align_config(noise, win), 0.1)
    e = res.errors["none"]
    assert e["time_s"].min() == 601.0 and e["time_s"].max() == 799.0
    assert "errors are reported there only" in res.config.notes[0]


def test_nothing_left_after_the_alignment_is_said_plainly() -> None:
    cfg, _, _, rec = _record("quasi-static", 0.2, 5.0, False)
    st = BlockStats()
    for s in _pieces(rec, 5.0):
        st.add(s)
    blocks = st.finish()
    win = find_window(blocks, 720.0, start_s=0.0)  # the whole 720 s recording
    noise = Noise(1e-7, 1e-4)
    tr = cfg.trajectory
    with pytest.raises(LogError, match="nothing is left to navigate"):
        navigate_recording(
            _pieces(rec, 5.0),
            Reference(tr.lat0, tr.lon0, tr.alt0),
            win,
            align_config(noise, win),
            0.2,
        )


def test_thermometers_empty_at_the_start_make_the_model_wait() -> None:
    n = 300
    t = np.arange(1, n + 1) * 0.1
    temps = np.full((n, 6), 25.0)
    temps[:55, 1] = np.nan  # one thermometer reads only from 5.5 s on
    comp = CausalModelCompensator(linear_model())
    out = comp(NavSamples(t, np.full(n, 0.1), np.zeros((n, 3)), np.zeros((n, 3)), temps=temps))
    assert np.isfinite(out).all()
    assert comp.skipped == 6  # the readings of seconds 0-5 (the first sample of each)
    assert (out[:60] == 0).all() and out[60, 0] == pytest.approx(25e-6)


def test_a_wrong_encoder_sign_or_unit_and_a_wrong_site_are_named() -> None:
    from dataclasses import replace

    from rinscal.nav.recorded.window import check_encoder

    _, _, _, rec = _record("quasi-static", 0.2, 5.0, False)
    st = BlockStats()
    for s in _pieces(rec, 5.0):
        st.add(s)
    blocks = st.finish()
    assert check_encoder(blocks) == []
    flipped = replace(blocks, table_turn=-blocks.table_turn)
    assert "against the z gyro" in check_encoder(flipped)[0]
    rad_as_deg = replace(blocks, table_turn=blocks.table_turn * math.pi / 180)
    assert "turns 0.0175 × what the z gyro turns" in check_encoder(rad_as_deg)[0]
    win = find_window(blocks, 600.0, start_s=0.0)
    lat = math.radians(32.06)
    vals, warn = check_at_rest(blocks, win, lat, 10.0)
    assert vals["latitude_measured_deg"] == pytest.approx(32.06, abs=0.5) and not warn
    _, warn = check_at_rest(blocks, win, -lat, 10.0)  # the southern hemisphere by mistake
    assert "measure latitude 32.0" in warn[0] and "the site says -32.06°" in warn[0]

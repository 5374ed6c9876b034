"""The multi-position and rate-table protocol on the two-axis turntable: physics of its
outputs (checked against textbook gravity, Earth rate and attitude written here, not
rinscal.turntable), its sequences, its turntable errors and its truth table."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from rinscal.errors import ConfigError
from rinscal.io.params import PARAMS_COLUMNS, check_params_table
from rinscal.schema import CHANNELS
from rinscal.sensormodel import PARAMETERS
from rinscal.sim.config import ImuConfig, NoiseConfig, OutputConfig
from rinscal.sim.multiposition import (
    SEQUENCES,
    iter_multiposition,
    load_sequence,
    simulate_multiposition,
)
from rinscal.sim.polynomial import ChannelThermal

OMEGA_E = 7.292115e-5  # rad/s
ARCSEC = math.pi / 648000.0
DPS = math.pi / 180.0


def _somigliana(lat: float, h: float) -> float:
    """WGS84 normal gravity (closed form) with the free-air gradient [m/s²]."""
    s2 = math.sin(lat) ** 2
    return 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - 0.00669437999013 * s2) - (
        3.086e-6 * h
    )


def _imu_axes_enu(outer_deg: float, inner_deg: float, heading_deg: float) -> np.ndarray:
    """Rows: IMU x, y, z in ENU. At zero angles y points along the outer axis (azimuth
    ``heading``), z up, x = y × z; the outer axis turns everything, then the inner axis
    (IMU z, carried by the outer frame) turns the IMU."""
    h = math.radians(heading_deg)
    y0 = np.array([math.sin(h), math.cos(h), 0.0])
    z0 = np.array([0.0, 0.0, 1.0])
    x0 = np.cross(y0, z0)
    r_out = Rotation.from_rotvec(math.radians(outer_deg) * y0)
    z1 = r_out.apply(z0)
    r = Rotation.from_rotvec(math.radians(inner_deg) * z1) * r_out
    return r.apply(np.stack([x0, y0, z0]))


def _textbook_inputs(cfg: ImuConfig, o: float, i: float) -> tuple[np.ndarray, np.ndarray]:
    lat = math.radians(cfg.latitude_deg)
    axes = _imu_axes_enu(o, i, cfg.heading_deg)
    w_n = OMEGA_E * np.array([0.0, math.cos(lat), math.sin(lat)])
    f_n = np.array([0.0, 0.0, _somigliana(lat, cfg.altitude_m)])
    return axes @ w_n, axes @ f_n


def _forward(s: np.ndarray, th: tuple[ChannelThermal, ...], gyro: bool) -> np.ndarray:
    """y = (1+k)u + a|u| + q u², u = s + M s, from the config's values at t_cal."""
    out = np.empty(3)
    for j in range(3):
        c = th[j if gyro else j + 3]
        u = s[j] + sum(c.misalignment_arcsec[k] * ARCSEC * s[k] for k in range(3) if k != j)
        if gyro:
            q = c.sf_quad * 1e-6 / DPS
            a = c.sf_asym_ppm * 1e-6
        else:
            q = c.sf_quad * 1e-6 * 9.80665 / 9.80665**2  # µg/g² → 1/(m/s²)
            a = 0.0
        out[j] = (1 + c.scale_factor_ppm * 1e-6) * u + a * abs(u) + q * u * u
    return out


def _quiet(base: ImuConfig, *, slopes: bool = False) -> ImuConfig:
    """No thermal bias, no noise, no offsets; the sensor terms of ``base`` (slopes zero
    unless asked), pulses."""
    th = []
    for c in base.thermal:
        keep = {
            k: getattr(c, k)
            for k in ("scale_factor_ppm", "misalignment_arcsec", "sf_asym_ppm", "sf_quad")
        }
        if slopes:
            for k in ("scale_factor_ppm_per_c", "misalignment_arcsec_per_c",
                      "sf_asym_ppm_per_c", "sf_quad_per_c"):  # fmt: skip
                keep[k] = getattr(c, k)
        th.append(ChannelThermal(**keep))
    zero = NoiseConfig(**{k: 0.0 for k in vars(NoiseConfig())})
    return replace(
        base,
        thermal=tuple(th),
        noise=zero,
        output=OutputConfig(mode="pulses"),
        effects=replace(base.effects, shupe=False, hysteresis=False),
    )


def _segments(df: pd.DataFrame) -> list[tuple[int, int, str]]:
    """Row ranges [a, b) of static positions and rate segments from the commanded columns
    (the log contract), with their kind."""
    cols = ["table_outer_deg", "table_inner_deg", "table_outer_rate_dps", "table_inner_rate_dps"]
    x = df[cols].to_numpy()
    static = (x[:, 2] == 0) & (x[:, 3] == 0)
    out = []
    a = 0
    n = len(x)
    while a < n:
        b = a + 1
        if static[a]:
            while b < n and static[b] and np.array_equal(x[b, :2], x[a, :2]):
                b += 1
            out.append((a, b, "static"))
        else:
            while b < n and np.array_equal(x[b, 2:], x[a, 2:]):
                b += 1
            out.append((a, b, "rate" if b - a > 5 else "transition"))
        a = b
    return out


PAPER = ImuConfig.paper()
SHORT = {"dwell_s": 5.0, "warmup_s": 60.0, "set_points_c": (20.0,), "rate_hz": 10.0}


def test_static_outputs_are_gravity_and_earth_rate_through_the_forward_model() -> None:
    cfg = _quiet(PAPER)
    log, _, meta = simulate_multiposition(cfg, sequence="19", rates_dps=(50.0,), **SHORT)
    w = np.asarray(list(meta["unit_to_si"].values()))  # per-sample pulse → SI rate
    statics = [s for s in _segments(log) if s[2] == "static"]
    assert len(statics) == 19
    for (a, b, _), (o, i) in zip(statics, SEQUENCES["19"], strict=True):
        mean = log[list(CHANNELS)].iloc[a:b].to_numpy().mean(axis=0) * w
        omega, f = _textbook_inputs(cfg, o, i)
        # the accumulator's count over the dwell is within one pulse of the integral
        one = w / (b - a)
        np.testing.assert_allclose(mean[:3], _forward(omega, cfg.thermal, True), atol=one[0])
        np.testing.assert_allclose(mean[3:], _forward(f, cfg.thermal, False), atol=one[3] + 1e-7)
        assert (log["table_outer_deg"].iloc[a] - o) % 360.0 == pytest.approx(0.0, abs=1e-9)


def test_pulse_sums_over_a_rate_segment_are_the_integrated_angle_through_the_model() -> None:
    cfg = _quiet(PAPER)
    log, _, meta = simulate_multiposition(cfg, sequence=[(0.0, 0.0)], rates_dps=(50.0, 200.0),
                                          **SHORT)  # fmt: skip
    dt = 1.0 / meta["rate_hz"]
    w = np.asarray(list(meta["unit_to_si"].values())) * dt  # weight of one pulse [rad, m/s]
    rates = [s for s in _segments(log) if s[2] == "rate"]
    assert len(rates) == 3 * 2 * 2
    lat = math.radians(cfg.latitude_deg)
    checked = 0
    for a, b, _ in rates:
        seg = log.iloc[a:b]
        wo, wi = seg["table_outer_rate_dps"].iloc[0], seg["table_inner_rate_dps"].iloc[0]
        t = (b - a) * dt
        if wi != 0:  # about z, z up: Earth's vertical rate adds, the horizontal averages out
            u = wi * DPS + OMEGA_E * math.sin(lat)
            c = cfg.thermal[2]
            q = c.sf_quad * 1e-6 / DPS
            expected = t * ((1 + c.scale_factor_ppm * 1e-6) * u + c.sf_asym_ppm * 1e-6 * abs(u)
                            + q * u * u)  # fmt: skip
            got = seg["gyro_z"].sum() * w[2]
            # within a pulse of the accumulator, and the integrated angle itself
            assert got == pytest.approx(expected, abs=2 * w[2])
            angle = seg["table_inner_deg"].iloc[-1] - log["table_inner_deg"].iloc[a - 1]
            assert angle == pytest.approx(wi * t, abs=1e-9)
            checked += 1
        elif seg["table_inner_deg"].iloc[0] % 360 == 90:  # about x: the outer axis (horizontal)
            # the Earth rate along the outer axis (azimuth = heading) is constant
            h = math.radians(cfg.heading_deg)
            u = wo * DPS + OMEGA_E * math.cos(lat) * math.cos(h)
            c = cfg.thermal[0]
            q = c.sf_quad * 1e-6 / DPS
            expected = t * ((1 + c.scale_factor_ppm * 1e-6) * u + c.sf_asym_ppm * 1e-6 * abs(u)
                            + q * u * u)  # fmt: skip
            got = seg["gyro_x"].sum() * w[0]
            # the misalignment couples the perpendicular Earth rate, which averages out
            assert got == pytest.approx(expected, abs=2 * w[0] + 1e-9 * t)
            checked += 1
    assert checked == 8  # 2 rates × 2 signs × (x, z)


def test_rate_segments_are_whole_revolutions() -> None:
    cfg = _quiet(PAPER)
    log, _, _ = simulate_multiposition(cfg, sequence=[(0.0, 0.0)], rates_dps=(7.0, 50.0, 200.0),
                                       dwell_s=5.0, warmup_s=60.0, set_points_c=(20.0,),
                                       rate_hz=10.0)  # fmt: skip
    dt = 0.1
    n_rate = 0
    for a, b, kind in _segments(log):
        if kind != "rate":
            continue
        seg = log.iloc[a:b]
        rate = np.abs(seg[["table_outer_rate_dps", "table_inner_rate_dps"]].to_numpy()).max()
        revs = (b - a) * dt * rate / 360.0
        assert revs == pytest.approx(round(revs), abs=1e-9) and round(revs) >= 1
        assert (b - a) * dt >= 36.0 - 1e-9
        n_rate += 1
    assert n_rate == 3 * 3 * 2
    # 7 deg/s at 10 Hz: 360/0.7 samples per revolution is not whole; 7 revolutions are
    with pytest.raises(ConfigError, match="whole number of revolutions"):
        simulate_multiposition(cfg, sequence=[(0.0, 0.0)], rates_dps=(7.3e-3,), **SHORT)


def test_sequences_put_every_axis_up_down_horizontal_and_tilted() -> None:
    for name, n in (("12", 12), ("18", 18), ("19", 19)):
        _, pos = load_sequence(name)
        assert len(pos) == n
        ups = np.array([_imu_axes_enu(o, i, 0.0)[:, 2] for o, i in pos])  # up comp. per axis
        for j in range(3):
            col = ups[:, j]
            assert np.isclose(col, 1).sum() >= 2 and np.isclose(col, -1).sum() >= 2
            assert np.isclose(col, 0, atol=1e-12).sum() >= 4
            if n >= 18:
                assert np.isclose(np.abs(col), math.sqrt(0.5)).sum() >= 2
        if n == 19:
            assert np.allclose(ups[-1], 1 / math.sqrt(3))
        # two orientations per up/down differ by 180° about the vertical: horizontal axes flip
        assert len({tuple(np.round(_imu_axes_enu(o, i, 0.0).ravel(), 6)) for o, i in pos}) == n


def test_sequence_from_toml(tmp_path) -> None:
    p = tmp_path / "seq.toml"
    p.write_text("positions = [[0, 0], [180, 0], [90.0, -90]]\n")
    name, pos = load_sequence(p)
    assert name == str(p) and pos.tolist() == [[0, 0], [180, 0], [90, -90]]
    p.write_text("positions = [[0, 0], [180]]\n")
    with pytest.raises(ConfigError, match=r"seq\.toml: positions entry 2"):
        load_sequence(p)
    p.write_text("position = [[0, 0]]\n")
    with pytest.raises(ConfigError, match=r"seq\.toml: unknown key"):
        load_sequence(p)
    with pytest.raises(ConfigError, match="neither built in"):
        load_sequence("20")


def test_turntable_errors_are_drawn_within_bounds_and_felt_by_the_plant() -> None:
    cfg = _quiet(PAPER)
    kw = {**SHORT, "sequence": "12", "rates_dps": (50.0,), "seed": 4}
    runs = list(iter_multiposition(cfg, turntable_error=True, **kw))
    ideal = next(iter_multiposition(cfg, **kw))
    err = runs[0].errors["position_arcmin"]
    assert err.shape == (12 + 3, 2)
    assert np.abs(err).max() <= 5.0 and np.abs(err).max() > 3.0
    assert np.abs(err).std() > 0.8  # spread as drawn (uniform ±5′: sd 2.9′)
    rate = runs[0].errors["rate_ppm"]
    assert rate.size == 3 * 2 and np.abs(rate).max() <= 10.0 and np.ptp(rate) > 0
    assert np.all(ideal.errors["position_arcmin"] == 0)
    # the logged angles are the commanded ones: identical with and without errors
    cols = ["table_outer_deg", "table_inner_deg", "table_outer_rate_dps", "table_inner_rate_dps"]
    assert runs[0].log[cols].equals(ideal.log[cols])
    # z up at (0, 0), outer angle off by e: accel x sees −g·sin(e) (x tilts by e about y)
    a, b, _ = _segments(ideal.log)[0]
    g = _somigliana(math.radians(cfg.latitude_deg), cfg.altitude_m)
    dx = (runs[0].log["accel_x"].iloc[a:b].mean() - ideal.log["accel_x"].iloc[a:b].mean()) * 1e-6
    dx /= 0.1  # pulses per 0.1 s → m/s²
    e = math.radians(err[0, 0] / 60.0)
    assert dx == pytest.approx(-g * math.sin(e), rel=1e-3)


def test_truth_table_format_and_laws() -> None:
    cfg = replace(PAPER, output=OutputConfig(mode="pulses"))
    log, truth, meta = simulate_multiposition(cfg, sequence="12", rates_dps=(50.0,),
                                              dwell_s=5.0, warmup_s=600.0,
                                              set_points_c=(0.0, 40.0))  # fmt: skip
    truth = check_params_table(truth)
    assert list(truth.columns) == list(PARAMS_COLUMNS)
    assert len(truth) == 2 * len(PARAMETERS) == 66 and np.all(truth["sd"] == 0)
    assert sorted(truth["temperature_c"].unique()) == sorted(meta["set_points_c"].values())
    assert meta["set_points_c"] == {"cal_+00C": 0.0, "cal_+40C": 40.0}
    assert meta["protocol"] == "multiposition" and meta["turntable"]["ideal"] is True
    for run, c in meta["set_points_c"].items():
        rows = log[log["run"] == run]
        segs = [s for s in _segments(rows) if s[2] != "transition"]
        sel = np.concatenate([np.arange(a, b) for a, b, _ in segs])
        for j, ch in enumerate(CHANNELS):
            temp = rows[f"temp_{ch}"].to_numpy()[sel].mean()  # thermometer: ±0.01 °C
            th = cfg.thermal[j]
            name = f"{ch.split('_')[0]}_sf_{ch[-1]}"
            pick = (truth["temperature_c"] == c) & (truth["parameter"] == name)
            got = truth.loc[pick, "value"].item()
            law = th.scale_factor_ppm + th.scale_factor_ppm_per_c * (temp - cfg.t_cal_c)
            assert got == pytest.approx(law, abs=abs(th.scale_factor_ppm_per_c) * 0.01)
    # the unit warms ~10 °C above the chamber: the 40 °C run's scale factors differ
    sf = truth[truth["parameter"] == "accel_sf_z"]["value"].to_numpy()
    assert sf[1] - sf[0] == pytest.approx(40.0 * cfg.thermal[5].scale_factor_ppm_per_c, rel=0.1)


def test_bias_truth_is_the_mean_bias_of_the_calibration_samples() -> None:
    """navigation_grade, noise off but turn-on offsets on: at each static position the
    output less the textbook signal through the truth's own terms is the truth's bias."""
    base = ImuConfig.navigation_grade()
    quiet = _quiet(base)
    bias_keys = ("b0", "t", "rate", "grad")
    thermal = tuple(
        replace(q, **{k: getattr(b, k) for k in bias_keys})
        for q, b in zip(quiet.thermal, base.thermal, strict=True)
    )
    noise = replace(quiet.noise, gyro_turn_on_dph=0.01, accel_turn_on_ug=20.0)
    cfg = replace(quiet, thermal=thermal, noise=noise)
    log, truth, meta = simulate_multiposition(cfg, sequence="12", rates_dps=(50.0,), dwell_s=5.0,
                                              warmup_s=36000.0, set_points_c=(20.0,))  # fmt: skip
    w = np.asarray(list(meta["unit_to_si"].values()))
    res = []
    for (a, b, _), (o, i) in zip([s for s in _segments(log) if s[2] == "static"],
                                 SEQUENCES["12"], strict=True):  # fmt: skip
        mean = log[list(CHANNELS)].iloc[a:b].to_numpy().mean(axis=0) * w
        omega, f = _textbook_inputs(cfg, o, i)
        res.append(mean - np.concatenate([_forward(omega, cfg.thermal, True),
                                          _forward(f, cfg.thermal, False)]))  # fmt: skip
    bias = np.mean(res, axis=0)
    tb = truth.set_index("parameter")["value"]
    gyro = np.array([tb[f"gyro_bias_{a}"] for a in "xyz"]) * DPS / 3600.0
    accel = np.array([tb[f"accel_bias_{a}"] for a in "xyz"]) * 9.80665e-6
    np.testing.assert_allclose(bias[:3], gyro, atol=2e-4 * DPS / 3600)  # 2e-4 deg/h
    np.testing.assert_allclose(bias[3:], accel, atol=0.5 * 9.80665e-6)  # 0.5 µg
    assert np.all(np.abs(gyro) > 1e-3 * DPS / 3600)  # thermal bias + offset, not zero


def test_ramp_is_one_run_with_repetitions() -> None:
    cfg = _quiet(PAPER)
    log, truth, meta = simulate_multiposition(cfg, sequence="12", rates_dps=(200.0,),
                                              dwell_s=5.0, warmup_s=60.0, ramp=True,
                                              ramp_rate_c_per_min=2.0,
                                              set_points_c=(0.0, 20.0))  # fmt: skip
    assert log["run"].unique().tolist() == ["cal_ramp"] and meta["set_points_c"] == {}
    reps = meta["repetitions"]
    assert len(reps) >= 2
    temps = sorted(truth["temperature_c"].unique())
    assert temps == [r["temperature_c"] for r in reps] and temps[-1] > temps[0] + 5
    assert np.all(np.diff(log["time_s"].to_numpy()) > 0)


def test_physical_units_truth_is_the_change_since_t_cal() -> None:
    cfg = replace(_quiet(PAPER, slopes=True), output=OutputConfig(mode="physical"))
    log, truth, meta = simulate_multiposition(cfg, sequence="12", rates_dps=(50.0,),
                                              **{**SHORT, "warmup_s": 3600.0})  # fmt: skip
    assert meta["units"]["gyro_x"] == "deg/h"
    tb = truth.set_index("parameter")["value"]
    # each parameter is its change since t_cal (20 °C), not its value
    sel = np.concatenate([np.arange(a, b) for a, b, k in _segments(log) if k != "transition"])
    dtemp = log["temp_gyro_x"].to_numpy()[sel].mean() - cfg.t_cal_c
    assert 1.0 < dtemp < 10.0  # the chamber is at t_cal; the unit warms after power-on
    th = PAPER.thermal[0]
    assert tb["gyro_sf_x"] == pytest.approx(th.scale_factor_ppm_per_c * dtemp, abs=0.03)
    assert tb["gyro_mis_xz"] == pytest.approx(th.misalignment_arcsec_per_c[2] * dtemp, abs=0.01)


def test_arguments_are_checked() -> None:
    cfg = _quiet(PAPER)
    for kw, word in (({"dwell_s": 0.0}, "dwell_s"), ({"rates_dps": (-5.0,)}, "rate"),
                     ({"set_points_c": (10.0, 10.2)}, "same"),
                     ({"set_points_c": (20.0,), "ramp": True}, "two for a ramp")):  # fmt: skip
        with pytest.raises(ConfigError, match=word):
            simulate_multiposition(cfg, **{**SHORT, **kw})

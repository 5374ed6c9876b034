"""The IMU plant: static output = Earth rate + gravity + true bias; noise statistics; config."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from rinscal import earth, units
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS
from rinscal.sim.config import ImuConfig, NoiseConfig, OutputConfig
from rinscal.sim.field import ThermometerConfig
from rinscal.sim.plant import SensorNoise, thermal_bias_eng
from rinscal.sim.polynomial import ChannelThermal
from rinscal.sim.protocols import protocol_runs, simulate_protocol, simulate_run

PRESET = ImuConfig.navigation_grade()
QUIET = replace(
    PRESET,
    noise=NoiseConfig(**{k: 0.0 for k in NoiseConfig.__dataclass_fields__}),
    thermometer=ThermometerConfig(noise_sd=0.0, resolution=0.0),
)


def test_preset_is_navigation_grade() -> None:
    """FOG 0.01 °/h class and quartz 0.01 mg class: thermal bias swings of hundredths of
    °/h and tens of µg over 0-50 °C (scale factor and misalignment, which scale the signal,
    aside)."""
    bias_only = replace(QUIET, effects=replace(QUIET.effects, scale_factor=False,
                                               misalignment=False))  # fmt: skip
    _, truth, _ = simulate_protocol("soak", hours=2.0, rate_hz=0.5, seed=1, imu=bias_only)
    b = truth.groupby("run")[[f"bias_{c}" for c in CHANNELS]].mean()
    swing = b.max() - b.min()
    for ch in CHANNELS[:3]:
        assert 0.005 < swing[f"bias_{ch}"] < 0.1  # deg/h
    for ch in CHANNELS[3:]:
        assert 10.0 < swing[f"bias_{ch}"] < 200.0  # µg


def test_static_output_is_earth_rate_and_gravity_plus_true_bias() -> None:
    spec = protocol_runs("soak", hours=0.5)[2]
    run = simulate_run(spec, QUIET, rate_hz=2.0, rng=np.random.default_rng(3))
    omega, f = earth.static_outputs_r(PRESET.latitude, PRESET.heading, PRESET.altitude_m)
    static = np.concatenate([omega / units.DPH_TO_RPS, f / units.UG_TO_MPS2])
    out = run.log[list(CHANNELS)].to_numpy()
    bias = run.truth[[f"bias_{c}" for c in CHANNELS]].to_numpy()
    np.testing.assert_allclose(out - bias, np.broadcast_to(static + run.offset, out.shape),
                               rtol=1e-12, atol=1e-9)  # fmt: skip
    # heading 0, level: x east, y north, z up -> (0, Ω cos φ, Ω sin φ) and (0, 0, g)
    lat = np.deg2rad(32.06)
    assert static[1] == pytest.approx(earth.RATE * np.cos(lat) / units.DPH_TO_RPS, rel=1e-12)
    assert static[1] == pytest.approx(12.747, abs=1e-3)  # deg/h at Nanjing
    assert static[5] == pytest.approx(earth.gravity(lat, 10.0) / units.UG_TO_MPS2, rel=1e-12)
    assert abs(static[0]) < 1e-12 and abs(static[3]) < 1e-9


def test_thermal_bias_formula_per_term() -> None:
    c = ChannelThermal(b0=1.0, t=(2.0, 0.5, 0.1), rate=(3.0, 0.2), grad=(-4.0, 0.3),
                       t_grad=0.7, t_rate=-0.6, stress=5.0)  # fmt: skip
    x, r, d, s = (np.array([v]) for v in (2.0, 0.5, -1.0, 0.25))
    expected = 1 + 2 * 2 + 0.5 * 4 + 0.1 * 8 + 3 * 0.5 + 0.2 * 0.25 - 4 * -1 + 0.3 * 1
    expected += 0.7 * 2 * -1 - 0.6 * 2 * 0.5 + 5 * 0.25
    assert c.evaluate(x, r, d, s)[0] == pytest.approx(expected, rel=1e-14)


def test_white_noise_matches_the_data_sheet_density() -> None:
    """Per-sample σ = N·√fs, so that an average over τ has σ = N/√τ (Allan at τ)."""
    cfg = replace(PRESET, noise=NoiseConfig(gyro_arw_deg_rth=0.001, accel_vrw_ug_rthz=10.0,
                                            gyro_bias_rw_dph_rth=0.0, accel_bias_rw_ug_rth=0.0,
                                            outlier_rate_hz=0.0))  # fmt: skip
    fs = 100.0
    e, _ = SensorNoise(cfg, np.random.default_rng(0), 1 / fs).draw(200_000)
    sd = e.std(axis=0)
    g_expected = 0.001 * units.DPRH_TO_RPRS * np.sqrt(fs)
    a_expected = 10.0 * units.UG_TO_MPS2 * np.sqrt(fs)
    np.testing.assert_allclose(sd[:3], g_expected, rtol=0.01)
    np.testing.assert_allclose(sd[3:], a_expected, rtol=0.01)
    # averaged over τ = 1 s: σ = N / √τ
    avg = e[:, 3].reshape(-1, 100).mean(axis=1)
    assert avg.std() == pytest.approx(10.0 * units.UG_TO_MPS2, rel=0.03)


def test_bias_random_walk_grows_as_sqrt_time_and_is_chunkable() -> None:
    cfg = replace(PRESET, noise=NoiseConfig(gyro_arw_deg_rth=0.0, accel_vrw_ug_rthz=0.0,
                                            gyro_bias_rw_dph_rth=0.0, accel_bias_rw_ug_rth=1.0,
                                            outlier_rate_hz=0.0))  # fmt: skip
    dt = 1.0
    gen = SensorNoise(cfg, np.random.default_rng(7), dt)
    chunks = np.concatenate([gen.draw(n)[0][:, 3] for n in (1000, 1, 2599)])
    steps = np.diff(chunks)
    step_sd = 1.0 * units.UG_TO_MPS2 / np.sqrt(3600.0)
    assert steps.std() == pytest.approx(step_sd, rel=0.05)
    # the walk carries across chunk boundaries: no step there is out of family
    assert np.all(np.abs(steps[[999, 1000]]) < 5 * step_sd)
    # σ of the walk after 1 h over many independent walks = 1 µg
    ends = np.array([SensorNoise(cfg, np.random.default_rng(s), 60.0).draw(60)[0][-1, 3]
                     for s in range(2000)])  # fmt: skip
    assert ends.std() / units.UG_TO_MPS2 == pytest.approx(1.0, rel=0.07)


def test_outliers_are_rare_and_large() -> None:
    fs, n = 10.0, 1_000_000  # 200 expected outliers per channel
    e, mask = SensorNoise(PRESET, np.random.default_rng(5), 1 / fs).draw(n)
    rate = mask.sum(axis=0) / (n / fs)
    np.testing.assert_allclose(rate, PRESET.noise.outlier_rate_hz, rtol=0.25)
    white = PRESET.noise.white_density_si() * np.sqrt(fs)
    assert np.median(np.abs(e[mask[:, 3], 3])) > 3 * white[3]


def test_pulse_output_conserves_the_integral() -> None:
    cfg = replace(QUIET, output=OutputConfig(mode="pulses"))
    spec = protocol_runs("soak", hours=0.2)[0]
    run = simulate_run(spec, cfg, rate_hz=10.0, rng=np.random.default_rng(0))
    counts = run.log[list(CHANNELS)].to_numpy()
    assert np.all(counts == np.round(counts))
    # truth, static and offset come in the log's unit: pulses per sample (not integers)
    true_pulses = run.truth[[f"bias_{c}" for c in CHANNELS]].to_numpy() + run.static + run.offset
    # the accumulator loses less than one pulse, however long the run
    np.testing.assert_array_less(np.abs(counts.sum(axis=0) - true_pulses.sum(axis=0)), 1.0)
    g = earth.gravity(PRESET.latitude, PRESET.altitude_m)
    # pulses are the raw output: level, accel z reads g through its scale-factor error and
    # quadratic term at t_cal (its misalignment sees no horizontal force)
    z = PRESET.thermal[5]
    raw = g * (1 + z.scale_factor_ppm * 1e-6) + z.sf_quad * units.UG_TO_MPS2 * (g / units.G0) ** 2
    assert z.scale_factor_ppm != 0 and z.sf_quad != 0
    assert run.static[5] == pytest.approx(raw * 0.1 / 1e-6, rel=1e-12)  # g·dt / weight


def _preset_text() -> str:
    from importlib import resources

    return resources.files("rinscal.data").joinpath("navigation_grade.toml").read_text()


def test_config_toml_round_trip(tmp_path) -> None:
    d = PRESET.to_dict()
    assert ImuConfig.from_dict(d) == PRESET
    p = tmp_path / "imu.toml"
    p.write_text(_preset_text().replace("latitude_deg = 32.06", "latitude_deg = 45.0"))
    cfg = ImuConfig.from_toml(p)
    assert cfg.latitude_deg == 45.0 and cfg == replace(PRESET, latitude_deg=45.0)
    assert ImuConfig.from_dict(ImuConfig.paper().to_dict()) == ImuConfig.paper()


@pytest.mark.parametrize(
    ("old", "new", "word"),
    [
        ("latitude_deg = 32.06", "latitude_deg = 95.0", "latitude_deg"),
        ("gyro_arw_deg_rth = 0.001", "gyro_arw_deg_rth = -1.0", "gyro_arw_deg_rth"),
        ("[noise]", "[noise]\nbogus = 1", r"bogus.*\[noise\]"),
        ("[thermal.gyro_x]", "[thermal.accel_q]\nb0 = 1\n[thermal.gyro_x]", "accel_q"),
        ("t = [6.0e-4, 1.0e-5, -2.0e-7]", "t = []", "thermal.t"),
        ('mode = "physical"', "mode = 'volts'", "output.mode"),
        ("[output]", "not toml ===", "not valid TOML"),
        ("hysteresis = 10.0", "hysteresis = -1.0", "hysteresis"),
        ("lever_arm = true", "lever_arm = 1", "effects.lever_arm"),
        ("misalignment_arcsec_per_c = [0.0, 0.8, 0.6]", "misalignment_arcsec_per_c = [0.8]",
         "misalignment_arcsec_per_c"),
        ("misalignment_arcsec_per_c = [0.0, 0.6, -0.8]",
         "misalignment_arcsec_per_c = [0.5, 0.6, -0.8]",
         r"\[thermal\.gyro_x\] misalignment_arcsec_per_c\[0\] must be 0"),
        ("misalignment_arcsec_per_c = [0.0, 0.6, -0.8]",
         "misalignment_arcsec_per_c = [0.0, 0.6, -0.8]\nlever_arm_m = [0.01, 0.0, 0.0]",
         r"\[thermal\.gyro_x\] lever_arm_m"),
    ],
)  # fmt: skip
def test_config_errors_name_the_key(tmp_path, old: str, new: str, word: str) -> None:
    text = _preset_text()
    assert old in text
    p = tmp_path / "bad.toml"
    p.write_text(text.replace(old, new, 1))
    with pytest.raises(ConfigError, match=word) as e:
        ImuConfig.from_toml(p)
    assert "bad.toml" in str(e.value)


@pytest.mark.parametrize("section", ["[noise]", "[effects]", "[thermal.accel_y]", "[network]"])
def test_a_missing_section_is_an_error_naming_it(tmp_path, section: str) -> None:
    """Today's trap: a missing [thermal.accel_y] silently became zeros."""
    text = _preset_text()
    start = text.index(section)
    end = text.find("\n[", start + 1)
    p = tmp_path / "cut.toml"
    p.write_text(text[:start] + (text[end + 1 :] if end >= 0 else ""))
    with pytest.raises(ConfigError, match=re.escape(f"missing section(s) {section}")):
        ImuConfig.from_toml(p)


def test_presets_by_name_and_unknown_names() -> None:
    from rinscal.presets import PRESETS
    from rinscal.sim.config import load_imu

    assert set(PRESETS) == {
        "paper",
        "navigation_grade",
        "paper_mechanistic",
        "navigation_grade_mechanistic",
        "ring_laser",
    }
    assert load_imu("navigation_grade") == PRESET
    assert load_imu("paper").name.startswith("the paper")
    with pytest.raises(ConfigError, match="neither a preset"):
        load_imu("navgrade")


def test_thermal_bias_uses_each_input() -> None:
    """The plant is not a function of T alone: rate, gradient and hidden stress all matter."""
    from rinscal.sim.field import ThermalField

    n = 4
    base = dict(t=np.arange(n, dtype=float), sensor=np.full((n, 6), 30.0),
                sensor_rate=np.zeros((n, 6)), outer=np.full(n, 30.0), chamber=np.full(n, 20.0),
                stress=np.zeros((n, 6)), coil_gradient=np.zeros((n, 6)),
                coil_gradient_rate=np.zeros((n, 6)))  # fmt: skip
    b0 = thermal_bias_eng(ThermalField(**base), PRESET)
    for key, val in (("sensor_rate", np.full((n, 6), 0.3 / 60)), ("outer", np.full(n, 29.0)),
                     ("stress", np.ones((n, 6)))):  # fmt: skip
        b = thermal_bias_eng(ThermalField(**{**base, key: val}), PRESET)
        assert np.all(np.abs(b - b0)[:, 3:] > 0.1), key  # µg

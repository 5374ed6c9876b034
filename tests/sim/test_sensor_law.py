"""The plant's scale factor, asymmetry, quadratic term and misalignment: the law in
temperature (:func:`rinscal.sim.sensor.sensor_law`), and the physical soak output
pinned to what it was before those terms existed."""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np
import pytest

from rinscal import earth, units
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS
from rinscal.sim.config import ImuConfig
from rinscal.sim.protocols import protocol_runs, simulate_run
from rinscal.sim.sensor import raw_output_r, sensor_law

# Recorded from main's code before the nonlinear terms were added (commit a422584):
# `simulate_run` of soak_+14C, 0.05 h at 1 Hz, rng seed 11, physical units.
PINNED = {
    "navigation_grade": {
        "first": [-0.08123024806355543, 12.855383321030867, 7.745407919942573,
                  29.90491426219985, -38.086556611819375, 998109.4561839753],
        "last": [-0.002872573688821256, 12.86581699762533, 7.975150815284521,
                 9.795957513181897, -52.465556889486685, 998276.8022916478],
        "sum": [1.3096459351136704, 2299.3285410880717, 1435.5231797588744,
                2390.027050394, -10101.872622273097, 179677683.95145917],
    },
    "paper": {
        "first": [12.695270123525905, 0.1330853030639891, 7.768680573656789,
                  183.39251244570283, 510.2953016036504, 997388.4706312958],
        "last": [12.752156813711839, 0.09425077084886321, 7.971893320054862,
                 -821.8126847416188, -343.4056174929548, 997712.4748388137],
        "sum": [2297.032908946315, 6.901068350121846, 1433.839335005055,
                -107255.79436873524, -34453.19722219671, 179554891.39255595],
    },
}  # fmt: skip

#: Keys of ChannelThermal that hold the slopes of the nonlinear scale-factor terms.
_NEW_SLOPES = ("sf_asym_ppm_per_c", "sf_quad_per_c")


def _without_new_slopes(cfg: ImuConfig) -> ImuConfig:
    names = {f.name for f in fields(cfg.thermal[0])}
    zero = {k: 0.0 for k in _NEW_SLOPES if k in names}
    return replace(cfg, thermal=tuple(replace(c, **zero) for c in cfg.thermal))


def _soak_output(cfg: ImuConfig) -> np.ndarray:
    spec = protocol_runs("soak", hours=0.05)[2]
    run = simulate_run(spec, cfg, rate_hz=1.0, rng=np.random.default_rng(11))
    return run.log[list(CHANNELS)].to_numpy()


@pytest.mark.parametrize("name", sorted(PINNED))
def test_physical_soak_output_is_pinned(name: str) -> None:
    x = _soak_output(_without_new_slopes(ImuConfig.preset(name)))
    pin = PINNED[name]
    # bit for bit on the machine they were recorded on; 1e-13 leaves room for another libm
    np.testing.assert_allclose(x[0], pin["first"], rtol=1e-13, atol=0)
    np.testing.assert_allclose(x[-1], pin["last"], rtol=1e-13, atol=0)
    np.testing.assert_allclose(x.sum(axis=0), pin["sum"], rtol=1e-13, atol=0)


def test_physical_output_ignores_the_values_at_t_cal() -> None:
    """After the factory calibration at t_cal only changes since t_cal remain: values at
    t_cal of every term leave the physical output bit for bit unchanged."""
    cfg = _without_new_slopes(ImuConfig.navigation_grade())
    blank = replace(
        cfg,
        thermal=tuple(
            replace(c, scale_factor_ppm=0.0, misalignment_arcsec=(0.0, 0.0, 0.0),
                    sf_asym_ppm=0.0, sf_quad=0.0)
            for c in cfg.thermal
        ),
    )  # fmt: skip
    assert np.array_equal(_soak_output(cfg), _soak_output(blank))


def test_physical_output_carries_the_drift_of_the_quadratic_term() -> None:
    """With a quadratic slope q' on accel z only, the level unit's z output changes by
    q'·(T − t_cal)·g² (g² in g units: µg), nothing else."""
    base = _without_new_slopes(ImuConfig.navigation_grade())
    th = list(base.thermal)
    th[5] = replace(th[5], sf_quad_per_c=2.0)  # µg/g²/°C
    cfg = replace(base, thermal=tuple(th))
    spec = protocol_runs("soak", hours=0.05)[0]  # 0 °C: 20 °C below t_cal
    r0 = simulate_run(spec, base, rate_hz=1.0, rng=np.random.default_rng(3))
    r1 = simulate_run(spec, cfg, rate_hz=1.0, rng=np.random.default_rng(3))
    d = (r1.log[list(CHANNELS)] - r0.log[list(CHANNELS)]).to_numpy()
    assert np.all(d[:, :5] == 0)
    g = earth.gravity(base.latitude, base.altitude_m) / units.G0
    t_true = r1.truth  # truth bias includes the signal drift: same difference
    temp = r1.log["temp_accel_z"].to_numpy()  # thermometer reading, ±0.01 °C
    expected = 2.0 * (temp - base.t_cal_c) * g**2
    np.testing.assert_allclose(d[:, 5], expected, atol=2.0 * 0.02 * g**2)
    assert np.all(d[:, 5] < -30)  # ~ −40 µg at 0 °C
    assert np.allclose(t_true["bias_accel_z"] - r0.truth["bias_accel_z"], d[:, 5])


def test_sensor_law_holds_the_config_values_and_slopes() -> None:
    cfg = ImuConfig.paper()
    law = sensor_law(cfg)
    assert law.t0_c == cfg.t_cal_c and law.t_range_c[0] <= -50 and law.t_range_c[1] >= 90
    gx, az = cfg.thermal[0], cfg.thermal[5]
    t = np.array([cfg.t_cal_c + 10.0])
    assert law.value("gyro_sf_x", t)[0] == pytest.approx(
        gx.scale_factor_ppm + 10 * gx.scale_factor_ppm_per_c
    )
    assert law.value("gyro_sf_asym_x", t)[0] == pytest.approx(
        gx.sf_asym_ppm + 10 * gx.sf_asym_ppm_per_c
    )
    assert law.value("gyro_mis_xz", t)[0] == pytest.approx(
        gx.misalignment_arcsec[2] + 10 * gx.misalignment_arcsec_per_c[2]
    )
    assert law.value("accel_sf_quad_z", t)[0] == pytest.approx(az.sf_quad + 10 * az.sf_quad_per_c)
    assert not any(p.endswith(("bias_x", "bias_y", "bias_z")) for p in law.t_coefs)
    # 15 gyro + 12 accel parameters (no accel asymmetry, no biases)
    assert len(law.t_coefs) == 15 + 12
    # effects off: the slopes go, the values at t_cal stay
    off = replace(cfg, effects=replace(cfg.effects, scale_factor=False, misalignment=False))
    law_off = sensor_law(off)
    for name, (v, s) in law_off.t_coefs.items():
        assert s == 0.0 and v == law.t_coefs[name][0]
    sf_only = sensor_law(replace(cfg, effects=replace(cfg.effects, misalignment=False)))
    assert sf_only.t_coefs["gyro_sf_quad_z"][1] == cfg.thermal[2].sf_quad_per_c
    assert sf_only.t_coefs["accel_mis_zy"][1] == 0.0


def test_raw_output_is_the_forward_model() -> None:
    """A rate of 100 deg/s about x, 1 g along z: the textbook model by hand."""
    cfg = ImuConfig.navigation_grade()
    law = sensor_law(cfg)
    w = np.radians(100.0)
    omega = np.array([w, 0.0, 0.0])
    f = np.array([0.0, 0.0, units.G0])
    y = raw_output_r(law, np.full(6, cfg.t_cal_c), omega, f)
    gx = cfg.thermal[0]
    expected_x = (
        w * (1 + 1e-6 * (gx.scale_factor_ppm + gx.sf_asym_ppm))
        + (gx.sf_quad * 1e-6 / np.radians(1.0)) * w**2
    )
    assert y[0] == pytest.approx(expected_x, rel=1e-12)
    gy = cfg.thermal[1]  # gyro y tilted towards x sees the x rate
    u = w * gy.misalignment_arcsec[0] * units.ARCSEC_TO_RAD
    expected_y = (u * (1 + 1e-6 * gy.scale_factor_ppm) + 1e-6 * gy.sf_asym_ppm * abs(u)
                  + gy.sf_quad * 1e-6 / np.radians(1.0) * u**2)  # fmt: skip
    assert y[1] == pytest.approx(expected_y, rel=1e-12)
    az = cfg.thermal[5]
    assert y[5] == pytest.approx(units.G0 * (1 + 1e-6 * az.scale_factor_ppm)
                                 + az.sf_quad * units.UG_TO_MPS2, rel=1e-12)  # fmt: skip


@pytest.mark.parametrize(
    ("channel", "key", "value", "word"),
    [
        ("accel_x", "sf_asym_ppm", 2.0, r"\[thermal\.accel_x\] sf_asym_ppm must be 0"),
        ("accel_y", "sf_asym_ppm_per_c", 0.1, r"sf_asym_ppm_per_c must be 0"),
        ("gyro_z", "misalignment_arcsec", [0.0, 1.0, 5.0], r"misalignment_arcsec\[2\] must be 0"),
        ("gyro_x", "misalignment_arcsec", [0.0, 1.0], "misalignment_arcsec must have 3"),
    ],
)
def test_config_refuses_bad_sensor_terms(channel, key, value, word) -> None:
    d = ImuConfig.navigation_grade().to_dict()
    d["thermal"][channel][key] = value
    with pytest.raises(ConfigError, match=word):
        ImuConfig.from_dict(d, source="x.toml")


def test_old_files_without_the_new_keys_still_load() -> None:
    d = ImuConfig.navigation_grade().to_dict()
    for ch in d["thermal"].values():
        for k in ("scale_factor_ppm", "misalignment_arcsec", "sf_asym_ppm",
                  "sf_asym_ppm_per_c", "sf_quad", "sf_quad_per_c"):  # fmt: skip
            ch.pop(k)
    cfg = ImuConfig.from_dict(d)
    assert all(c.scale_factor_ppm == 0 and c.sf_quad == 0 for c in cfg.thermal)

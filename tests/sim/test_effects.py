"""The plant's physics beyond a polynomial bias, each against an independent value.

The paper preset against Table 6 converted here by hand; distinct T, Ṫ and ΔT; the FOG
Shupe bias; quartz hysteresis; scale factor, non-orthogonality and the lever arm; heat fixed
in the body while the IMU turns.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rinscal import earth, units
from rinscal.nav.rotation import RotationSchedule
from rinscal.schema import CHANNELS
from rinscal.sim.config import EffectsConfig, ImuConfig, NoiseConfig
from rinscal.sim.field import ChamberProfile, ThermalField, simulate_field
from rinscal.sim.plant import hysteresis_play, play_operator, thermal_bias_eng
from rinscal.sim.polynomial import ChannelThermal
from rinscal.sim.protocols import protocol_runs, simulate_run

PAPER = ImuConfig.paper()
NAV = ImuConfig.navigation_grade()
OFF = EffectsConfig(False, False, False, False, False, False)

# Table 6 of the paper [pulses]: (T1, T2, T3), (Ṫ1, Ṫ2, Ṫ3), (ΔT1, ΔT2, ΔT3)
TABLE6_ACCEL = {
    "accel_x": ((-8.52, 0.180, -1.84e-3), (92.22, 256.82, -148.15), (-533.16, 280.29, -45.09)),
    "accel_y": ((3.41, 0.0575, -1.73e-3), (94.10, 118.68, -18.01), (-407.06, 191.04, -27.73)),
    "accel_z": ((-10.31, 0.122, -2.61e-4), (-128.82, -23.17, -1.41), (-290.31, 163.01, -25.43)),
}
TABLE6_GYRO = {"gyro_x": (-0.0175, 40.48, 3.87), "gyro_y": (-0.0158, 14.85, 0.592),
               "gyro_z": (-0.0419, 4.82, 0.397)}  # fmt: skip
G0X, G0Z, A0Z = 7361.77, 3617.88, 465231.31  # Table 6 static outputs [pulses]


def _field(T, Tdot_per_min, dT) -> ThermalField:  # type: ignore[no-untyped-def]
    """A field with the given sensor temperature, rate and gradient (all channels)."""
    T = np.atleast_1d(np.asarray(T, dtype=float))
    n = T.size
    z = np.zeros((n, 6))
    sensor = np.repeat(T[:, None], 6, axis=1)
    rate = np.repeat(np.broadcast_to(np.asarray(Tdot_per_min, float) / 60.0, (n,))[:, None], 6, 1)
    outer = T - np.broadcast_to(np.asarray(dT, float), (n,))
    return ThermalField(t=np.arange(n, dtype=float), sensor=sensor, sensor_rate=rate,
                        outer=outer, chamber=T.copy(), stress=z, coil_gradient=z,
                        coil_gradient_rate=z)  # fmt: skip


def test_paper_preset_is_table_6_converted() -> None:
    """Pulse scales from the paper's own static outputs (A0z = 1 g, G0z = Ω sin L, G0x =
    Ω cos L with x north), applied to Table 6 here, equal the preset's bias at chosen
    (T, Ṫ, ΔT) points inside the data's range."""
    lat = np.deg2rad(32.06)
    ug = earth.gravity(lat, 10.0) / 9.80665e-6 / A0Z  # µg per accelerometer pulse
    om = 7.2921151467e-5 * 180 / np.pi * 3600  # Earth rate [deg/h]
    dph = {"gyro_x": om * np.cos(lat) / G0X, "gyro_z": om * np.sin(lat) / G0Z}
    dph["gyro_y"] = 0.5 * (dph["gyro_x"] + dph["gyro_z"])
    assert ug == pytest.approx(2.147, abs=1e-3) and dph["gyro_z"] == pytest.approx(0.0022, 1e-2)
    pts = [(5.0, 0.3, 0.5), (21.0, 0.05, 1.2), (38.0, 0.8, 2.4), (14.0, 0.0, 0.0)]
    cfg = replace(PAPER, effects=OFF)
    for T, r, d in pts:
        b = thermal_bias_eng(_field([T], r, d), cfg)[0]
        for ch, (pt, pr, pd) in TABLE6_ACCEL.items():
            terms = [c * v ** (k + 1) for cs, v in ((pt, T), (pr, r), (pd, d))
                     for k, c in enumerate(cs)]  # fmt: skip
            # the preset holds 5 significant digits: 1e-4 of the largest term
            tol = 1e-4 * ug * max(abs(x) for x in terms)
            assert b[CHANNELS.index(ch)] == pytest.approx(sum(terms) * ug, abs=tol), (ch, T)
        for ch, (gt, gr, gd) in TABLE6_GYRO.items():
            want = (gt * T + gr * r + gd * d) * dph[ch]
            assert b[CHANNELS.index(ch)] == pytest.approx(want, rel=2e-4), (ch, T, r, d)
    # the static outputs these scales come from: the simulated log at 0 °C reads Table 6's
    omega, f = earth.static_outputs_r(PAPER.latitude, PAPER.heading, PAPER.altitude_m)
    assert omega[0] / units.DPH_TO_RPS / dph["gyro_x"] == pytest.approx(G0X, rel=1e-4)
    assert abs(omega[1] / units.DPH_TO_RPS) < 1e-9  # y east-west: G0y ≈ 0
    assert f[2] / units.UG_TO_MPS2 / ug == pytest.approx(A0Z, rel=1e-6)


def test_paper_gradient_polynomial_is_continued_by_its_tangent_outside_its_range() -> None:
    c = ChannelThermal(t=(0.0,), grad=(-533.16, 280.29, -45.09), grad_range=(0.0, 2.6))
    z = np.zeros(3)
    d = np.array([-1.0, 2.6, 3.6])
    slope0, slope_hi = -533.16, -533.16 + 2 * 280.29 * 2.6 - 3 * 45.09 * 2.6**2
    p_hi = -533.16 * 2.6 + 280.29 * 2.6**2 - 45.09 * 2.6**3
    np.testing.assert_allclose(c.evaluate(z, z, d, z), [-slope0, p_hi, p_hi + slope_hi], rtol=1e-12)


@pytest.mark.parametrize("profile", ["soak", "ramp"])
def test_rate_and_gradient_are_distinct_signals(profile: str) -> None:
    """After the first ten minutes |corr(Ṫ, ΔT)| < 0.95 for every sensor (it was −1.000
    with one dominant thermal mode): heat reaches each sensor by several paths."""
    spec = protocol_runs(profile)[0]
    f = simulate_field(spec.profile, PAPER.thermal_network(), spec.duration_s, dt_s=2.0)
    late = f.t >= 600.0
    for j in range(6):
        c = np.corrcoef(f.sensor_rate[late, j], f.gradient[late, j])[0, 1]
        assert abs(c) < 0.95, (CHANNELS[j], c)


def _shupe_only(ch: int) -> ImuConfig:
    thermal = tuple(
        ChannelThermal(t=(0.0,), shupe=0.2 if j == ch else 0.0) for j in range(6)
    )  # fmt: skip
    return replace(PAPER, thermal=thermal, effects=replace(OFF, shupe=True))


def test_shupe_bias_follows_the_coil_gradient_rate_and_vanishes_at_rest() -> None:
    """In a linear chamber ramp the gyro bias is S·d(T_coil − T_hub)/dt; at constant
    chamber temperature after warm-up it vanishes; an outside ramp and self-heating give
    different biases at the same rate of the sensor node."""
    cfg = _shupe_only(0)
    net = cfg.thermal_network()
    ramp = simulate_field(ChamberProfile.ramp(-2.0, 50.0, 0.2, hold_before_s=12 * 3600.0),
                          net, duration_s=16 * 3600.0, dt_s=1.0, power_on_s=-1.0)  # fmt: skip
    bias = thermal_bias_eng(ramp, cfg)[:, 0]
    # numerical derivative of the coil-minus-hub temperatures [°C/min], by the test
    g = ramp.coil_gradient[:, 0]
    num = np.gradient(g, ramp.t) * 60.0
    sl = slice(12 * 3600 + 10, 16 * 3600 - 10)
    np.testing.assert_allclose(bias[sl], 0.2 * num[sl], rtol=2e-3, atol=1e-7)
    assert np.abs(bias[sl]).max() > 1e-4  # deg/h: a real bias while the ramp starts
    # warmed up at a constant chamber: nothing
    rest = simulate_field(ChamberProfile.constant(20.0), net, 30 * 3600.0, dt_s=10.0)
    assert abs(thermal_bias_eng(rest, cfg)[-1, 0]) < 1e-6
    # outside heating (unpowered unit in a ramp) against self-heating (cold start)
    out = simulate_field(ChamberProfile.ramp(0.0, 50.0, 1.0), net, 3600.0, 1.0,
                         power_on_s=np.inf)  # fmt: skip
    own = simulate_field(ChamberProfile.constant(20.0), net, 3 * 3600.0, 1.0)
    r_out, r_own = out.sensor_rate[:, 0] * 60, own.sensor_rate[:, 0] * 60
    target = 0.1  # °C/min, reached by both (self-heating: after its first 2.5 min)
    i = np.argmin(np.abs(r_out[600:] - target)) + 600
    k = np.argmin(np.abs(r_own[150:] - target)) + 150
    assert abs(r_out[i] - target) < 0.005 and abs(r_own[k] - target) < 0.005
    b_out, b_own = thermal_bias_eng(out, cfg)[i, 0], thermal_bias_eng(own, cfg)[k, 0]
    # outside heat reaches the hub (baseplate) before the coil, the coil gradient falls;
    # self-heating has passed its peak and the coil catches up with the hub: it rises
    assert b_out < 0 < b_own and abs(b_own - b_out) > 1e-3  # deg/h


def test_play_operator_is_the_textbook_backlash() -> None:
    x = np.array([0.0, 0.5, 2.0, 3.0, 2.5, 1.0, -1.0])
    np.testing.assert_allclose(play_operator(x, 1.0, 0.0), [0, 0, 1, 2, 2, 2, 0], atol=0)


def test_hysteresis_loop_width_and_memory() -> None:
    """A closed temperature cycle: heating and cooling legs differ by the configured loop
    width at the same temperature; the memory carries the direction of the last excursion
    into the next run, so the order of soak runs matters."""
    cfg = replace(NAV, effects=replace(OFF, hysteresis=True))
    T = np.concatenate([np.linspace(10.0, 30.0, 201), np.linspace(30.0, 10.0, 201)[1:]])
    f = _field(T, 0.0, 0.0)
    b = thermal_bias_eng(f, cfg, hysteresis_play(f, cfg, memory=np.full(6, 10.0)))
    up, down = 100, 200 + 100  # both at 20 °C
    assert T[up] == pytest.approx(20.0) and T[down] == pytest.approx(20.0)
    for j in range(3, 6):
        width = NAV.thermal[j].hysteresis
        assert width > 0
        assert b[up, j] - b[down, j] == pytest.approx(width, rel=1e-12)
    # memory: a soak run at 21 °C after a hotter run starts on the cooling leg, after a
    # colder one on the heating leg
    spec = replace(protocol_runs("soak", hours=0.02)[3], duration_s=60.0)
    quiet = replace(cfg, noise=NoiseConfig(**{k: 0.0 for k in NoiseConfig.__dataclass_fields__}))
    rng = np.random.default_rng
    after_hot = simulate_run(spec, quiet, 1.0, rng(0), memory=np.full(6, 40.0))
    after_cold = simulate_run(spec, quiet, 1.0, rng(0), memory=np.full(6, 0.0))
    d = after_cold.truth.iloc[0, 2 + 3] - after_hot.truth.iloc[0, 2 + 3]  # accel_x [µg]
    # (half a second after power-on the unit has warmed a little: 0.3 % of the loop)
    assert d == pytest.approx(NAV.thermal[3].hysteresis, rel=5e-3)


def test_scale_factor_and_misalignment_in_the_static_log_are_k_times_dT_times_g() -> None:
    """A level unit: accel_z reads k_sf·(T − t_ref)·g more, accel_x m_xz·(T − t_ref)·g."""
    from rinscal.sim.plant import signal_error_coefs, signal_errors_r

    cfg = replace(NAV, effects=replace(OFF, scale_factor=True, misalignment=True))
    _, f = earth.static_outputs_r(cfg.latitude, cfg.heading, cfg.altitude_m)
    x = np.full((1, 6), 12.0)
    e = signal_errors_r(x, signal_error_coefs(cfg), np.zeros(3), f)[0]
    g = f[2]
    assert e[5] == pytest.approx(12.0 * 120e-6 * g, rel=1e-12)
    assert e[3] == pytest.approx(12.0 * 0.6 * np.pi / 180 / 3600 * g, rel=1e-12)
    assert e[4] == pytest.approx(12.0 * 0.9 * np.pi / 180 / 3600 * g, rel=1e-12)


def test_lever_arm_senses_the_centripetal_and_tangential_acceleration() -> None:
    """Accelerometer j at ρ_j on a table turning at ω about z senses −ω²ρ_j,x/y; while
    the table accelerates at ω̇ it senses ω̇ × ρ too."""
    from rinscal.sim.sensors import ThermalPlant

    cfg = replace(NAV, effects=replace(OFF, lever_arm=True))
    plant = ThermalPlant(cfg, ChamberProfile.constant(20.0), 10.0, 100.0, noise=False,
                         turn_on=False, thermal=False)  # fmt: skip
    w = 10 * np.pi / 180
    omega = np.tile([0.0, 0.0, w], (50, 1))
    se = plant.size_effect(omega)
    rx, ry = NAV.thermal[3].lever_arm_m[0], NAV.thermal[4].lever_arm_m[1]
    assert se[-1, 0] == pytest.approx(-(w**2) * rx, rel=1e-12)
    assert se[-1, 1] == pytest.approx(-(w**2) * ry, rel=1e-12)
    wdot = 5 * np.pi / 180  # rad/s²
    spin = np.column_stack([np.zeros(50), np.zeros(50), w + wdot * np.arange(1, 51) * 0.01])
    se = plant.size_effect(spin)
    rho_x = np.asarray(NAV.thermal[3].lever_arm_m)
    wz = spin[-1, 2]
    expect = -(wz**2) * rho_x[0] - wdot * rho_x[1]  # (ω̇ ẑ × ρ)_x = −ω̇ ρ_y
    assert se[-1, 0] == pytest.approx(expect, rel=1e-9)


def test_heat_fixed_in_the_body_follows_the_encoder_angle() -> None:
    """With the table turning continuously, each sensor's temperature oscillates at the
    rotation period, warmest when it faces the body-fixed hot side; the boundary swing
    (2 × 0.1 °C) reaches the sensors attenuated but measurable; the field of a table at
    rest has no such oscillation."""
    net = NAV.thermal_network()
    sched = RotationSchedule.continuous(rate_dps=6.0)  # one turn a minute
    spin = simulate_field(ChamberProfile.constant(20.0), net, 4 * 3600.0, 1.0, power_on_s=-1.0,
                          encoder=sched.angle)  # fmt: skip
    still = simulate_field(ChamberProfile.constant(20.0), net, 4 * 3600.0, 1.0, power_on_s=-1.0)
    last = spin.t > 3 * 3600.0
    phi = sched.angle(spin.t[last])
    for j in (3, 4, 5):  # accelerometers face the air directly
        osc = spin.sensor[last, j] - spin.sensor[last, j].mean()
        facing = np.cos(phi + np.radians(net.sensor_azimuth_deg[j] - net.rotation_heat_azimuth_deg))
        # a first-order lag of the facing: fit a·cos + b·sin, the amplitude is what counts
        A = np.column_stack([facing, np.sin(phi + np.radians(net.sensor_azimuth_deg[j]))])
        coef = np.linalg.lstsq(A, osc, rcond=None)[0]
        amp = np.hypot(*coef)
        assert 0.001 < amp < 0.1, (j, amp)
        assert np.ptp(still.sensor[last, j]) < 1e-6

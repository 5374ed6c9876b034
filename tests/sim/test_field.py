"""Physics of the lumped thermal network: equilibrium, energy balance, time constants."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rinscal.errors import ConfigError
from rinscal.sim.field import (
    AIR,
    BLOCK,
    COIL0,
    ELECTRONICS,
    HOUSING,
    N_STATES,
    SENSOR0,
    STRESS0,
    ChamberProfile,
    ThermalNetworkConfig,
    ThermometerConfig,
    measure,
    simulate_field,
)

NET = ThermalNetworkConfig()


def test_unpowered_network_settles_at_chamber_temperature() -> None:
    """Switched off, every node (and the stress states) relaxes to the chamber air."""
    x0 = np.full(N_STATES, 35.0)
    x0[STRESS0:] = 3.0  # stress states start away from zero too
    tau = NET.time_constants()[0]
    f = simulate_field(
        ChamberProfile.constant(10.0), NET, duration_s=20 * tau, dt_s=5.0, power_on_s=np.inf, x0=x0
    )
    np.testing.assert_allclose(f.sensor[-1], 10.0, atol=1e-6)
    assert abs(f.outer[-1] - 10.0) < 1e-6
    np.testing.assert_allclose(f.stress[-1], 0.0, atol=1e-6)
    np.testing.assert_allclose(f.sensor_rate[-1], 0.0, atol=1e-9)


def _conduction_rise(n: ThermalNetworkConfig) -> np.ndarray:
    """Steady rises over the chamber from conduction alone, written out here from the
    network's drawing (independent of ThermalNetworkConfig.system): Σ_m G_km (T_m − T_k)
    + P_k = 0 at every node, the housing also losing G_ha·T_housing to the chamber."""
    names = ["housing", "electronics", "air", "block"] + [f"s{j}" for j in range(6)]
    names += [f"coil{k}" for k in range(3)]
    ix = {nm: i for i, nm in enumerate(names)}
    edges = [("electronics", "housing", n.g_electronics_housing),
             ("electronics", "air", n.g_electronics_air),
             ("electronics", "block", n.g_electronics_block),
             ("air", "housing", n.g_air_housing), ("block", "housing", n.g_block_housing),
             ("block", "air", n.g_block_air)]  # fmt: skip
    for j in range(6):
        g = (n.g_gyro_block if j < 3 else n.g_accel_block) * n.sensor_coupling[j]
        edges.append((f"s{j}", "block", g))
        if j >= 3:
            edges.append((f"s{j}", "air", n.g_accel_air))
    for k in range(3):
        edges += [(f"coil{k}", f"s{k}", n.g_coil), (f"coil{k}", "air", n.g_coil_air)]
    L = np.zeros((13, 13))
    for a, b, g in edges:
        i, k = ix[a], ix[b]
        L[i, i] += g
        L[k, k] += g
        L[i, k] -= g
        L[k, i] -= g
    L[0, 0] += n.g_housing_air
    P = np.zeros(13)
    P[ix["electronics"]] = n.p_electronics
    P[[ix[f"s{j}"] for j in range(3)]] = n.p_gyro
    P[[ix[f"s{j}"] for j in range(3, 6)]] = n.p_accel
    return np.linalg.solve(L, P)


def test_powered_steady_state_rise_is_the_energy_balance() -> None:
    """Steady-state rises follow from conduction alone (the hot side off); all the power
    leaves through the housing: its rise is P_total / G_ha."""
    n = replace(NET, rotation_heat_c=0.0)
    rise = _conduction_rise(n)
    assert rise[0] == pytest.approx(n.total_power / n.g_housing_air, rel=1e-12)
    chamber = 21.0
    tau = n.time_constants()[0]
    f = simulate_field(ChamberProfile.constant(chamber), n, duration_s=25 * tau, dt_s=10.0)
    np.testing.assert_allclose(f.outer[-1] - chamber, rise[0], rtol=1e-6)
    np.testing.assert_allclose(f.sensor[-1] - chamber, rise[4:10], rtol=1e-6)
    ss = n.steady_state(chamber)
    for node in (HOUSING, ELECTRONICS, AIR, BLOCK):
        assert ss[node] - chamber == pytest.approx(rise[node], rel=1e-10)
    np.testing.assert_allclose(ss[SENSOR0 : SENSOR0 + 6] - chamber, rise[4:10], rtol=1e-10)
    np.testing.assert_allclose(ss[COIL0 : COIL0 + 3] - chamber, rise[10:13], rtol=1e-10)


def test_hot_side_only_moves_heat_around() -> None:
    """The body-fixed hot side redistributes heat inside the housing: the housing's
    steady rise (all the power leaving to the chamber) does not change, the sensors facing
    the hot side warm and those opposite cool."""
    hot = NET.steady_state(20.0)
    cold = replace(NET, rotation_heat_c=0.0).steady_state(20.0)
    assert hot[HOUSING] == pytest.approx(cold[HOUSING], rel=1e-12)
    facing = np.cos(np.radians(np.asarray(NET.sensor_azimuth_deg) - NET.rotation_heat_azimuth_deg))
    diff = (hot - cold)[SENSOR0 : SENSOR0 + 6]
    assert np.all(np.sign(diff[facing > 0.3]) > 0) and np.all(np.sign(diff[facing < -0.3]) < 0)


def test_late_warm_up_decays_with_the_dominant_time_constant() -> None:
    """Late in a cold start the remaining rise decays as exp(-t/τ1), τ1 from A's eigenvalues."""
    tau1 = NET.time_constants()[0]
    f = simulate_field(ChamberProfile.constant(0.0), NET, duration_s=12 * tau1, dt_s=2.0)
    ss = NET.steady_state(0.0)[SENSOR0]
    rem = ss - f.sensor[:, 0]
    i1, i2 = np.searchsorted(f.t, [5 * tau1, 8 * tau1])
    tau_measured = (f.t[i2] - f.t[i1]) / np.log(rem[i1] / rem[i2])
    assert tau_measured == pytest.approx(tau1, rel=1e-3)


def test_single_node_matches_the_rc_formula() -> None:
    """With the chamber stepped, the unpowered housing of a nearly massless IMU follows
    1 − exp(−t/τ) with τ = C/G."""
    n = ThermalNetworkConfig(
        c_electronics=1e-3, c_air=1e-3, c_block=1e-3, c_gyro=1e-4, c_coil=1e-4, c_accel=1e-4,
        g_electronics_housing=1e3, g_block_housing=1e3, g_gyro_block=1e3, g_accel_block=1e3,
        g_air_housing=1e3, g_coil=1e3,
        p_electronics=0.0, p_gyro=0.0, p_accel=0.0,
    )  # fmt: skip
    tau = n.c_housing / n.g_housing_air
    x0 = np.zeros(N_STATES)
    f = simulate_field(ChamberProfile.constant(10.0), n, duration_s=3 * tau, dt_s=1.0, x0=x0)
    expected = 10.0 * (1.0 - np.exp(-f.t / tau))
    np.testing.assert_allclose(f.outer, expected, atol=2e-3)
    assert n.time_constants()[0] == pytest.approx(tau, rel=1e-3)


def test_cold_start_warms_sensors_about_11_degrees_in_3_hours_most_in_two() -> None:
    f = simulate_field(ChamberProfile.constant(20.0), NET, duration_s=3 * 3600.0, dt_s=10.0)
    rise_3h = f.sensor[-1] - 20.0
    assert np.all((rise_3h > 10.0) & (rise_3h < 13.0))
    i2h = np.searchsorted(f.t, 2 * 3600.0)
    assert np.all((f.sensor[i2h] - 20.0) / rise_3h > 0.75)
    # a cold start produces a real inside/outside gradient and a non-zero rate early on
    i10 = np.searchsorted(f.t, 600.0)
    assert np.all(np.abs(f.gradient[i10]) > 0.05)
    assert np.all(f.sensor_rate[i10] * 60.0 > 0.05)


def test_rate_is_the_derivative_of_temperature() -> None:
    f = simulate_field(ChamberProfile.ramp(-2.0, 50.0, 0.2), NET, duration_s=5 * 3600.0, dt_s=1.0)
    num = np.gradient(f.sensor[:, 2], f.t)
    # central differences err by h²·T‴/6: 2e-4 relative on the fastest (~30 s) modes
    np.testing.assert_allclose(f.sensor_rate[1:-1, 2], num[1:-1], atol=2e-6, rtol=1e-3)


def test_ramp_profile_and_interpolation() -> None:
    p = ChamberProfile.ramp(-2.0, 50.0, 0.2)
    assert p.times_s[-1] == pytest.approx(52.0 / 0.2 * 60.0)
    assert p(0.0) == -2.0 and p(1e6) == 50.0
    assert p.rate(100.0) == pytest.approx(0.2 / 60.0)
    f = simulate_field(p, NET, duration_s=600.0, dt_s=1.0)
    g = f.at([10.5, 20.25])
    assert g.sensor.shape == (2, 6)
    np.testing.assert_allclose(g.chamber, p(np.array([10.5, 20.25])), rtol=1e-12)


def test_thermometer_quantises_to_its_resolution() -> None:
    rng = np.random.default_rng(0)
    y = measure(np.full(10000, 20.123456), ThermometerConfig(noise_sd=0.004, resolution=0.01), rng)
    steps = np.round(y / 0.01)
    np.testing.assert_allclose(y, steps * 0.01, atol=1e-12)
    assert abs(y.mean() - 20.123456) < 1e-3


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [({"g_housing_air": 0.0}, "g_housing_air"), ({"p_gyro": -1.0}, "p_gyro"),
     ({"sensor_coupling": (1.0, 2.0)}, "sensor_coupling")],
)  # fmt: skip
def test_network_config_errors_name_the_parameter(kwargs: dict, word: str) -> None:
    with pytest.raises(ConfigError, match=word):
        ThermalNetworkConfig(**kwargs)


def test_chamber_profile_rejects_non_increasing_times() -> None:
    with pytest.raises(ConfigError, match="strictly increasing"):
        ChamberProfile((0.0, 10.0, 5.0), (1.0, 2.0, 3.0))

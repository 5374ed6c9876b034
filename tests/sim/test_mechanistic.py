"""The mechanistic thermal law: the network's node dynamics it is driven by, each of its terms
computed by hand, a bias-free plant when every coefficient is zero, loading, and the CLI and
the navigation oracle on a mechanistic plant."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate
import scipy.signal
from typer.testing import CliRunner

from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS
from rinscal.sim.config import ImuConfig
from rinscal.sim.field import (
    HOUSING,
    N_NODES,
    NODE_NAMES,
    ChamberProfile,
    ThermalNetworkConfig,
    simulate_field,
)
from rinscal.sim.mechanistic import first_order_lag
from rinscal.sim.plant import thermal_bias_eng
from rinscal.sim.polynomial import POLYNOMIAL_KEYS

DOCS = Path(__file__).resolve().parents[2] / "docs" / "plant.md"
NET = ThermalNetworkConfig()
GYRO = {
    "b0": 0.002, "k_t": 0.0015, "t_sat_c": 15.0, "k_mount": 0.0008, "k_mount2": -2e-5,
    "t_mount_c": 25.0, "k_elec": 0.0006, "tau_elec_s": 1200.0, "k_path": -0.001,
    "k_coil": 0.01, "k_stress": 0.004,
}  # fmt: skip
ACCEL = {
    "b0": 5.0, "k_t": 2.0, "t_sat_c": 15.0, "k_mount": -1.5, "k_mount2": 0.03,
    "t_mount_c": 25.0, "k_elec": 0.8, "tau_elec_s": 1500.0, "k_path": 3.0, "k_stress": 6.0,
}  # fmt: skip


def mech_dict(gyro: dict | None = None, accel: dict | None = None) -> dict:  # type: ignore[type-arg]
    """navigation_grade with the mechanistic law (its Shupe, hysteresis, signal errors and
    lever arms kept, its polynomial keys dropped)."""
    d = ImuConfig.navigation_grade().to_dict()
    d["imu"]["thermal_law"] = "mechanistic"
    for ch in CHANNELS:
        for k in POLYNOMIAL_KEYS:
            d["thermal"][ch].pop(k, None)
    d["mechanistic"] = {
        ch: dict(GYRO if gyro is None else gyro)
        if j < 3
        else dict(ACCEL if accel is None else accel)
        for j, ch in enumerate(CHANNELS)
    }
    return d


def toml_text(d: dict) -> str:  # type: ignore[type-arg]
    """A minimal TOML writer for the configuration layout (tables of scalars and lists)."""

    def val(v: object) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list | tuple):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(float(v)) if isinstance(v, float) else str(v)

    out = []
    for name, sec in d.items():
        subs = {k: v for k, v in sec.items() if isinstance(v, dict)}
        flat = {k: v for k, v in sec.items() if not isinstance(v, dict)}
        if flat or not subs:
            out.append(f"[{name}]")
            out += [f"{k} = {val(v)}" for k, v in flat.items()]
        for sub, tab in subs.items():
            out.append(f"[{name}.{sub}]")
            out += [f"{k} = {val(v)}" for k, v in tab.items()]
    return "\n".join(out) + "\n"


MECH = ImuConfig.from_dict(mech_dict(), source="test")


def _t63(t: np.ndarray, y: np.ndarray) -> float:
    """Time at which a monotone step response covers 1 − 1/e of its change (interpolated)."""
    frac = (y - y[0]) / (y[-1] - y[0])
    k = int(np.argmax(frac >= 1 - np.exp(-1)))
    w = (1 - np.exp(-1) - frac[k - 1]) / (frac[k] - frac[k - 1])
    return float(t[k - 1] + w * (t[k] - t[k - 1]))


def _documented_t63() -> dict[str, tuple[float, float, float]]:
    """The table "node | own C/ΣG | chamber step t63 | power-on t63" of docs/plant.md [min]."""
    text = DOCS.read_text()
    sec = text[text.index("## The mechanistic law") :]
    head = sec.index("| node | own `C/ΣG`")  # the time-constant table, to a blank line
    table = sec[head : sec.index("\n\n", head)]
    rows = re.findall(r"^\| `(\w+)` \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \|", table, re.M)
    return {name: (float(c), float(a), float(b)) for name, c, a, b in rows}


def _scipy_lag(u: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """τ dy/dt = u − y from equilibrium, by scipy's exact first-order-hold discretisation
    (its state is shifted by the feed-through ``d``: ξ = y − d·u)."""
    sys_c = (np.array([[-1 / tau]]), np.array([[1 / tau]]), np.array([[1.0]]), np.zeros((1, 1)))
    ad, bd, cd, dd, _ = scipy.signal.cont2discrete(sys_c, dt, "foh")
    _, y, _ = scipy.signal.dlsim((ad, bd, cd, dd, dt), u, x0=[u[0] * (1 - dd[0, 0])])
    return y[:, 0]


@pytest.fixture(scope="module")
def chamber_step():  # type: ignore[no-untyped-def]
    """Unpowered unit soaked at 20 °C, chamber stepped to 30 °C (over 1 s), 20 h."""
    prof = ChamberProfile((0.0, 1.0), (20.0, 30.0))
    return simulate_field(prof, NET, 20 * 3600.0, power_on_s=np.inf)


@pytest.fixture(scope="module")
def cold_start():  # type: ignore[no-untyped-def]
    """Powered on at t = 0 in a 20 °C chamber (soaked, unpowered), 6 h."""
    return simulate_field(ChamberProfile.constant(20.0), NET, 6 * 3600.0, power_on_s=0.0)


# --------------------------------------------------------------------------- node dynamics
def test_chamber_step_moves_each_node_with_its_documented_time_constant(chamber_step) -> None:  # type: ignore[no-untyped-def]
    """Each node the law uses reaches 1 − 1/e of a chamber step at the time docs/plant.md
    gives, and of a power-on at the time it gives for that."""
    doc = _documented_t63()
    assert {"housing", "electronics", "block", "sensor_gyro_x", "coil_gyro_x"} <= set(doc)
    power = simulate_field(ChamberProfile.constant(20.0), NET, 20 * 3600.0, power_on_s=0.0)
    A, _ = NET.system()
    for name, (own, t_chamber, t_power) in doc.items():
        i = NODE_NAMES.index(name)
        assert -1.0 / A[i, i] / 60 == pytest.approx(own, abs=0.006), name
        assert _t63(chamber_step.t, chamber_step.nodes[:, i]) / 60 == pytest.approx(
            t_chamber, abs=0.1
        ), name
        assert _t63(power.t, power.nodes[:, i]) / 60 == pytest.approx(t_power, abs=0.1), name


def test_step_response_is_the_networks_modal_solution(chamber_step) -> None:  # type: ignore[no-untyped-def]
    """The simulated step response equals the eigen-decomposition's closed form
    ``x(t) = x_f + V e^{Λt} V⁻¹ (x_0 − x_f)`` (independent of the integrator), and every node's
    late approach to the chamber decays with the slowest mode of ``time_constants()``."""
    A, _ = NET.system()
    lam, V = np.linalg.eig(A)
    x0 = NET.steady_state(20.0, powered=False)
    xf = NET.steady_state(30.0, powered=False)
    np.testing.assert_allclose(xf[:N_NODES], 30.0, atol=1e-9)  # no power: all at the chamber
    t = chamber_step.t[1::600]  # the step is over at 1 s; from then on constant input
    # state at 1 s from the simulation, then the closed form from there
    c = np.linalg.solve(V, chamber_step.nodes[1] - xf)
    closed = xf + (V * np.exp(np.outer(t - 1.0, lam))[:, None, :] * c).sum(-1).real
    np.testing.assert_allclose(chamber_step.nodes[1::600], closed, atol=1e-8)
    assert np.allclose(chamber_step.nodes[0], x0)
    tau1 = NET.time_constants()[0]
    late = slice(6 * 3600, 12 * 3600)
    for name in ("housing", "electronics", "block", "sensor_gyro_x", "coil_gyro_z", "air"):
        y = np.log(30.0 - chamber_step.node(name)[late])
        slope = np.polyfit(chamber_step.t[late], y, 1)[0]
        assert -1.0 / slope == pytest.approx(tau1, rel=1e-3), name
    assert tau1 / 60 == pytest.approx(152.7, abs=0.05)  # documented


def test_stress_state_is_the_gradient_lagged_by_tau_stress(cold_start) -> None:  # type: ignore[no-untyped-def]
    """σ_j obeys τ_σ dσ/dt = (T_j − T_housing) − σ (integrated here by scipy's ODE solver)."""
    f = cold_start
    for j in (0, 4):
        d = f.sensor[:, j] - f.outer

        def rhs(t: float, s: np.ndarray, d: np.ndarray = d) -> np.ndarray:
            return (np.interp(t, f.t, d) - s) / NET.tau_stress_s

        sol = scipy.integrate.solve_ivp(
            rhs, (0.0, f.t[-1]), [0.0], t_eval=f.t[::60], rtol=1e-9, atol=1e-11, max_step=5.0
        )
        np.testing.assert_allclose(f.stress[::60, j], sol.y[0], atol=2e-5)
        assert np.abs(f.stress[:, j]).max() > 0.5  # it does move on a cold start


def test_energy_balance_and_linearity_of_the_network(chamber_step) -> None:  # type: ignore[no-untyped-def]
    """Powered at equilibrium, all the dissipated power leaves through the housing; a chamber
    step on a powered unit at equilibrium moves every node as on an unpowered one."""
    x = NET.steady_state(20.0, powered=True)
    assert NET.g_housing_air * (x[HOUSING] - 20.0) == pytest.approx(NET.total_power, rel=1e-9)
    prof = ChamberProfile((0.0, 1.0), (20.0, 30.0))
    on = simulate_field(prof, NET, 6 * 3600.0, power_on_s=-1.0)
    n = on.t.size
    np.testing.assert_allclose(
        on.nodes - on.nodes[0], chamber_step.nodes[:n] - chamber_step.nodes[0], atol=1e-9
    )


# --------------------------------------------------------------------------- the lag
def test_lag_reaches_one_minus_one_over_e_at_tau_and_lags_a_ramp_by_tau() -> None:
    tau = 900.0
    t = np.arange(0.0, 5 * tau + 1.0, 1.0)
    step = np.where(t > 0, 1.0, 0.0)
    y = first_order_lag(t, step, tau)
    assert y[int(tau)] == pytest.approx(1 - np.exp(-1), abs=2e-3)  # the 1 s ramp-in
    # the exact step response from the 1 s point on
    np.testing.assert_allclose(y[1:], 1 - (1 - y[1]) * np.exp(-(t[1:] - 1.0) / tau), atol=1e-12)
    ramp = first_order_lag(t, 0.01 * t, tau)
    assert ramp[-1] == pytest.approx(0.01 * (t[-1] - tau), rel=0, abs=0.01 * tau * np.exp(-5))


def test_lag_equals_scipys_first_order_hold_discretisation() -> None:
    """An independent exact discretisation (scipy cont2discrete, 'foh') on an irregular signal."""
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 3000.0, 2.0)
    u = np.cumsum(rng.standard_normal(t.size))
    tau = 300.0
    np.testing.assert_allclose(first_order_lag(t, u, tau), _scipy_lag(u, 2.0, tau), atol=1e-9)
    # irregular grid: every second sample dropped gives the same values where both exist
    t2, u2 = t[::2], u[::2]
    lin = first_order_lag(t, np.interp(t, t2, u2), tau)
    np.testing.assert_allclose(first_order_lag(t2, u2, tau), lin[::2], atol=1e-9)


# --------------------------------------------------------------------------- each term
ZERO_G = dict.fromkeys(GYRO, 0.0) | {"t_sat_c": 15.0, "tau_elec_s": 1200.0, "t_mount_c": 25.0}
ZERO_A = {k: v for k, v in ZERO_G.items() if k != "k_coil"}


def _alone(key: str, value: float) -> ImuConfig:
    g = ZERO_G | {key: value}
    a = ZERO_A | ({key: value} if key != "k_coil" else {})
    cfg = ImuConfig.from_dict(mech_dict(g, a), source="test")
    return cfg


def _effects_off(cfg: ImuConfig) -> ImuConfig:
    from dataclasses import replace

    from rinscal.sim.config import EffectsConfig

    return replace(cfg, effects=EffectsConfig(shupe=False, hysteresis=False))


def test_every_coefficient_zero_gives_a_bias_free_plant(cold_start) -> None:  # type: ignore[no-untyped-def]
    """All mechanistic coefficients zero and Shupe/hysteresis off: no thermal bias at all,
    in the field's bias and in a simulated run's truth file."""
    from rinscal.sim.protocols import protocol_runs, simulate_run

    cfg = _effects_off(_alone("b0", 0.0))
    assert not np.any(thermal_bias_eng(cold_start, cfg))
    # the truth file also carries the static signal errors: switch those off too
    from dataclasses import replace

    cfg = replace(cfg, effects=replace(cfg.effects, scale_factor=False, misalignment=False))
    run = simulate_run(protocol_runs("soak", 0.3)[0], cfg, 1.0, np.random.default_rng(0))
    assert not np.any(run.truth[[f"bias_{c}" for c in CHANNELS]].to_numpy())
    # while the same plant with the law's coefficients is not bias-free
    assert np.ptp(thermal_bias_eng(cold_start, _effects_off(MECH)), axis=0).min() > 0


@pytest.mark.parametrize(
    ("key", "value"),
    [("b0", 0.7), ("k_t", 0.9), ("k_mount", 0.4), ("k_mount2", 0.05), ("k_elec", 0.6),
     ("k_path", 0.8), ("k_coil", 2.0), ("k_stress", 1.3)],
)  # fmt: skip
def test_each_coefficient_alone_gives_its_term(cold_start, key: str, value: float) -> None:  # type: ignore[no-untyped-def]
    f = cold_start
    cfg = _effects_off(_alone(key, value))
    b = thermal_bias_eng(f, cfg)
    tr = cfg.t_ref_c
    block, elec = f.node("block"), f.node("electronics")
    for j, ch in enumerate(CHANNELS):
        own = f.node(f"sensor_{ch}")
        if key == "b0":
            want = np.full(f.t.size, value)
        elif key == "k_t":
            want = value * 15.0 * np.tanh((own - tr) / 15.0)
        elif key == "k_mount":
            want = value * (block - 25.0)
        elif key == "k_mount2":
            want = value * (block - 25.0) ** 2
        elif key == "k_elec":
            want = value * (_scipy_lag(elec, 1.0, 1200.0) - tr)
        elif key == "k_path":
            want = value * (elec - block)
        elif key == "k_coil":
            want = value * (f.node(f"coil_{ch}") - own) if j < 3 else np.zeros(f.t.size)
        else:
            want = value * f.node(f"stress_{ch}")
        np.testing.assert_allclose(b[:, j], want, rtol=1e-12, atol=1e-9, err_msg=f"{key} {ch}")
        if key not in ("b0",) and not (key == "k_coil" and j >= 3):
            assert np.ptp(want) > 1e-3 * value  # the term really moves on a cold start


def test_own_temperature_term_saturates_and_the_mount_term_changes_sign() -> None:
    """k_t·s·tanh: slope k_t at t_ref, bounded by ±k_t·s far from it; the mount term changes
    sign across t_mount_c: a ramp through it gives a bias of both signs."""
    prof = ChamberProfile.ramp(-40.0, 70.0, 1.0)  # soaked at -40 °C, held at 70 °C after
    f = simulate_field(prof, NET, 16 * 3600.0, dt_s=10.0, power_on_s=np.inf)
    b = thermal_bias_eng(f, _effects_off(_alone("k_t", 1.0)))[:, 3]
    assert b.max() < 15.0 and b.min() > -15.0
    assert b.max() > 13.5 and b.min() < -13.0  # near saturation at both ends
    m = thermal_bias_eng(f, _effects_off(_alone("k_mount", 1.0)))[:, 3]
    assert m.min() < -50 and m.max() > 40


# --------------------------------------------------------------------------- loading
def test_polynomial_presets_keep_their_bias(cold_start) -> None:  # type: ignore[no-untyped-def]
    """Under the default law the bias is ChannelThermal's polynomial, evaluated by hand here,
    and the network states do not enter it (a field without them gives the same bias)."""
    from dataclasses import replace

    from rinscal import units

    for name in ("paper", "navigation_grade"):
        cfg = ImuConfig.preset(name)
        assert cfg.thermal_law == "polynomial" and cfg.mechanistic is None
        cfg = _effects_off(cfg)
        b = thermal_bias_eng(cold_start, cfg)
        f = cold_start
        for j, c in enumerate(cfg.thermal):
            want = c.evaluate(
                f.sensor[:, j] - cfg.t_ref_c,
                f.sensor_rate[:, j] * units.MIN_TO_S,
                f.sensor[:, j] - f.outer,
                f.stress[:, j],
            )
            np.testing.assert_array_equal(b[:, j], want)
        np.testing.assert_array_equal(thermal_bias_eng(replace(f, nodes=None), cfg), b)


def test_mechanistic_config_round_trips_and_needs_its_nodes(cold_start) -> None:  # type: ignore[no-untyped-def]
    from dataclasses import replace

    d = MECH.to_dict()
    assert d["imu"]["thermal_law"] == "mechanistic"
    assert "k_coil" not in d["mechanistic"]["accel_x"]
    assert not set(d["thermal"]["gyro_x"]) & set(POLYNOMIAL_KEYS)
    assert ImuConfig.from_dict(d) == MECH
    assert ImuConfig.from_dict(ImuConfig.paper().to_dict()) == ImuConfig.paper()
    with pytest.raises(ConfigError, match="nodes"):
        thermal_bias_eng(replace(cold_start, nodes=None), MECH)


def test_mechanistic_toml_file_loads(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from rinscal.sim.config import load_imu

    path = tmp_path / "mech.toml"
    path.write_text(toml_text(mech_dict()))
    assert load_imu(str(path)) == MECH


M = "mechanistic"
BAD = [
    (lambda d: d.pop(M), r"needs the section\(s\) \[mechanistic.gyro_x\]"),
    (lambda d: d[M].pop("accel_y"), r"missing section\(s\) \[mechanistic.accel_y\]"),
    (lambda d: d[M]["gyro_z"].pop("k_elec"), r"\['k_elec'\] in \[mechanistic.gyro_z\]"),
    (lambda d: d[M]["gyro_x"].update(k_tt=1.0), r"unknown key\(s\) \['k_tt'\] in \[mech"),
    (lambda d: d[M]["accel_x"].update(k_coil=1.0), "an accelerometer has no coil"),
    (lambda d: d[M].update(gyro_w={}), r"unknown channel\(s\) \['gyro_w'\]"),
    (lambda d: d["thermal"]["accel_z"].update(b0=1.0, t=[1.0]), r"\['b0', 't'\] in \[thermal.ac"),
    (lambda d: d["imu"].update(thermal_law="neural"), "must be one of polynomial, mechanistic"),
    (lambda d: d["imu"].update(thermal_law="polynomial"), r"\[mechanistic\] given but imu"),
    (lambda d: d[M]["gyro_y"].update(tau_elec_s=0.0), "tau_elec_s must be > 0"),
    (lambda d: d[M]["accel_x"].update(t_sat_c=-1.0), "t_sat_c must be > 0"),
]


@pytest.mark.parametrize(("edit", "message"), BAD)
def test_bad_mechanistic_tables_are_refused_by_name(edit, message: str) -> None:  # type: ignore[no-untyped-def]
    d = mech_dict()
    edit(d)
    with pytest.raises(ConfigError, match=message):
        ImuConfig.from_dict(d, source="unit.toml")


def test_a_polynomial_config_missing_thermal_law_still_loads() -> None:
    d = ImuConfig.navigation_grade().to_dict()
    d["imu"].pop("thermal_law")
    assert ImuConfig.from_dict(d) == ImuConfig.navigation_grade()


# --------------------------------------------------------------------------- CLI and navigation
def test_cli_simulate_and_navigate_with_a_mechanistic_toml(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import pandas as pd

    from rinscal.cli import app

    imu = tmp_path / "mech.toml"
    imu.write_text(toml_text(mech_dict()))
    runner = CliRunner()
    log = tmp_path / "soak.csv"
    args = ["simulate", "soak", "--imu", str(imu), "--rate", "1", "--hours", "1", "--out", str(log)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    df = pd.read_csv(log, comment="#")
    assert len(df) > 3600 and np.isfinite(df["accel_z"]).all()
    out = tmp_path / "nav"
    args = ["navigate", "--scenario", "quasi-static", "--imu", str(imu), "--hours", "0.2",
            "--rate", "5", "--out", str(out)]  # fmt: skip
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert any(out.iterdir())


def test_true_compensation_of_a_mechanistic_plant_equals_an_imu_without_thermal_errors() -> None:
    """The oracle subtracts exactly the mechanistic plant's thermal errors (same tolerance as
    the polynomial test in tests/nav/test_nav_thermal.py)."""
    from rinscal.sim.scenario import ThermalPlant, oracle_compensator, preset, run_scenario

    cfg = preset("quasi-static", hours=1.0, rate_hz=5.0)
    assert cfg.chamber is not None
    plant = ThermalPlant(MECH, cfg.chamber, cfg.duration_s, cfg.rate_hz, seed=2)
    r = run_scenario(cfg, plant, {"none": None, "true": oracle_compensator(plant)})
    ref = ThermalPlant(MECH, cfg.chamber, cfg.duration_s, cfg.rate_hz, seed=2, thermal=False)
    e_ref = run_scenario(cfg, ref).errors["none"]["horizontal_m"].to_numpy()
    np.testing.assert_allclose(r.errors["true"]["horizontal_m"].to_numpy(), e_ref, atol=1e-5)
    # the compensation did something: the thermal bias moved during the run
    gap = np.abs(r.errors["none"]["horizontal_m"].to_numpy() - e_ref).max()
    b = plant.thermal_bias(np.array([0.0, 3600.0]))
    assert np.all(np.abs(b[1, 3:] - b[0, 3:]) > 1e-5)  # > 1 µg on every accelerometer
    assert gap > 5.0  # metres (12 m here)


def test_field_at_interpolates_the_nodes(cold_start) -> None:  # type: ignore[no-untyped-def]
    t = np.array([0.0, 10.5, 3600.25, 1e9])
    g = cold_start.at(t)
    for i in (0, 1, 3, 10, 15):
        np.testing.assert_allclose(
            g.nodes[:, i], np.interp(t, cold_start.t, cold_start.nodes[:, i])
        )
    np.testing.assert_array_equal(g.node("sensor_gyro_y"), g.sensor[:, 1])
    assert cold_start.at(t, nodes=False).nodes is None

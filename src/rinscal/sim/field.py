r"""Thermal field of a single-axis RINS in a thermal chamber: chamber profiles and a lumped network.

The IMU is a lumped thermal network (capacities joined by conductances) driven by the chamber
air, by the power dissipated once the system is switched on (electronics, FOG light sources
and electronics, accelerometer servo loops) and by the turntable's torque motor while it
moves. Heat reaches every sensor by more than one path — the mount (through the IMU block
and the baseplate), the air inside the housing (warmed by the electronics) and its own
dissipation — so that its temperature, its rate and the inside/outside gradient are
distinct signals through a cold start and a ramp, as on a real unit::

    chamber ── G_ha ── housing (outer thermometer) ── G_eh ── electronics (P_e)
                 │   └─ motor (P_m while the table moves)        │
                 ├── G_ah ── inner air ── G_ea ──────────────────┘
                 │              │  \__ G_ca ── gyro coil, outer layers k = 1..3
                 │             G_ba    \_ G_sa ── accelerometer j     │ G_coil
                G_bh            │                                  gyro hub k (P_g)
                 └──────── IMU block ── G_sb ── sensor j (inner thermometer j)

Each node obeys ``C_k dT_k/dt = Σ_m G_km (T_m − T_k) + P_k``. The inner thermometer of a
gyro sits on its hub (light source, electronics); the outer layers of its fibre coil face
the inner air. Heat from outside therefore crosses the coil inwards and self-heating
outwards, and the FOG's Shupe bias follows the time derivative of that radial coil gradient
``T_coil − T_hub`` (see :mod:`rinscal.sim.plant`).

Heat fixed in the body while the IMU turns: the electronics and the motor sit on one side
of the housing, so the inner air a sensor faces is warmer on that side. Sensor ``j`` sits at
azimuth ``α_j`` on the turntable (``r`` frame); with the encoder at ``φ`` it faces air
``a · cos(φ + α_j − ψ_h)`` [°C] warmer than the mean inner air (``a`` the amplitude once
powered, ``ψ_h`` the azimuth of the hot side in the body frame).

On top of the temperatures the network carries one slow *stress* state per sensor, a
first-order lag of the sensor's inside/outside gradient, ``τ_σ dσ_j/dt = (T_j − T_housing)
− σ_j``: it stands for the thermo-mechanical stress of the sensor package, which biases the
sensor but which no thermometer sees. The whole system is linear, ``dx/dt = A x + B u``
with ``u = (T_chamber, power_on, motor_on, power_on·cos φ, power_on·sin φ)``, and is
integrated exactly (matrix exponential with a first-order hold on the inputs, a zero-order
hold on the power switch).

Temperatures in °C, times in s, capacities in J/K, conductances in W/K, powers in W.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, replace

import numba
import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS

#: Sensor nodes in channel order (gyro x, y, z, accel x, y, z).
N_SENSORS = 6
#: Gyros (the first three sensors) have a fibre coil with its own outer-layer node.
N_GYROS = 3
#: Index of the housing (package surface) node in the state vector.
HOUSING = 0
#: Index of the electronics node in the state vector.
ELECTRONICS = 1
#: Index of the inner-air node in the state vector.
AIR = 2
#: Index of the IMU block node in the state vector.
BLOCK = 3
#: Index of the first sensor node in the state vector.
SENSOR0 = 4
#: Index of the first gyro coil (outer layers) node in the state vector.
COIL0 = SENSOR0 + N_SENSORS
#: Number of thermal nodes (all but the stress states).
N_NODES = COIL0 + N_GYROS
#: Index of the first stress state in the state vector.
STRESS0 = N_NODES
#: Number of states: 4 structural nodes, 6 sensors, 3 coils, 6 stress states.
N_STATES = STRESS0 + N_SENSORS
#: Name of each state of :meth:`ThermalNetworkConfig.system`'s ``x`` (and of the columns of
#: :attr:`ThermalField.nodes`), in that order.
NODE_NAMES: tuple[str, ...] = (
    "housing",
    "electronics",
    "air",
    "block",
    *(f"sensor_{c}" for c in CHANNELS),
    *(f"coil_{c}" for c in CHANNELS[:3]),
    *(f"stress_{c}" for c in CHANNELS),
)
#: Inputs: chamber [°C], power switch, motor switch, power·cos φ, power·sin φ.
N_INPUTS = 5
#: Inputs held over each integration step (zero-order): the power and motor switches. The
#: chamber and the hot side's cos φ, sin φ are linear between steps (first-order); so is
#: the power factor of the hot side, which ramps in over the one step of a power-on.
_HELD = [1, 2]
#: Sub-steps per integration step over which the motor's running time is measured.
_MOTOR_SUBSTEPS = 10


# --------------------------------------------------------------------------- chamber profile
@dataclass(frozen=True)
class ChamberProfile:
    """Piecewise-linear chamber air temperature.

    Parameters
    ----------
    times_s : tuple of float [s]
        Break points, strictly increasing, the first one 0. Before the first and after the
        last break point the temperature is held.
    temps_c : tuple of float [°C]
        Chamber temperature at each break point.
    """

    times_s: tuple[float, ...]
    temps_c: tuple[float, ...]

    def __post_init__(self) -> None:
        t = np.asarray(self.times_s, dtype=float)
        y = np.asarray(self.temps_c, dtype=float)
        if t.ndim != 1 or t.size == 0 or t.shape != y.shape:
            raise ConfigError("chamber profile: times_s and temps_c must be equal-length lists")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))):
            raise ConfigError("chamber profile: times_s and temps_c must be finite")
        if np.any(np.diff(t) <= 0):
            raise ConfigError("chamber profile: times_s must be strictly increasing")
        if np.any(y < -70.0) or np.any(y > 150.0):
            raise ConfigError("chamber profile: temps_c outside the chamber range -70..150 °C")

    @classmethod
    def constant(cls, temp_c: float) -> ChamberProfile:
        """A chamber held at one set point [°C]."""
        return cls((0.0,), (float(temp_c),))

    @classmethod
    def ramp(
        cls,
        start_c: float,
        end_c: float,
        rate_c_per_min: float,
        hold_before_s: float = 0.0,
    ) -> ChamberProfile:
        """Hold ``start_c`` for ``hold_before_s`` [s], then ramp at ``rate_c_per_min`` [°C/min].

        The chamber holds ``end_c`` [°C] after the ramp.
        """
        if rate_c_per_min <= 0:
            raise ConfigError(f"ramp: rate_c_per_min must be > 0, got {rate_c_per_min}")
        t_ramp = abs(end_c - start_c) / rate_c_per_min * 60.0
        if hold_before_s > 0:
            return cls((0.0, hold_before_s, hold_before_s + t_ramp), (start_c, start_c, end_c))
        return cls((0.0, t_ramp), (start_c, end_c))

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """Chamber temperature [°C] at times ``t`` [s]."""
        return np.interp(np.asarray(t, dtype=float), self.times_s, self.temps_c)

    def rate(self, t: ArrayLike) -> NDArray[np.float64]:
        """Chamber temperature rate [°C/s] at times ``t`` [s] (right derivative)."""
        t = np.asarray(t, dtype=float)
        tb = np.asarray(self.times_s)
        yb = np.asarray(self.temps_c)
        if tb.size == 1:
            return np.zeros_like(t)
        slopes = np.diff(yb) / np.diff(tb)
        idx = np.searchsorted(tb, t, side="right") - 1
        out = np.zeros_like(t)
        inside = (idx >= 0) & (idx < slopes.size)
        out[inside] = slopes[idx[inside]]
        return out


# --------------------------------------------------------------------------- network
@dataclass(frozen=True)
class ThermalNetworkConfig:
    """Parameters of the lumped thermal network (defaults: a navigation-grade FOG RINS).

    With the defaults the system dissipates 16.2 W (12 W in a heavy electronics box);
    a cold start warms the sensors by about 11 °C in 3 h, three quarters of it in the
    first two hours: first by their own dissipation (minutes), then at a nearly steady
    rate for an hour while the electronics box and the housing warm (time constants of
    about 30 min and 2.5 h), so that the sensor temperature rate, which falls and then
    stalls, is not a copy of the inside/outside gradient, which keeps rising
    (|corr| ≈ 0.9 after the first ten minutes, 0.65-0.86 on the chamber ramp).

    Parameters
    ----------
    c_housing, c_electronics, c_air, c_block : float [J/K]
        Heat capacities of the housing, the electronics board, the inner air (with the
        light parts it washes) and the IMU block.
    c_gyro, c_coil, c_accel : float [J/K]
        Heat capacity of each gyro hub, each gyro's coil outer layers, each accelerometer.
    g_housing_air : float [W/K]
        Conductance (convection) from the housing to the chamber air.
    g_electronics_housing, g_electronics_air, g_electronics_block : float [W/K]
        From the electronics to the housing (mount), to the inner air and to the IMU block
        (the frame the boards are fixed to).
    g_air_housing : float [W/K]
        From the inner air to the housing walls.
    g_block_housing, g_block_air : float [W/K]
        From the IMU block to the housing (baseplate) and to the inner air.
    g_gyro_block, g_accel_block : float [W/K]
        From each gyro hub and each accelerometer to the IMU block (mount).
    g_coil : float [W/K]
        Across each fibre coil, outer layers to hub.
    g_coil_air, g_accel_air : float [W/K]
        From each coil's outer layers and each accelerometer to the inner air.
    p_electronics : float [W]
        Power of the electronics once switched on.
    p_gyro, p_accel : float [W]
        Power dissipated in each gyro hub (light source, FOG electronics) and each
        accelerometer (servo loop).
    p_motor : float [W]
        Torque-motor power into the housing while the turntable moves.
    tau_stress_s : float [s]
        Time constant of the hidden package-stress state.
    sensor_coupling : tuple of 6 float [-]
        Factor on each sensor's conductance to the block (mounting differs from sensor to
        sensor, so their temperatures differ).
    rotation_heat_c : float [°C]
        Amplitude of the body-fixed hot side of the inner air once powered (0: none).
    rotation_heat_azimuth_deg : float [deg]
        Azimuth of the hot side in the body frame (counter-clockwise from body x).
    sensor_azimuth_deg : tuple of 6 float [deg]
        Azimuth of each sensor on the turntable, in the ``r`` frame.
    """

    c_housing: float = 7500.0
    c_electronics: float = 1600.0
    c_air: float = 60.0
    c_block: float = 800.0
    c_gyro: float = 60.0
    c_coil: float = 40.0
    c_accel: float = 25.0
    g_housing_air: float = 1.2
    g_electronics_housing: float = 0.4
    g_electronics_air: float = 0.12
    g_electronics_block: float = 0.18
    g_air_housing: float = 1.2
    g_block_housing: float = 3.0
    g_block_air: float = 0.16
    g_gyro_block: float = 1.4
    g_accel_block: float = 0.27
    g_coil: float = 0.25
    g_coil_air: float = 0.15
    g_accel_air: float = 0.3
    p_electronics: float = 12.0
    p_gyro: float = 1.0
    p_accel: float = 0.4
    p_motor: float = 2.0
    tau_stress_s: float = 2400.0
    sensor_coupling: tuple[float, ...] = (1.0, 0.85, 1.15, 1.0, 0.8, 1.25)
    rotation_heat_c: float = 0.1
    rotation_heat_azimuth_deg: float = 0.0
    sensor_azimuth_deg: tuple[float, ...] = (0.0, 90.0, 225.0, 45.0, 135.0, 300.0)

    def __post_init__(self) -> None:
        for name in ("sensor_coupling", "sensor_azimuth_deg"):
            v = np.asarray(getattr(self, name), dtype=float)
            if v.shape != (N_SENSORS,) or not np.all(np.isfinite(v)):
                raise ConfigError(f"thermal network: {name} must be 6 finite numbers")
        if np.any(np.asarray(self.sensor_coupling) <= 0):
            raise ConfigError("thermal network: sensor_coupling must be 6 finite numbers > 0")
        for f in fields(self):
            if f.name in ("sensor_coupling", "sensor_azimuth_deg"):
                continue
            v = getattr(self, f.name)
            if not np.isfinite(v):
                raise ConfigError(f"thermal network: {f.name} must be finite, got {v}")
            if f.name == "rotation_heat_azimuth_deg":
                continue
            if f.name.startswith("p_") or f.name == "rotation_heat_c":
                if v < 0:
                    raise ConfigError(f"thermal network: {f.name} must be >= 0, got {v}")
            elif v <= 0:
                raise ConfigError(f"thermal network: {f.name} must be > 0, got {v}")

    @property
    def total_power(self) -> float:
        """Total dissipated power once switched on, the table at rest [W]."""
        return self.p_electronics + N_GYROS * self.p_gyro + 3 * self.p_accel

    def capacities(self) -> NDArray[np.float64]:
        """Heat capacities of the thirteen thermal nodes [J/K]."""
        return np.array(
            [self.c_housing, self.c_electronics, self.c_air, self.c_block]
            + [self.c_gyro] * 3
            + [self.c_accel] * 3
            + [self.c_coil] * N_GYROS
        )

    def powers(self) -> NDArray[np.float64]:
        """Power into each of the thirteen thermal nodes when switched on [W]."""
        return np.array(
            [0.0, self.p_electronics, 0.0, 0.0]
            + [self.p_gyro] * 3
            + [self.p_accel] * 3
            + [0.0] * N_GYROS
        )

    def links(self) -> list[tuple[int, int, float]]:
        """Conductances between nodes ``(i, j, G [W/K])`` (the chamber link excluded)."""
        out = [
            (ELECTRONICS, HOUSING, self.g_electronics_housing),
            (ELECTRONICS, AIR, self.g_electronics_air),
            (ELECTRONICS, BLOCK, self.g_electronics_block),
            (AIR, HOUSING, self.g_air_housing),
            (BLOCK, HOUSING, self.g_block_housing),
            (BLOCK, AIR, self.g_block_air),
        ]
        for j in range(N_SENSORS):
            g = self.g_gyro_block if j < N_GYROS else self.g_accel_block
            out.append((SENSOR0 + j, BLOCK, g * self.sensor_coupling[j]))
            if j >= N_GYROS:
                out.append((SENSOR0 + j, AIR, self.g_accel_air))
        for k in range(N_GYROS):
            out.append((COIL0 + k, SENSOR0 + k, self.g_coil))
            out.append((COIL0 + k, AIR, self.g_coil_air))
        return out

    def air_faces(self) -> list[tuple[int, float, float]]:
        """The nodes that face the inner air: ``(node, G [W/K], azimuth [rad] in r)``."""
        az = np.radians(self.sensor_azimuth_deg)
        faces = [(COIL0 + k, self.g_coil_air, float(az[k])) for k in range(N_GYROS)]
        faces += [(SENSOR0 + j, self.g_accel_air, float(az[j])) for j in range(N_GYROS, 6)]
        return faces

    def system(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """State-space matrices of the network.

        Returns
        -------
        A : ndarray, shape (19, 19) [1/s]
            ``dx/dt = A x + B u`` for ``x = (T_housing, T_electronics, T_air, T_block,
            T_sensor[6], T_coil[3], σ[6])``.
        B : ndarray, shape (19, 5)
            Inputs ``u = (T_chamber [°C], power switch, motor switch, power·cos φ,
            power·sin φ)``; columns 1-4 in [K/s].
        """
        G = np.zeros((N_NODES, N_NODES))
        for i, j, g in self.links():
            G[i, j] += g
            G[j, i] += g
            G[i, i] -= g
            G[j, j] -= g
        G[HOUSING, HOUSING] -= self.g_housing_air
        cap = self.capacities()
        A = np.zeros((N_STATES, N_STATES))
        A[:N_NODES, :N_NODES] = G / cap[:, None]
        B = np.zeros((N_STATES, N_INPUTS))
        B[HOUSING, 0] = self.g_housing_air / cap[HOUSING]
        B[:N_NODES, 1] = self.powers() / cap
        B[HOUSING, 2] = self.p_motor / cap[HOUSING]
        # the hot side: a cos(φ + α − ψ) = a [cos(α − ψ) cos φ − sin(α − ψ) sin φ]
        psi = np.radians(self.rotation_heat_azimuth_deg)
        # (heat the hot side brings a node, it takes from the mean inner air: energy kept)
        for node, g, alpha in self.air_faces():
            for col, q in ((3, np.cos(alpha - psi)), (4, -np.sin(alpha - psi))):
                flow = g * self.rotation_heat_c * q  # [W]
                B[node, col] += flow / cap[node]
                B[AIR, col] -= flow / cap[AIR]
        k = 1.0 / self.tau_stress_s
        for j in range(N_SENSORS):
            s = STRESS0 + j
            A[s, s] = -k
            A[s, SENSOR0 + j] += k
            A[s, HOUSING] -= k
        return A, B

    def steady_state(self, chamber_c: float, powered: bool = True) -> NDArray[np.float64]:
        """Equilibrium state at a constant chamber temperature [°C], powered or not, the
        table at rest at encoder zero.

        Returns
        -------
        ndarray, shape (19,)
            Temperatures [°C] of the nodes and the stress states [°C].
        """
        A, B = self.system()
        p = 1.0 if powered else 0.0
        u = np.array([chamber_c, p, 0.0, p, 0.0])
        return np.linalg.solve(A, -B @ u)

    def time_constants(self) -> NDArray[np.float64]:
        """Time constants of the network's thermal modes, largest first [s]."""
        A, _ = self.system()
        lam = np.linalg.eigvals(A[:N_NODES, :N_NODES]).real
        return np.sort(-1.0 / lam)[::-1]


# --------------------------------------------------------------------------- field
@dataclass(frozen=True)
class ThermalField:
    """True temperatures of the IMU on a time grid.

    Attributes
    ----------
    t : ndarray, shape (n,) [s]
        Time since power-on of this run.
    sensor : ndarray, shape (n, 6) [°C]
        Inner temperature of each sensor (channel order gyro x..z, accel x..z).
    sensor_rate : ndarray, shape (n, 6) [°C/s]
        Exact time derivative of ``sensor``.
    outer : ndarray, shape (n,) [°C]
        Housing (package surface) temperature, what the outer thermometer sees.
    chamber : ndarray, shape (n,) [°C]
        Chamber air temperature.
    stress : ndarray, shape (n, 6) [°C]
        Hidden package-stress state of each sensor (a slow lag of the gradient).
    coil_gradient : ndarray, shape (n, 6) [°C]
        Radial gradient across each gyro's fibre coil, outer layers minus hub (zero for the
        accelerometers).
    coil_gradient_rate : ndarray, shape (n, 6) [°C/s]
        Exact time derivative of ``coil_gradient``.
    nodes : ndarray, shape (n, 19) [°C], optional
        Every state of the network in the order of :meth:`ThermalNetworkConfig.system`'s
        ``x`` (names in :data:`NODE_NAMES`): housing, electronics, inner air, IMU block, the
        six sensors, the three coils' outer layers, the six stress states. Set by
        :func:`simulate_field`; the mechanistic thermal law needs it. None for a field built
        by hand from the thermometer-visible signals alone.
    """

    t: NDArray[np.float64]
    sensor: NDArray[np.float64]
    sensor_rate: NDArray[np.float64]
    outer: NDArray[np.float64]
    chamber: NDArray[np.float64]
    stress: NDArray[np.float64]
    coil_gradient: NDArray[np.float64]
    coil_gradient_rate: NDArray[np.float64]
    nodes: NDArray[np.float64] | None = None

    def node(self, name: str) -> NDArray[np.float64]:
        """One state of the network by its name in :data:`NODE_NAMES`, shape (n,) [°C]."""
        if self.nodes is None:
            raise ConfigError("this thermal field carries no network states (nodes)")
        if name not in NODE_NAMES:
            raise ConfigError(f"unknown node {name!r}; known {', '.join(NODE_NAMES)}")
        return self.nodes[:, NODE_NAMES.index(name)]

    @property
    def gradient(self) -> NDArray[np.float64]:
        """Inner minus outer temperature of each sensor, ΔT, shape (n, 6) [°C]."""
        return self.sensor - self.outer[:, None]

    def at(self, t: ArrayLike, nodes: bool = True) -> ThermalField:
        """The field linearly interpolated at times ``t`` [s] (held beyond the grid).

        ``nodes=False`` leaves the network states out (``nodes`` None), for a caller that
        reads only the thermometer-visible signals (less than half the work)."""
        t = np.asarray(t, dtype=float)

        def interp(y: NDArray[np.float64]) -> NDArray[np.float64]:
            if y.ndim == 1:
                return np.interp(t, self.t, y)
            return np.stack([np.interp(t, self.t, y[:, k]) for k in range(y.shape[1])], axis=1)

        return replace(
            self,
            t=t,
            sensor=interp(self.sensor),
            sensor_rate=interp(self.sensor_rate),
            outer=interp(self.outer),
            chamber=interp(self.chamber),
            stress=interp(self.stress),
            coil_gradient=interp(self.coil_gradient),
            coil_gradient_rate=interp(self.coil_gradient_rate),
            nodes=None if self.nodes is None or not nodes else interp(self.nodes),
        )


def _discretise(
    A: NDArray[np.float64], B: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Exact discretisation with a first-order hold on every input.

    Returns ``Phi, G0, G1`` such that ``x[k+1] = Phi x[k] + G0 u[k] + G1 u[k+1]`` is exact
    when ``u`` is linear between the two samples.
    """
    n, m = B.shape
    M = np.zeros((n + 2 * m, n + 2 * m))
    M[:n, :n] = A * dt
    M[:n, n : n + m] = B * dt
    M[n : n + m, n + m :] = np.eye(m)
    E = scipy.linalg.expm(M)
    Phi = E[:n, :n]
    Gam1 = E[:n, n : n + m]
    Gam2 = E[:n, n + m :]
    return Phi, Gam1 - Gam2, Gam2


def simulate_field(
    profile: ChamberProfile,
    network: ThermalNetworkConfig | None = None,
    duration_s: float = 3 * 3600.0,
    dt_s: float = 1.0,
    power_on_s: float = 0.0,
    x0: NDArray[np.float64] | None = None,
    encoder: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
) -> ThermalField:
    """Integrate the thermal network through a chamber profile.

    Parameters
    ----------
    profile : ChamberProfile
        Chamber air temperature against time [°C].
    network : ThermalNetworkConfig, optional
        Network parameters; the navigation-grade defaults if omitted.
    duration_s : float [s]
        Length of the run; the grid covers ``[0, duration_s]``.
    dt_s : float [s]
        Grid step. The integration is exact for a chamber profile that is linear between
        grid points, so 1 s is ample for thermal time constants of minutes.
    power_on_s : float [s]
        Time at which the system is switched on; ``inf`` for a run without power.
    x0 : ndarray, shape (19,), optional
        Initial state. Default: unpowered equilibrium at the chamber's initial temperature
        (the unit has soaked, as in the paper's 3 h soak).
    encoder : callable, optional
        Turntable encoder angle ``φ(t)`` [rad] for times [s]: the body-fixed hot side then
        reaches each sensor according to the angle, and the torque motor heats the housing
        while the angle changes. None: the table holds at encoder zero.

    Returns
    -------
    ThermalField
        True temperatures, rates and stress states on the grid.
    """
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ConfigError(f"duration_s must be finite and > 0, got {duration_s}")
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ConfigError(f"dt_s must be finite and > 0, got {dt_s}")
    network = network or ThermalNetworkConfig()
    A, B = network.system()
    n = int(np.floor(duration_s / dt_s + 1e-9)) + 1
    t = np.arange(n) * dt_s
    if t[-1] < duration_s - 1e-9:
        t = np.append(t, duration_s)
    power = (t >= power_on_s).astype(float)
    u = np.zeros((t.size, N_INPUTS))
    u[:, 0] = profile(t)
    u[:, 1] = power
    if encoder is None:
        u[:, 3] = power
    else:
        phi = np.asarray(encoder(t), dtype=float)
        # the motor's share of each interval: the fraction of _MOTOR_SUBSTEPS sub-intervals
        # in which the angle changes (held over the interval, like the power switch)
        frac = np.linspace(0.0, 1.0, _MOTOR_SUBSTEPS + 1)
        tt = t[:-1, None] + np.diff(t)[:, None] * frac
        sub = np.asarray(encoder(tt.ravel()), dtype=float).reshape(tt.shape)
        u[:-1, 2] = (np.abs(np.diff(sub, axis=1)) > 1e-12).mean(axis=1) * power[:-1]
        u[:, 3] = power * np.cos(phi)
        u[:, 4] = power * np.sin(phi)
    x = np.empty((t.size, N_STATES))
    if x0 is None:  # soaked, switched off (or long on, if power_on_s < 0)
        x0 = network.steady_state(float(u[0, 0]), powered=power_on_s < 0)
    x[0] = x0
    Phi, G0, G1 = _discretise(A, B, dt_s)
    _integrate(x, u, t, A, B, dt_s, Phi, G0, G1)
    # exact derivative: the chamber's own rate enters only through the states (einsum, not a
    # threaded BLAS matmul: the same last bits whatever the thread count)
    xdot = np.einsum("ij,kj->ik", x, A) + np.einsum("ij,kj->ik", u, B)
    sl = slice(SENSOR0, SENSOR0 + N_SENSORS)
    coil = np.zeros((t.size, N_SENSORS))
    coil_rate = np.zeros((t.size, N_SENSORS))
    coil[:, :N_GYROS] = x[:, COIL0:N_NODES] - x[:, SENSOR0 : SENSOR0 + N_GYROS]
    coil_rate[:, :N_GYROS] = xdot[:, COIL0:N_NODES] - xdot[:, SENSOR0 : SENSOR0 + N_GYROS]
    return ThermalField(
        t=t,
        sensor=x[:, sl].copy(),
        sensor_rate=xdot[:, sl].copy(),
        outer=x[:, HOUSING].copy(),
        chamber=u[:, 0].copy(),
        stress=x[:, STRESS0:].copy(),
        coil_gradient=coil,
        coil_gradient_rate=coil_rate,
        nodes=x,
    )


def _integrate(
    x: NDArray[np.float64],
    u: NDArray[np.float64],
    t: NDArray[np.float64],
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    dt_s: float,
    Phi: NDArray[np.float64],
    G0: NDArray[np.float64],
    G1: NDArray[np.float64],
) -> None:
    """March ``x[k+1] = Phi x[k] + G0 u[k] + G1 u[k+1]`` in place (switches held)."""
    # The power and motor switches are steps: hold them (zero-order) over each interval.
    G0 = G0.copy()
    G1 = G1.copy()
    G0[:, _HELD] += G1[:, _HELD]
    G1[:, _HELD] = 0.0
    h = np.diff(t)
    regular = np.abs(h - dt_s) <= 1e-9
    # input terms of every step at once, then the recursion over the states alone
    drive = np.einsum("ij,kj->ik", u[:-1], G0) + np.einsum("ij,kj->ik", u[1:], G1)
    n_reg = int(np.argmin(regular)) if not np.all(regular) else regular.size
    _march(x, np.ascontiguousarray(Phi), drive, n_reg)
    for k in range(n_reg, t.size - 1):  # the last, shorter interval
        P, g0, g1 = _discretise(A, B, float(h[k]))
        g0[:, _HELD] += g1[:, _HELD]
        g1[:, _HELD] = 0.0
        x[k + 1] = P @ x[k] + g0 @ u[k] + g1 @ u[k + 1]


@numba.njit(cache=True, nogil=True)
def _march(
    x: NDArray[np.float64], Phi: NDArray[np.float64], drive: NDArray[np.float64], n: int
) -> None:  # pragma: no cover - compiled
    """``x[k+1] = Phi x[k] + drive[k]`` for ``k < n``, in place."""
    m = x.shape[1]
    for k in range(n):
        for i in range(m):
            acc = drive[k, i]
            for j in range(m):
                acc += Phi[i, j] * x[k, j]
            x[k + 1, i] = acc


@dataclass(frozen=True)
class ThermometerConfig:
    """Measurement model of the temperature sensors (Table 2: 0.01 °C accuracy).

    Parameters
    ----------
    noise_sd : float [°C]
        White noise of one reading.
    resolution : float [°C]
        Quantisation step of a reading; 0 for none.
    """

    noise_sd: float = 0.004
    resolution: float = 0.01

    def __post_init__(self) -> None:
        if not (np.isfinite(self.noise_sd) and self.noise_sd >= 0):
            raise ConfigError(f"thermometer: noise_sd must be >= 0 °C, got {self.noise_sd}")
        if not (np.isfinite(self.resolution) and self.resolution >= 0):
            raise ConfigError(f"thermometer: resolution must be >= 0 °C, got {self.resolution}")


def measure(
    true_c: NDArray[np.float64], thermometer: ThermometerConfig, rng: np.random.Generator
) -> NDArray[np.float64]:
    """A thermometer's readings of true temperatures: noise, then quantisation.

    Parameters
    ----------
    true_c : ndarray [°C]
        True temperatures, any shape.
    thermometer : ThermometerConfig
        Noise and resolution.
    rng : numpy.random.Generator
        Source of the noise.

    Returns
    -------
    ndarray [°C]
        Readings of the same shape.
    """
    # float32 draws are twice as fast and ample for a 0.004 °C noise
    y = rng.standard_normal(true_c.shape, dtype=np.float32).astype(np.float64)
    y *= thermometer.noise_sd
    y += true_c
    if thermometer.resolution > 0:
        y *= 1.0 / thermometer.resolution
        np.rint(y, out=y)
        y *= thermometer.resolution
    y += 0.0  # no negative zeros in the log
    return y


__all__ = [
    "NODE_NAMES",
    "ChamberProfile",
    "ThermalField",
    "ThermalNetworkConfig",
    "ThermometerConfig",
    "measure",
    "simulate_field",
]

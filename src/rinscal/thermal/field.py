"""Thermal field of a single-axis RINS in a thermal chamber: chamber profiles and a lumped network.

The IMU is a lumped thermal network (capacities joined by conductances) driven by the chamber
air and by the power dissipated once the system is switched on (electronics, FOG light
sources, accelerometer servo loops)::

    chamber air ── G_ha ── housing (outer sensor) ── G_eh ── electronics  (P_e)
                              │
                             G_bh
                              │
                          IMU block ── G_sb ── sensor j (inner sensor j)  (P_j), j = 1..6

Each node obeys ``C_k dT_k/dt = Σ_m G_km (T_m − T_k) + P_k``. On top of the temperatures the
network carries one slow *stress* state per sensor, a first-order lag of the sensor's
inside/outside gradient, ``τ_σ dσ_j/dt = (T_j − T_housing) − σ_j``: it stands for the
thermo-mechanical stress of the sensor package, which biases the sensor but which no
thermometer sees. The whole system is linear, ``dx/dt = A x + B u`` with
``u = (T_chamber, power_on)``, and is integrated exactly (matrix exponential with a
first-order hold on the chamber temperature, a zero-order hold on the power switch).

Temperatures in °C, times in s, capacities in J/K, conductances in W/K, powers in W.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from rinscal.errors import ConfigError

#: Sensor nodes in channel order (gyro x, y, z, accel x, y, z).
N_SENSORS = 6
#: Index of the housing (package surface) node in the state vector.
HOUSING = 0
#: Index of the electronics node in the state vector.
ELECTRONICS = 1
#: Index of the IMU block node in the state vector.
BLOCK = 2
#: Index of the first sensor node in the state vector.
SENSOR0 = 3
#: Index of the first stress state in the state vector.
STRESS0 = SENSOR0 + N_SENSORS
#: Number of states: 3 structural nodes, 6 sensors, 6 stress states.
N_STATES = STRESS0 + N_SENSORS


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

    With the defaults the system dissipates 15.2 W; a cold start warms the housing by about
    10 °C and the sensors by 11-13 °C with a dominant time constant of about 45 min, so most
    of the rise happens in the first one to two hours.

    Parameters
    ----------
    c_housing, c_electronics, c_block : float [J/K]
        Heat capacities of the housing, the electronics board and the IMU block.
    c_gyro, c_accel : float [J/K]
        Heat capacity of each gyro and each accelerometer.
    g_housing_air : float [W/K]
        Conductance (convection) from the housing to the chamber air.
    g_electronics_housing, g_block_housing : float [W/K]
        Conductances from the electronics and from the IMU block to the housing.
    g_gyro_block, g_accel_block : float [W/K]
        Conductance from each gyro and each accelerometer to the IMU block.
    p_electronics : float [W]
        Power of the electronics once switched on.
    p_gyro, p_accel : float [W]
        Power dissipated in each gyro (light source, FOG electronics) and each accelerometer.
    tau_stress_s : float [s]
        Time constant of the hidden package-stress state.
    sensor_coupling : tuple of 6 float [-]
        Factor on each sensor's conductance to the block (mounting differs from sensor to
        sensor, so their temperatures differ).
    """

    c_housing: float = 2200.0
    c_electronics: float = 350.0
    c_block: float = 1500.0
    c_gyro: float = 90.0
    c_accel: float = 25.0
    g_housing_air: float = 1.5
    g_electronics_housing: float = 1.2
    g_block_housing: float = 2.5
    g_gyro_block: float = 0.6
    g_accel_block: float = 0.4
    p_electronics: float = 12.0
    p_gyro: float = 1.0
    p_accel: float = 0.08
    tau_stress_s: float = 2400.0
    sensor_coupling: tuple[float, ...] = (1.0, 0.85, 1.15, 1.0, 0.8, 1.25)

    def __post_init__(self) -> None:
        coupling = np.asarray(self.sensor_coupling, dtype=float)
        if coupling.shape != (N_SENSORS,) or not np.all(np.isfinite(coupling) & (coupling > 0)):
            raise ConfigError("thermal network: sensor_coupling must be 6 finite numbers > 0")
        for f in fields(self):
            if f.name == "sensor_coupling":
                continue
            v = getattr(self, f.name)
            if not np.isfinite(v):
                raise ConfigError(f"thermal network: {f.name} must be finite, got {v}")
            if f.name.startswith("p_"):
                if v < 0:
                    raise ConfigError(f"thermal network: {f.name} must be >= 0 W, got {v}")
            elif v <= 0:
                raise ConfigError(f"thermal network: {f.name} must be > 0, got {v}")

    @property
    def total_power(self) -> float:
        """Total dissipated power once switched on [W]."""
        return self.p_electronics + 3 * self.p_gyro + 3 * self.p_accel

    def capacities(self) -> NDArray[np.float64]:
        """Heat capacities of the nine thermal nodes [J/K]."""
        return np.array(
            [self.c_housing, self.c_electronics, self.c_block]
            + [self.c_gyro] * 3
            + [self.c_accel] * 3
        )

    def powers(self) -> NDArray[np.float64]:
        """Power into each of the nine thermal nodes when switched on [W]."""
        return np.array([0.0, self.p_electronics, 0.0] + [self.p_gyro] * 3 + [self.p_accel] * 3)

    def system(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """State-space matrices of the network.

        Returns
        -------
        A : ndarray, shape (15, 15) [1/s]
            ``dx/dt = A x + B u`` for ``x = (T_housing, T_electronics, T_block, T_sensor[6],
            σ[6])``.
        B : ndarray, shape (15, 2)
            Inputs ``u = (T_chamber [°C], power switch [0 or 1])``; column 1 in [K/s].
        """
        n_nodes = SENSOR0 + N_SENSORS
        G = np.zeros((n_nodes, n_nodes))

        def link(i: int, j: int, g: float) -> None:
            G[i, j] += g
            G[j, i] += g
            G[i, i] -= g
            G[j, j] -= g

        link(ELECTRONICS, HOUSING, self.g_electronics_housing)
        link(BLOCK, HOUSING, self.g_block_housing)
        for j in range(N_SENSORS):
            g = self.g_gyro_block if j < 3 else self.g_accel_block
            link(SENSOR0 + j, BLOCK, g * self.sensor_coupling[j])
        G[HOUSING, HOUSING] -= self.g_housing_air
        cap = self.capacities()
        A = np.zeros((N_STATES, N_STATES))
        A[:n_nodes, :n_nodes] = G / cap[:, None]
        B = np.zeros((N_STATES, 2))
        B[HOUSING, 0] = self.g_housing_air / cap[HOUSING]
        B[:n_nodes, 1] = self.powers() / cap
        k = 1.0 / self.tau_stress_s
        for j in range(N_SENSORS):
            s = STRESS0 + j
            A[s, s] = -k
            A[s, SENSOR0 + j] += k
            A[s, HOUSING] -= k
        return A, B

    def steady_state(self, chamber_c: float, powered: bool = True) -> NDArray[np.float64]:
        """Equilibrium state at a constant chamber temperature [°C], powered or not.

        Returns
        -------
        ndarray, shape (15,)
            Temperatures [°C] of the nodes and the stress states [°C].
        """
        A, B = self.system()
        u = np.array([chamber_c, 1.0 if powered else 0.0])
        return np.linalg.solve(A, -B @ u)

    def time_constants(self) -> NDArray[np.float64]:
        """Time constants of the network's thermal modes, largest first [s]."""
        A, _ = self.system()
        n_nodes = SENSOR0 + N_SENSORS
        lam = np.linalg.eigvals(A[:n_nodes, :n_nodes]).real
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
    """

    t: NDArray[np.float64]
    sensor: NDArray[np.float64]
    sensor_rate: NDArray[np.float64]
    outer: NDArray[np.float64]
    chamber: NDArray[np.float64]
    stress: NDArray[np.float64]

    @property
    def gradient(self) -> NDArray[np.float64]:
        """Inner minus outer temperature of each sensor, ΔT, shape (n, 6) [°C]."""
        return self.sensor - self.outer[:, None]

    def at(self, t: ArrayLike) -> ThermalField:
        """The field linearly interpolated at times ``t`` [s] (held beyond the grid)."""
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
    x0 : ndarray, shape (15,), optional
        Initial state. Default: unpowered equilibrium at the chamber's initial temperature
        (the unit has soaked, as in the paper's 3 h soak).

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
    u = np.empty((t.size, 2))
    u[:, 0] = profile(t)
    u[:, 1] = (t >= power_on_s).astype(float)
    x = np.empty((t.size, N_STATES))
    if x0 is None:  # soaked, switched off (or long on, if power_on_s < 0)
        x0 = network.steady_state(float(u[0, 0]), powered=power_on_s < 0)
    x[0] = x0
    Phi, G0, G1 = _discretise(A, B, dt_s)
    # The power switch is a step: hold it (zero-order) over each interval.
    G_power = G0[:, 1] + G1[:, 1]
    h = np.diff(t)
    for k in range(t.size - 1):
        if abs(h[k] - dt_s) > 1e-9:  # the last, shorter interval
            Phi, G0, G1 = _discretise(A, B, float(h[k]))
            G_power = G0[:, 1] + G1[:, 1]
        x[k + 1] = Phi @ x[k] + G0[:, 0] * u[k, 0] + G1[:, 0] * u[k + 1, 0] + G_power * u[k, 1]
    # exact derivative: the chamber's own rate enters only through the states
    xdot = x @ A.T + u @ B.T
    sl = slice(SENSOR0, SENSOR0 + N_SENSORS)
    return ThermalField(
        t=t,
        sensor=x[:, sl].copy(),
        sensor_rate=xdot[:, sl].copy(),
        outer=x[:, HOUSING].copy(),
        chamber=u[:, 0].copy(),
        stress=x[:, STRESS0:].copy(),
    )


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
    "ChamberProfile",
    "ThermalField",
    "ThermalNetworkConfig",
    "ThermometerConfig",
    "measure",
    "simulate_field",
]

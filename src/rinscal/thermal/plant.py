"""The IMU thermal plant: the true thermal bias, noise and outliers of each sensor channel.

This module is the truth that calibration models are judged against. It is written from the
physics of the sensors, not shaped after any calibration model: each channel's thermal bias
depends on its own inner temperature ``T``, the rate ``dT/dt``, the inside/outside gradient
``ΔT``, their couplings, and a hidden slow package-stress state (see
:mod:`rinscal.thermal.field`) that no thermometer sees. On top come a turn-on-to-turn-on
offset, white noise, a bias random walk, and rare vibration outliers.

Everything here is in SI (rad/s for gyros, m/s² for accelerometers) and resolved in the
rotating IMU frame ``r``; the configuration file uses deg/h and µg (see
``rinscal/data/navigation_grade.toml``).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, field, fields, replace
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numba
import numpy as np
from numpy.typing import NDArray

from rinscal import units
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS
from rinscal.thermal.field import (
    BLOCK,
    COIL0,
    ELECTRONICS,
    N_GYROS,
    SENSOR0,
    STRESS0,
    ThermalField,
    ThermalNetworkConfig,
    ThermometerConfig,
)
from rinscal.thermal.presets import DEFAULT_PRESET, PRESETS

#: Engineering unit of each channel in configuration files and physical-unit logs.
ENGINEERING_UNITS = ("deg/h",) * 3 + ("ug",) * 3
#: Factor from the engineering unit of each channel to SI [(rad/s)/(deg/h) or (m/s²)/µg].
ENG_TO_SI = np.array([units.DPH_TO_RPS] * 3 + [units.UG_TO_MPS2] * 3)


def _finite(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(f"{name} must be a finite number, got {value!r}")
    return v


def _nonneg(name: str, value: float) -> float:
    v = _finite(name, value)
    if v < 0:
        raise ConfigError(f"{name} must be >= 0, got {value!r}")
    return v


def _poly(coefs: tuple[float, ...], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Σ_k coefs[k]·x^(k+1) (no constant term), Horner form."""
    out = np.zeros_like(x)
    for c in reversed(coefs):
        out = (out + c) * x
    return out


def _poly_slope(coefs: tuple[float, ...], x: float) -> float:
    """Derivative of :func:`_poly` at the scalar ``x``."""
    return float(sum((k + 1) * c * x**k for k, c in enumerate(coefs)))


def _poly_window(
    coefs: tuple[float, ...],
    x: NDArray[np.float64],
    window: tuple[float, float] | None,
) -> NDArray[np.float64]:
    """:func:`_poly` inside ``window``, continued by its tangent outside (C¹), so that a
    polynomial fitted over a limited range does not explode beyond it."""
    if window is None or not coefs:
        return _poly(coefs, x)
    lo, hi = window
    xc = np.clip(x, lo, hi)
    out = _poly(coefs, xc)
    below, above = x < lo, x > hi
    if np.any(below):
        out[below] += _poly_slope(coefs, lo) * (x[below] - lo)
    if np.any(above):
        out[above] += _poly_slope(coefs, hi) * (x[above] - hi)
    return out


@dataclass(frozen=True)
class ChannelThermal:
    """Thermal-error coefficients of one channel, in engineering units (deg/h or µg).

    Bias: ``b = b0 + Σ t[k]·x^(k+1) + Σ rate[k]·r^(k+1) + Σ grad[k]·d^(k+1) + t_grad·x·d
    + t_rate·x·r + stress·s + shupe·ġ + h`` with ``x = T − t_ref`` [°C], ``r = dT/dt``
    [°C/min], ``d = ΔT`` [°C], ``s`` the hidden stress state [°C], ``ġ`` the rate of the
    radial gradient across a gyro's fibre coil [°C/min] (Shupe effect) and ``h`` the
    hysteresis of a quartz accelerometer (a play operator of half-width
    ``hysteresis_play_c`` on ``T``, ``h = ±hysteresis/2`` on a heating / cooling leg).
    Signal errors: ``(T − t_cal)·(scale_factor_ppm_per_c·1e-6·s_j + Σ_k
    misalignment_arcsec_per_c[k]·(π/648000)·s_k)`` for the true signal ``s`` (rate or
    specific force) along the ``r`` axes, ``t_cal`` the temperature of the unit's
    scale/axis calibration.

    Parameters
    ----------
    b0 : float [unit]
        Thermal bias at the reference temperature, at rest, without gradient.
    t : tuple of 1-4 float [unit/°C^k]
        Temperature polynomial.
    rate : tuple of 0-4 float [unit/(°C/min)^k]
        Temperature-rate polynomial (servo drift in accelerometers; the rate part of a
        FOG's thermal drift).
    grad : tuple of 0-4 float [unit/°C^k]
        Inside/outside gradient polynomial.
    t_grad : float [unit/°C²]
        Coupling of temperature and gradient.
    t_rate : float [unit/(°C·°C/min)]
        Coupling of temperature and rate.
    stress : float [unit/°C]
        Sensitivity to the hidden package-stress state.
    rate_range : (float, float) or None [°C/min]
        Range over which the rate polynomial holds; continued by its tangent outside.
    grad_range : (float, float) or None [°C]
        Range over which the gradient polynomial holds; continued by its tangent outside.
    shupe : float [unit/(°C/min)]
        Shupe bias per rate of the coil's radial gradient (gyros; outer minus hub).
    hysteresis : float [unit]
        Width of the thermal hysteresis loop (quartz accelerometers): heating and cooling
        legs differ by this much at the same temperature.
    hysteresis_play_c : float [°C]
        Half-width ``w`` of the play: a temperature reversal of ``2w`` takes the output from
        one leg to the other.
    scale_factor_ppm_per_c : float [ppm/°C]
        Scale-factor change with temperature.
    misalignment_arcsec_per_c : tuple of 3 float [arcsec/°C]
        Change with temperature of this axis's tilt towards the IMU axes x, y, z of the
        ``r`` frame (its own entry must be 0: that is the scale factor; checked by
        :class:`ImuConfig`).
    lever_arm_m : tuple of 3 float [m]
        Lever arm of an accelerometer's proof mass from the turntable axis, in ``r``, that
        the navigation computer's size-effect compensation leaves (the error of its lever-arm
        calibration; the whole arm for a computer that does not compensate): it senses
        ω×(ω×ρ) + ω̇×ρ. 0 for gyros.
    """

    b0: float = 0.0
    t: tuple[float, ...] = (0.0, 0.0, 0.0)
    rate: tuple[float, ...] = (0.0, 0.0)
    grad: tuple[float, ...] = (0.0, 0.0)
    t_grad: float = 0.0
    t_rate: float = 0.0
    stress: float = 0.0
    rate_range: tuple[float, float] | None = None
    grad_range: tuple[float, float] | None = None
    shupe: float = 0.0
    hysteresis: float = 0.0
    hysteresis_play_c: float = 1.0
    scale_factor_ppm_per_c: float = 0.0
    misalignment_arcsec_per_c: tuple[float, float, float] = (0.0, 0.0, 0.0)
    lever_arm_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            vals = () if v is None else v if isinstance(v, tuple) else (v,)
            for x in vals:
                _finite(f"thermal.{f.name}", x)
        for name, lo in (("t", 1), ("rate", 0), ("grad", 0)):
            if not lo <= len(getattr(self, name)) <= 4:
                raise ConfigError(f"thermal.{name} must have {lo} to 4 coefficients")
        for name in ("rate_range", "grad_range"):
            w = getattr(self, name)
            if w is not None and (len(w) != 2 or not w[0] < w[1]):
                raise ConfigError(f"thermal.{name} must be [low, high] with low < high")
        for name in ("misalignment_arcsec_per_c", "lever_arm_m"):
            if len(getattr(self, name)) != 3:
                raise ConfigError(f"thermal.{name} must have 3 values (x, y, z)")
        if self.hysteresis_play_c <= 0:
            raise ConfigError("thermal.hysteresis_play_c must be > 0 °C")
        if self.hysteresis < 0:
            raise ConfigError("thermal.hysteresis (the loop width) must be >= 0")

    def evaluate(
        self,
        x: NDArray[np.float64],
        r: NDArray[np.float64],
        d: NDArray[np.float64],
        s: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Thermal bias [unit] for temperature offset ``x`` [°C], rate ``r`` [°C/min],
        gradient ``d`` [°C] and stress ``s`` [°C] (Shupe and hysteresis excluded)."""
        return (
            self.b0
            + _poly(self.t, x)
            + _poly_window(self.rate, r, self.rate_range)
            + _poly_window(self.grad, d, self.grad_range)
            + self.t_grad * x * d
            + self.t_rate * x * r
            + self.stress * s
        )


#: Keys of ``[thermal.<channel>]`` that make up the polynomial law's bias. Under the
#: mechanistic law they are replaced by ``[mechanistic.<channel>]``; the other keys of
#: ``[thermal.<channel>]`` (Shupe, hysteresis, signal errors, lever arm) hold under both laws.
POLYNOMIAL_KEYS = (
    "b0",
    "t",
    "rate",
    "grad",
    "t_grad",
    "t_rate",
    "stress",
    "rate_range",
    "grad_range",
)
#: The thermal laws an :class:`ImuConfig` can use (``[imu] thermal_law``).
THERMAL_LAWS = ("polynomial", "mechanistic")


@dataclass(frozen=True)
class MechanisticThermal:
    """Thermal bias of one channel driven by the network's own states (engineering units).

    The bias is a sum of physically shaped terms, each driven by a node of the thermal
    network (:data:`rinscal.thermal.field.NODE_NAMES`), several of them nodes that no
    thermometer sees::

        b = b0
          + k_t · s_t · tanh((T_j − t_ref) / s_t)             own temperature, saturating
          + k_mount · y + k_mount2 · y²,  y = T_block − t_mount_c   mount, zero at assembly
          + k_elec · (L_τe[T_electronics] − t_ref)            electronics box, lagged
          + k_path · (T_electronics − T_block)                gradient along the mount path
          + k_coil · (T_coil − T_hub)                         coil's radial gradient (gyros)
          + k_stress · σ_j                                    package stress (τ_σ lag)

    ``T_j`` is the sensor's own node (its inner thermometer's), ``L_τ`` a first-order lag of
    time constant ``τ`` (:func:`first_order_lag`, from equilibrium at the run's first
    sample) and ``t_ref`` the configuration's ``t_ref_c``. Shupe, hysteresis and the signal
    errors come from the channel's ``[thermal.<channel>]`` table as under the polynomial law.
    See ``docs/plant.md`` ("The mechanistic law") for the physical reading of each term.

    Parameters
    ----------
    b0 : float [unit]
        Bias with every driving term at zero.
    k_t : float [unit/°C]
        Slope of the own-temperature term at ``t_ref``.
    t_sat_c : float [°C]
        Saturation scale of the own-temperature term (> 0): linear within a few degrees of
        ``t_ref``, bounded by ``±k_t·t_sat_c`` far from it.
    k_mount, k_mount2 : float [unit/°C, unit/°C²]
        Linear and quadratic sensitivity to the IMU block (the sensor's mount) relative to
        ``t_mount_c``; the linear term changes sign across ``t_mount_c``.
    t_mount_c : float [°C]
        Temperature at which the mount is stress-free (the bonding/assembly temperature).
    k_elec : float [unit/°C]
        Sensitivity to the lagged electronics-box temperature.
    tau_elec_s : float [s]
        Time constant of that lag (> 0): the readout's components behind the box node.
    k_path : float [unit/°C]
        Sensitivity to the gradient from the electronics box to the IMU block.
    k_coil : float [unit/°C]
        Sensitivity to the static radial gradient of a gyro's fibre coil (outer layers minus
        hub); must be 0 for an accelerometer.
    k_stress : float [unit/°C]
        Sensitivity to the hidden package-stress state (network ``tau_stress_s``).
    """

    b0: float = 0.0
    k_t: float = 0.0
    t_sat_c: float = 30.0
    k_mount: float = 0.0
    k_mount2: float = 0.0
    t_mount_c: float = 20.0
    k_elec: float = 0.0
    tau_elec_s: float = 600.0
    k_path: float = 0.0
    k_coil: float = 0.0
    k_stress: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            _finite(f"mechanistic.{f.name}", getattr(self, f.name))
        if self.t_sat_c <= 0:
            raise ConfigError(f"mechanistic.t_sat_c must be > 0 °C, got {self.t_sat_c}")
        if self.tau_elec_s <= 0:
            raise ConfigError(f"mechanistic.tau_elec_s must be > 0 s, got {self.tau_elec_s}")

    def terms(self, field: ThermalField, j: int, t_ref_c: float) -> dict[str, NDArray[np.float64]]:
        """Each term of the bias of channel ``j`` [unit] through ``field`` (in time order,
        the whole run: the electronics lag starts at equilibrium with its first sample).

        Returns
        -------
        dict of str to ndarray, shape (n,)
            ``b0, temperature, mount, electronics, path, coil, stress``; their sum is
            :meth:`evaluate`.
        """
        if field.nodes is None:
            raise ConfigError(
                "the mechanistic thermal law needs the network's states (ThermalField.nodes, "
                "set by simulate_field)"
            )
        x = field.nodes
        n = x.shape[0]
        own = x[:, SENSOR0 + j]
        block = x[:, BLOCK]
        elec = x[:, ELECTRONICS]
        y = block - self.t_mount_c
        out = {
            "b0": np.full(n, self.b0),
            "temperature": self.k_t * self.t_sat_c * np.tanh((own - t_ref_c) / self.t_sat_c),
            "mount": self.k_mount * y + self.k_mount2 * y * y,
            "electronics": np.zeros(n),
            "path": self.k_path * (elec - block),
            "coil": np.zeros(n),
            "stress": self.k_stress * x[:, STRESS0 + j],
        }
        if self.k_elec:
            lag = first_order_lag(field.t, elec, self.tau_elec_s)
            out["electronics"] = self.k_elec * (lag - t_ref_c)
        if j < N_GYROS and self.k_coil:
            out["coil"] = self.k_coil * (x[:, COIL0 + j] - own)
        return out

    def evaluate(self, field: ThermalField, j: int, t_ref_c: float) -> NDArray[np.float64]:
        """Thermal bias [unit] of channel ``j`` through ``field`` (Shupe, hysteresis and
        signal errors excluded); see :meth:`terms`."""
        terms = self.terms(field, j, t_ref_c)
        out = terms.pop("b0")
        for v in terms.values():
            out = out + v
        return out


def first_order_lag(
    t: NDArray[np.float64], u: NDArray[np.float64], tau_s: float
) -> NDArray[np.float64]:
    """First-order lag ``τ dy/dt = u − y`` of a signal sampled at times ``t``.

    Exact for ``u`` linear between samples (any spacing), starting at equilibrium with the
    first sample (``y[0] = u[0]``).

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Sample times, increasing.
    u : ndarray, shape (n,)
        Input.
    tau_s : float [s]
        Time constant (> 0).

    Returns
    -------
    ndarray, shape (n,)
    """
    if not (math.isfinite(tau_s) and tau_s > 0):
        raise ConfigError(f"lag time constant must be > 0 s, got {tau_s}")
    return _lag(
        np.ascontiguousarray(t, dtype=np.float64),
        np.ascontiguousarray(u, dtype=np.float64),
        float(tau_s),
    )


@numba.njit(cache=True, nogil=True)
def _lag(t: NDArray[np.float64], u: NDArray[np.float64], tau: float) -> NDArray[np.float64]:
    out = np.empty(u.shape[0])  # pragma: no cover - compiled
    if u.shape[0] == 0:
        return out
    y = u[0]
    out[0] = y
    for k in range(u.shape[0] - 1):
        h = t[k + 1] - t[k]
        a = math.exp(-h / tau)
        # u linear over the step: y → a·y + (1 − a)·u[k] + (u[k+1] − u[k])·(1 − τ(1 − a)/h)
        y = a * y + (1.0 - a) * u[k] + (u[k + 1] - u[k]) * (1.0 - tau * (1.0 - a) / h)
        out[k + 1] = y
    return out


@dataclass(frozen=True)
class EffectsConfig:
    """Which error effects beyond the polynomial bias the plant applies (all on by default).

    Parameters
    ----------
    shupe : bool
        FOG Shupe bias from the rate of the coil's radial gradient.
    hysteresis : bool
        Quartz accelerometer thermal hysteresis with persistent memory.
    scale_factor : bool
        Scale factor against temperature.
    misalignment : bool
        Non-orthogonality against temperature.
    lever_arm : bool
        The accelerometers' lever arm from the turntable axis (size effect), navigation.
    rotation_heat : bool
        Heat fixed in the body reaching the turning sensors by encoder angle, and the torque
        motor's heat while the table moves.
    """

    shupe: bool = True
    hysteresis: bool = True
    scale_factor: bool = True
    misalignment: bool = True
    lever_arm: bool = True
    rotation_heat: bool = True

    def __post_init__(self) -> None:
        for f in fields(self):
            if not isinstance(getattr(self, f.name), bool):
                raise ConfigError(f"effects.{f.name} must be true or false")


@dataclass(frozen=True)
class NoiseConfig:
    """Stochastic errors of the sensors (engineering units, as on a data sheet).

    Parameters
    ----------
    gyro_arw_deg_rth : float [deg/√h]
        Gyro angle random walk.
    gyro_bias_rw_dph_rth : float [deg/h/√h]
        Gyro bias random walk.
    gyro_turn_on_dph : float [deg/h]
        Gyro turn-on-to-turn-on bias repeatability, 1σ.
    gyro_outlier_dph : float [deg/h]
        Size (1σ) of a gyro vibration outlier.
    accel_vrw_ug_rthz : float [µg/√Hz]
        Accelerometer white-noise density.
    accel_bias_rw_ug_rth : float [µg/√h]
        Accelerometer bias random walk.
    accel_turn_on_ug : float [µg]
        Accelerometer turn-on-to-turn-on repeatability, 1σ.
    accel_outlier_ug : float [µg]
        Size (1σ) of an accelerometer vibration outlier.
    outlier_rate_hz : float [1/s]
        Mean rate of single-sample outliers per channel (torque-motor vibration).
    """

    gyro_arw_deg_rth: float = 0.001
    gyro_bias_rw_dph_rth: float = 0.0003
    gyro_turn_on_dph: float = 0.003
    gyro_outlier_dph: float = 5.0
    accel_vrw_ug_rthz: float = 10.0
    accel_bias_rw_ug_rth: float = 0.5
    accel_turn_on_ug: float = 15.0
    accel_outlier_ug: float = 1000.0
    outlier_rate_hz: float = 0.002

    def __post_init__(self) -> None:
        for f in fields(self):
            _nonneg(f"noise.{f.name}", getattr(self, f.name))

    def white_density_si(self) -> NDArray[np.float64]:
        """White-noise density per channel [rad/s/√Hz = rad/√s, m/s²/√Hz]."""
        g = self.gyro_arw_deg_rth * units.DPRH_TO_RPRS
        a = self.accel_vrw_ug_rthz * units.UG_TO_MPS2
        return np.array([g] * 3 + [a] * 3)

    def bias_rw_si(self) -> NDArray[np.float64]:
        """Bias random-walk density per channel [rad/s/√s, m/s²/√s]."""
        g = self.gyro_bias_rw_dph_rth * units.DPH_TO_RPS / math.sqrt(units.HOUR_TO_S)
        a = self.accel_bias_rw_ug_rth * units.UG_TO_MPS2 / math.sqrt(units.HOUR_TO_S)
        return np.array([g] * 3 + [a] * 3)

    def turn_on_sd_si(self) -> NDArray[np.float64]:
        """Turn-on repeatability (1σ) per channel [rad/s, m/s²]."""
        g = self.gyro_turn_on_dph * units.DPH_TO_RPS
        a = self.accel_turn_on_ug * units.UG_TO_MPS2
        return np.array([g] * 3 + [a] * 3)

    def outlier_sd_si(self) -> NDArray[np.float64]:
        """Outlier size (1σ) per channel [rad/s, m/s²]."""
        g = self.gyro_outlier_dph * units.DPH_TO_RPS
        a = self.accel_outlier_ug * units.UG_TO_MPS2
        return np.array([g] * 3 + [a] * 3)


@dataclass(frozen=True)
class OutputConfig:
    """How the IMU reports: physical units or pulses.

    Parameters
    ----------
    mode : {"physical", "pulses"}
        ``physical``: mean rate per sample in deg/h and µg; ``pulses``: integer counts per
        sample from an accumulator with carried remainder (FOG and I/F converter style).
    gyro_pulse_arcsec : float [arcsec]
        Angle weight of one gyro pulse.
    accel_pulse_mps : float [m/s]
        Velocity weight of one accelerometer pulse.
    """

    mode: Literal["physical", "pulses"] = "physical"
    gyro_pulse_arcsec: float = 0.001
    accel_pulse_mps: float = 1e-6

    def __post_init__(self) -> None:
        if self.mode not in ("physical", "pulses"):
            raise ConfigError(f"output.mode must be 'physical' or 'pulses', got {self.mode!r}")
        for name in ("gyro_pulse_arcsec", "accel_pulse_mps"):
            if _finite(f"output.{name}", getattr(self, name)) <= 0:
                raise ConfigError(f"output.{name} must be > 0")

    def pulse_weight_si(self) -> NDArray[np.float64]:
        """Increment weight of one pulse per channel [rad, m/s]."""
        return np.array(
            [self.gyro_pulse_arcsec * units.ARCSEC_TO_RAD] * 3 + [self.accel_pulse_mps] * 3
        )


@dataclass(frozen=True)
class ImuConfig:
    """Everything that defines a simulated IMU on its turntable in a chamber.

    Parameters
    ----------
    name : str
        Free text.
    latitude_deg : float [deg]
        Latitude of the turntable (Earth rate and gravity in the static outputs).
    heading_deg : float [deg]
        Azimuth of the IMU y axis at encoder zero, clockwise from north.
    altitude_m : float [m]
        Height above the ellipsoid.
    t_ref_c : float [°C]
        Reference temperature of the thermal-bias polynomial.
    t_cal_c : float [°C]
        Temperature at which scale factors and axes were calibrated: their thermal changes
        are proportional to ``T − t_cal_c``.
    thermal : tuple of 6 ChannelThermal
        Thermal-bias coefficients per channel (gyro x..z in deg/h, accel x..z in µg).
    noise : NoiseConfig
        Stochastic errors.
    output : OutputConfig
        Units of the log.
    network : ThermalNetworkConfig
        The lumped thermal network.
    thermometer : ThermometerConfig
        The temperature sensors.
    effects : EffectsConfig
        Which effects beyond the polynomial bias are applied.
    thermal_law : {"polynomial", "mechanistic"}
        The law of the thermal bias: the polynomial of each ``thermal`` entry, or the
        network-driven terms of each ``mechanistic`` entry (Shupe, hysteresis and signal
        errors from ``thermal`` under both).
    mechanistic : tuple of 6 MechanisticThermal or None
        The mechanistic law's coefficients per channel; required with that law (and then
        the polynomial keys of ``thermal`` must be left at zero), refused with the other.
    """

    name: str = "custom"
    latitude_deg: float = 32.06
    heading_deg: float = 0.0
    altitude_m: float = 10.0
    t_ref_c: float = 20.0
    t_cal_c: float = 20.0
    thermal: tuple[ChannelThermal, ...] = field(
        default_factory=lambda: tuple(ChannelThermal() for _ in CHANNELS)
    )
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    network: ThermalNetworkConfig = field(default_factory=ThermalNetworkConfig)
    thermometer: ThermometerConfig = field(default_factory=ThermometerConfig)
    effects: EffectsConfig = field(default_factory=EffectsConfig)
    thermal_law: str = "polynomial"
    mechanistic: tuple[MechanisticThermal, ...] | None = None

    def __post_init__(self) -> None:
        lat = _finite("imu.latitude_deg", self.latitude_deg)
        if abs(lat) > 89.0:
            raise ConfigError(f"imu.latitude_deg must be within ±89°, got {lat}")
        _finite("imu.heading_deg", self.heading_deg)
        _finite("imu.altitude_m", self.altitude_m)
        _finite("imu.t_ref_c", self.t_ref_c)
        _finite("imu.t_cal_c", self.t_cal_c)
        if len(self.thermal) != len(CHANNELS):
            raise ConfigError(f"thermal: need one table per channel {CHANNELS}")
        for j, (ch, coef) in enumerate(zip(CHANNELS, self.thermal, strict=True)):
            own = coef.misalignment_arcsec_per_c[j % 3]
            if own != 0.0:
                raise ConfigError(
                    f"[thermal.{ch}] misalignment_arcsec_per_c[{j % 3}] must be 0 (the tilt "
                    f"of an axis towards itself is its scale factor), got {own}"
                )
            if j < 3 and any(coef.lever_arm_m):
                raise ConfigError(f"[thermal.{ch}] lever_arm_m: a gyro has no size effect")
        if self.thermal_law not in THERMAL_LAWS:
            raise ConfigError(
                f"imu.thermal_law must be one of {', '.join(THERMAL_LAWS)}, "
                f"got {self.thermal_law!r}"
            )
        if self.thermal_law == "polynomial":
            if self.mechanistic is not None:
                raise ConfigError(
                    "[mechanistic] coefficients given but imu.thermal_law = 'polynomial' "
                    "(they would be ignored): set thermal_law = 'mechanistic' or drop them"
                )
            return
        if self.mechanistic is None or len(self.mechanistic) != len(CHANNELS):
            raise ConfigError(
                f"imu.thermal_law = 'mechanistic' needs one [mechanistic.<channel>] table per "
                f"channel {CHANNELS}"
            )
        blank = ChannelThermal()
        for j, (ch, coef, mech) in enumerate(
            zip(CHANNELS, self.thermal, self.mechanistic, strict=True)
        ):
            if not isinstance(mech, MechanisticThermal):
                raise ConfigError(f"mechanistic[{j}] must be a MechanisticThermal")
            if j >= N_GYROS and mech.k_coil != 0.0:
                raise ConfigError(f"[mechanistic.{ch}] k_coil: an accelerometer has no coil")
            used = [k for k in POLYNOMIAL_KEYS if getattr(coef, k) != getattr(blank, k)]
            used = [k for k in used if k not in ("t", "rate", "grad") or any(getattr(coef, k))]
            if used:
                raise ConfigError(
                    f"[thermal.{ch}] polynomial key(s) {used} set but imu.thermal_law = "
                    "'mechanistic' (they would be ignored): the bias is [mechanistic."
                    f"{ch}]'s"
                )

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<dict>") -> ImuConfig:
        """Build and validate a configuration from the nested TOML layout.

        Every section must be present (``[imu]``, ``[output]``, ``[noise]``,
        ``[thermometer]``, ``[network]``, ``[effects]`` and ``[thermal.<channel>]`` for each
        of the six channels): a missing one is an error naming it, never silent zeros.
        Unknown sections or keys raise :class:`ConfigError` naming them and ``source``.
        """
        known = {"imu", "output", "noise", "thermometer", "network", "effects", "thermal"}
        known_opt = {"mechanistic"}
        extra = set(data) - known - known_opt
        if extra:
            raise ConfigError(
                f"{source}: unknown section(s) {sorted(extra)}; known {sorted(known | known_opt)}"
            )
        thermal_sec = data.get("thermal", {})
        if not isinstance(thermal_sec, dict):
            raise ConfigError(f"{source}: [thermal] must be a table")

        def section(name: str, klass: type, allowed: set[str] | None = None) -> dict[str, Any]:
            sec = data.get(name)
            if not isinstance(sec, dict):
                raise ConfigError(f"{source}: [{name}] must be a table")
            names = allowed or {f.name for f in fields(klass)}
            bad = set(sec) - names
            if bad:
                raise ConfigError(f"{source}: unknown key(s) {sorted(bad)} in [{name}]")
            return {k: tuple(v) if isinstance(v, list) else v for k, v in sec.items()}

        imu_keys = {
            "name",
            "latitude_deg",
            "heading_deg",
            "altitude_m",
            "t_ref_c",
            "t_cal_c",
            "thermal_law",
        }
        klasses = {
            "noise": NoiseConfig,
            "output": OutputConfig,
            "network": ThermalNetworkConfig,
            "thermometer": ThermometerConfig,
            "effects": EffectsConfig,
        }
        # unknown keys first (a typo is the likelier mistake), then missing sections
        for name, klass in klasses.items():
            if name in data:
                section(name, klass)
        imu = section("imu", cls, imu_keys) if "imu" in data else {}
        bad = set(thermal_sec) - set(CHANNELS)
        if bad:
            raise ConfigError(f"{source}: unknown channel(s) {sorted(bad)} in [thermal]")
        missing = [f"[{k}]" for k in sorted(known - {"thermal"}) if k not in data]
        missing += [f"[thermal.{ch}]" for ch in CHANNELS if ch not in thermal_sec]
        if missing:
            raise ConfigError(f"{source}: missing section(s) {', '.join(missing)}")
        law = imu.get("thermal_law", "polynomial")
        if law not in THERMAL_LAWS:
            raise ConfigError(
                f"{source}: imu.thermal_law must be one of {', '.join(THERMAL_LAWS)}, got {law!r}"
            )
        mechanistic = _mechanistic_section(data, law, source)
        thermal = []
        required = {"b0", "t"} if law == "polynomial" else set()
        for ch in CHANNELS:
            sec = thermal_sec[ch]
            if not isinstance(sec, dict):
                raise ConfigError(f"{source}: [thermal.{ch}] must be a table")
            bad = set(sec) - {f.name for f in fields(ChannelThermal)}
            if bad:
                raise ConfigError(f"{source}: unknown key(s) {sorted(bad)} in [thermal.{ch}]")
            poly = sorted(set(sec) & set(POLYNOMIAL_KEYS))
            if law == "mechanistic" and poly:
                raise ConfigError(
                    f"{source}: polynomial key(s) {poly} in [thermal.{ch}] but imu.thermal_law "
                    f"= 'mechanistic': the bias is [mechanistic.{ch}]'s; [thermal.{ch}] keeps "
                    "only shupe, hysteresis, signal errors and lever arm"
                )
            lacking = required - set(sec)
            if lacking:
                raise ConfigError(f"{source}: missing key(s) {sorted(lacking)} in [thermal.{ch}]")
            kw = {k: tuple(v) if isinstance(v, list) else v for k, v in sec.items()}
            try:
                thermal.append(ChannelThermal(**kw))
            except (TypeError, ConfigError) as e:
                raise ConfigError(f"{source}: [thermal.{ch}] {e}") from None
        try:
            return cls(
                thermal=tuple(thermal),
                noise=NoiseConfig(**section("noise", NoiseConfig)),
                output=OutputConfig(**section("output", OutputConfig)),
                network=ThermalNetworkConfig(**section("network", ThermalNetworkConfig)),
                thermometer=ThermometerConfig(**section("thermometer", ThermometerConfig)),
                effects=EffectsConfig(**section("effects", EffectsConfig)),
                mechanistic=mechanistic,
                **imu,
            )
        except (TypeError, ConfigError) as e:
            raise ConfigError(f"{source}: {e}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> ImuConfig:
        """Read a configuration from a TOML file (layout of ``navigation_grade.toml``)."""
        path = Path(path)
        try:
            with path.open("rb") as fh:
                data = tomllib.load(fh)
        except FileNotFoundError:
            raise ConfigError(f"{path}: IMU configuration file not found") from None
        except tomllib.TOMLDecodeError as e:
            raise ConfigError(f"{path}: not valid TOML: {e}") from None
        return cls.from_dict(data, source=str(path))

    @classmethod
    def preset(cls, name: str) -> ImuConfig:
        """A built-in preset by name (see :data:`PRESETS`)."""
        if name not in PRESETS:
            raise ConfigError(f"unknown IMU preset {name!r}; choose one of {', '.join(PRESETS)}")
        text = resources.files("rinscal.data").joinpath(f"{name}.toml").read_text()
        return cls.from_dict(tomllib.loads(text), source=f"preset {name} ({name}.toml)")

    @classmethod
    def navigation_grade(cls) -> ImuConfig:
        """The built-in preset: a navigation-grade FOG + quartz RINS (our own unit)."""
        return cls.preset("navigation_grade")

    @classmethod
    def paper(cls) -> ImuConfig:
        """The built-in preset of the paper's own IMU (Tables 4 and 6 converted)."""
        return cls.preset("paper")

    def to_dict(self) -> dict[str, Any]:
        """The nested TOML layout (round-trips through :meth:`from_dict`)."""
        drop = POLYNOMIAL_KEYS if self.thermal_law == "mechanistic" else ()
        out: dict[str, Any] = {
            "imu": {
                "name": self.name,
                "latitude_deg": self.latitude_deg,
                "heading_deg": self.heading_deg,
                "altitude_m": self.altitude_m,
                "t_ref_c": self.t_ref_c,
                "t_cal_c": self.t_cal_c,
                "thermal_law": self.thermal_law,
            },
            "output": asdict(self.output),
            "noise": asdict(self.noise),
            "thermometer": asdict(self.thermometer),
            "network": _toml_table(asdict(self.network)),
            "effects": asdict(self.effects),
            "thermal": {
                ch: _toml_table(asdict(c), drop=drop)
                for ch, c in zip(CHANNELS, self.thermal, strict=True)
            },
        }
        if self.mechanistic is not None:
            out["mechanistic"] = {
                ch: {k: v for k, v in asdict(m).items() if j < N_GYROS or k != "k_coil"}
                for j, (ch, m) in enumerate(zip(CHANNELS, self.mechanistic, strict=True))
            }
        return out

    # ------------------------------------------------------------------ derived
    @property
    def latitude(self) -> float:
        """Latitude [rad]."""
        return self.latitude_deg * units.DEG_TO_RAD

    @property
    def heading(self) -> float:
        """Heading of the IMU y axis at encoder zero [rad]."""
        return self.heading_deg * units.DEG_TO_RAD

    def thermal_network(self) -> ThermalNetworkConfig:
        """The network as simulated: without the body-fixed hot side if that effect is off."""
        if self.effects.rotation_heat:
            return self.network
        return replace(self.network, rotation_heat_c=0.0, p_motor=0.0)

    def log_units(self) -> tuple[str, ...]:
        """Unit of each channel in a log written with this configuration."""
        return ("pulse",) * 6 if self.output.mode == "pulses" else ENGINEERING_UNITS


def load_imu(spec: str | Path) -> ImuConfig:
    """An IMU configuration from a preset name (:data:`PRESETS`) or a TOML file path."""
    if isinstance(spec, str) and spec in PRESETS:
        return ImuConfig.preset(spec)
    path = Path(spec)
    if path.suffix.lower() != ".toml" and not path.exists():
        raise ConfigError(
            f"IMU {str(spec)!r} is neither a preset ({', '.join(PRESETS)}) nor a TOML file"
        )
    return ImuConfig.from_toml(path)


def _toml_table(d: dict[str, Any], drop: tuple[str, ...] = ()) -> dict[str, Any]:
    """A dataclass dict as TOML can hold it: tuples as lists, None and ``drop`` left out."""
    return {
        k: list(v) if isinstance(v, tuple) else v
        for k, v in d.items()
        if v is not None and k not in drop
    }


def _mechanistic_section(
    data: dict[str, Any], law: str, source: str
) -> tuple[MechanisticThermal, ...] | None:
    """The ``[mechanistic.<channel>]`` tables: all six with every coefficient (``k_coil``
    for gyros only) under the mechanistic law, none under the polynomial one."""
    sec = data.get("mechanistic")
    if law == "polynomial":
        if sec is not None:
            raise ConfigError(
                f"{source}: [mechanistic] given but imu.thermal_law is 'polynomial' (it would "
                'be ignored): set thermal_law = "mechanistic" in [imu] or drop the section'
            )
        return None
    if not isinstance(sec, dict):
        raise ConfigError(
            f"{source}: imu.thermal_law = 'mechanistic' needs the section(s) "
            + ", ".join(f"[mechanistic.{ch}]" for ch in CHANNELS)
        )
    bad = set(sec) - set(CHANNELS)
    if bad:
        raise ConfigError(f"{source}: unknown channel(s) {sorted(bad)} in [mechanistic]")
    missing = [f"[mechanistic.{ch}]" for ch in CHANNELS if ch not in sec]
    if missing:
        raise ConfigError(f"{source}: missing section(s) {', '.join(missing)}")
    names = [f.name for f in fields(MechanisticThermal)]
    out = []
    for j, ch in enumerate(CHANNELS):
        tab = sec[ch]
        if not isinstance(tab, dict):
            raise ConfigError(f"{source}: [mechanistic.{ch}] must be a table")
        allowed = set(names) if j < N_GYROS else set(names) - {"k_coil"}
        bad = set(tab) - allowed
        if bad:
            why = " (an accelerometer has no coil)" if "k_coil" in bad and j >= N_GYROS else ""
            raise ConfigError(f"{source}: unknown key(s) {sorted(bad)} in [mechanistic.{ch}]{why}")
        lacking = sorted(allowed - set(tab), key=names.index)
        if lacking:
            raise ConfigError(f"{source}: missing key(s) {lacking} in [mechanistic.{ch}]")
        try:
            out.append(MechanisticThermal(**tab))
        except (TypeError, ConfigError) as e:
            raise ConfigError(f"{source}: [mechanistic.{ch}] {e}") from None
    return tuple(out)


# --------------------------------------------------------------------------- the plant
#: Temperature a unit is kept at between uses [°C]: the hysteresis memory of a unit that
#: comes from the lab starts there.
STORAGE_C = 20.0


def play_operator(
    temp: NDArray[np.float64], half_width: float, start: float
) -> NDArray[np.float64]:
    """The play (backlash) operator: an output that follows ``temp`` only once it is more
    than ``half_width`` away, the elementary hysteresis with memory.

    Parameters
    ----------
    temp : ndarray, shape (n,) [°C]
        Input, in time order.
    half_width : float [°C]
        Half-width of the play (> 0).
    start : float [°C]
        Output before the first sample (the memory of earlier excursions).

    Returns
    -------
    ndarray, shape (n,) [°C]
        ``p[k] = min(max(p[k-1], temp[k] − w), temp[k] + w)``.
    """
    return _play(np.ascontiguousarray(temp, dtype=np.float64), float(half_width), float(start))


@numba.njit(cache=True, nogil=True)
def _play(temp: NDArray[np.float64], w: float, p: float) -> NDArray[np.float64]:
    out = np.empty(temp.shape[0])  # pragma: no cover - compiled
    for k in range(temp.shape[0]):
        x = temp[k]
        if p < x - w:
            p = x - w
        elif p > x + w:
            p = x + w
        out[k] = p
    return out


def hysteresis_play(
    field: ThermalField, config: ImuConfig, memory: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Play-operator state of every channel through a run.

    Parameters
    ----------
    field : ThermalField
        True temperatures, in time order.
    config : ImuConfig
        The plant (each channel's ``hysteresis_play_c``).
    memory : ndarray, shape (6,), optional [°C]
        Play state left by the unit's previous run (the output of the last sample of that
        run); default :data:`STORAGE_C`, a unit coming from the lab.

    Returns
    -------
    ndarray, shape (n, 6) [°C]
        Play state per sample; its last row is the memory for the next run. Channels
        without hysteresis (or with the effect off) follow the temperature.
    """
    memory = np.full(6, STORAGE_C) if memory is None else np.asarray(memory, dtype=float)
    out = field.sensor.copy()
    if not config.effects.hysteresis:
        return out
    for j, coef in enumerate(config.thermal):
        if coef.hysteresis > 0:
            out[:, j] = play_operator(field.sensor[:, j], coef.hysteresis_play_c, memory[j])
    return out


def thermal_bias_eng(
    field: ThermalField, config: ImuConfig, play: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """True thermal bias in engineering units (signal errors excluded).

    Parameters
    ----------
    field : ThermalField
        True temperatures at the sample times, in time order.
    config : ImuConfig
        The plant.
    play : ndarray, shape (n, 6), optional [°C]
        Hysteresis state from :func:`hysteresis_play`; default: computed for a unit coming
        from the lab.

    Returns
    -------
    ndarray, shape (n, 6) [deg/h for gyros, µg for accelerometers]
        Thermal bias of each channel in the ``r`` frame (turn-on offset excluded):
        polynomial bias, Shupe term and hysteresis.
    """
    x = field.sensor - config.t_ref_c
    r = field.sensor_rate * units.MIN_TO_S  # °C/s -> °C/min
    d = field.gradient
    fx = config.effects
    if fx.hysteresis and play is None:
        play = hysteresis_play(field, config)
    out = np.empty_like(x)
    for j, coef in enumerate(config.thermal):
        if config.mechanistic is not None:
            out[:, j] = config.mechanistic[j].evaluate(field, j, config.t_ref_c)
        else:
            out[:, j] = coef.evaluate(x[:, j], r[:, j], d[:, j], field.stress[:, j])
        if fx.shupe and coef.shupe:
            out[:, j] += coef.shupe * field.coil_gradient_rate[:, j] * units.MIN_TO_S
        if fx.hysteresis and coef.hysteresis > 0 and play is not None:
            lag = (field.sensor[:, j] - play[:, j]) / coef.hysteresis_play_c  # -1 .. 1
            out[:, j] += 0.5 * coef.hysteresis * lag
    return out


def thermal_bias_r(
    field: ThermalField, config: ImuConfig, play: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """True thermal bias in SI, resolved in the rotating IMU frame ``r``.

    Returns
    -------
    ndarray, shape (n, 6) [rad/s for gyros, m/s² for accelerometers]
        Thermal bias of each channel (turn-on offset and signal errors excluded); see
        :func:`thermal_bias_eng`.
    """
    return thermal_bias_eng(field, config, play) * ENG_TO_SI


def signal_error_coefs(config: ImuConfig) -> NDArray[np.float64]:
    """Scale-factor and non-orthogonality change per °C, as one row per channel.

    Returns
    -------
    ndarray, shape (6, 3) [1/°C]
        Row ``j``: the error of channel ``j`` is ``(T_j − t_cal) · row_j · s`` for the true
        signal ``s`` (angular rate for gyros, specific force for accelerometers) along the
        ``r`` axes x, y, z. Zero where the effects are off.
    """
    fx = config.effects
    out = np.zeros((6, 3))
    for j, coef in enumerate(config.thermal):
        if fx.scale_factor:
            out[j, j % 3] += coef.scale_factor_ppm_per_c * 1e-6
        if fx.misalignment:
            out[j] += np.asarray(coef.misalignment_arcsec_per_c) * units.ARCSEC_TO_RAD
    return out


def signal_errors_r(
    temp_offset: NDArray[np.float64],
    coefs: NDArray[np.float64],
    omega_r: NDArray[np.float64],
    f_r: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Scale-factor and non-orthogonality errors of each sample.

    Parameters
    ----------
    temp_offset : ndarray, shape (n, 6) [°C]
        ``T_j − t_cal`` of each channel.
    coefs : ndarray, shape (6, 3) [1/°C]
        From :func:`signal_error_coefs`.
    omega_r, f_r : ndarray, shape (n, 3) or (3,) [rad/s, m/s²]
        True angular rate and specific force in ``r``.

    Returns
    -------
    ndarray, shape (n, 6) [rad/s, m/s²]
    """
    out = np.empty(temp_offset.shape)
    # einsum's own loop, not a threaded BLAS matmul, whose last bits depend on the thread
    # count (the BP network amplifies them: reproduce gave another method 3 on another machine)
    out[:, :3] = temp_offset[:, :3] * np.einsum("ij,kj->ik", np.atleast_2d(omega_r), coefs[:3])
    out[:, 3:] = temp_offset[:, 3:] * np.einsum("ij,kj->ik", np.atleast_2d(f_r), coefs[3:])
    return out


def turn_on_offsets(config: ImuConfig, rng: np.random.Generator) -> NDArray[np.float64]:
    """Draw the constant bias offsets of one power-on.

    Returns
    -------
    ndarray, shape (6,) [rad/s, m/s²]
    """
    return config.noise.turn_on_sd_si() * rng.standard_normal(6)


class SensorNoise:
    """White noise, bias random walk and rare outliers, drawn chunk by chunk.

    The random-walk state is carried from one call of :meth:`draw` to the next, so a run can
    be generated in chunks of any size with bounded memory.

    Parameters
    ----------
    config : ImuConfig
        The plant.
    rng : numpy.random.Generator
        Source of randomness (seeded by the caller).
    dt : float [s]
        Sample interval.
    """

    def __init__(self, config: ImuConfig, rng: np.random.Generator, dt: float) -> None:
        if not (math.isfinite(dt) and dt > 0):
            raise ConfigError(f"dt must be > 0 s, got {dt}")
        self.rng = rng
        self.dt = dt
        self.white_sd = config.noise.white_density_si() / math.sqrt(dt)
        self.rw_step_sd = config.noise.bias_rw_si() * math.sqrt(dt)
        self.outlier_sd = config.noise.outlier_sd_si()
        self.outlier_p = min(1.0, config.noise.outlier_rate_hz * dt)
        self.walk = np.zeros(6)

    def draw(self, n: int) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Errors of the next ``n`` samples.

        Returns
        -------
        errors : ndarray, shape (n, 6) [rad/s, m/s²]
            Mean error over each sample interval (white noise + random walk + outliers).
        outlier : ndarray, shape (n, 6) of bool
            Where an outlier was added.
        """
        rng = self.rng
        # float32 normals are twice as fast to draw; scaled and summed in float64
        e = rng.standard_normal((n, 6), dtype=np.float32) * self.white_sd
        if np.any(self.rw_step_sd > 0):
            walk = rng.standard_normal((n, 6), dtype=np.float32) * self.rw_step_sd
            np.cumsum(walk, axis=0, out=walk)
            walk += self.walk
            self.walk = walk[-1].copy()
            e += walk
        outlier = np.zeros((n, 6), dtype=bool)
        if self.outlier_p > 0:
            k = rng.binomial(n * 6, self.outlier_p)
            if k:
                flat = rng.choice(n * 6, size=k, replace=False)
                outlier.ravel()[flat] = True
                e.ravel()[flat] += rng.standard_normal(k) * self.outlier_sd[flat % 6]
        return e, outlier


def to_log_units(
    values_si: NDArray[np.float64],
    config: ImuConfig,
    dt: float,
    carry: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Convert mean rates/specific forces per sample to the log's unit.

    Parameters
    ----------
    values_si : ndarray, shape (n, 6) [rad/s, m/s²]
        Mean output over each sample interval.
    config : ImuConfig
        ``config.output`` chooses physical units or pulses.
    dt : float [s]
        Sample interval.
    carry : ndarray, shape (6,), optional [pulses]
        Fractional pulses left over from the previous chunk (pulse mode).

    Returns
    -------
    out : ndarray, shape (n, 6)
        deg/h and µg, or integer pulse counts per sample.
    carry : ndarray, shape (6,) [pulses]
        Remainder to pass to the next chunk.
    """
    if config.output.mode == "physical":
        out = values_si * (1.0 / ENG_TO_SI)
        return out, np.zeros(6) if carry is None else carry
    w = config.output.pulse_weight_si()
    acc = np.cumsum(values_si * (dt / w), axis=0)
    acc += np.zeros(6) if carry is None else carry
    whole = np.floor(acc)
    counts = np.diff(whole, axis=0, prepend=np.zeros((1, 6)))
    return counts, acc[-1] - whole[-1]


def log_units_to_si(config: ImuConfig, dt: float) -> NDArray[np.float64]:
    """Factor from the log's unit to SI per channel [(rad/s or m/s²) per unit]."""
    if config.output.mode == "physical":
        return ENG_TO_SI.copy()
    return config.output.pulse_weight_si() / dt


__all__ = [
    "DEFAULT_PRESET",
    "ENGINEERING_UNITS",
    "ENG_TO_SI",
    "POLYNOMIAL_KEYS",
    "PRESETS",
    "STORAGE_C",
    "THERMAL_LAWS",
    "ChannelThermal",
    "EffectsConfig",
    "ImuConfig",
    "MechanisticThermal",
    "NoiseConfig",
    "OutputConfig",
    "SensorNoise",
    "first_order_lag",
    "hysteresis_play",
    "load_imu",
    "log_units_to_si",
    "play_operator",
    "signal_error_coefs",
    "signal_errors_r",
    "thermal_bias_eng",
    "thermal_bias_r",
    "to_log_units",
    "turn_on_offsets",
]

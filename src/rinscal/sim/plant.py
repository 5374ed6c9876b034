"""The IMU thermal plant: the true thermal bias, noise and outliers of each sensor channel.

This module is the truth that calibration models are judged against. It is written from the
physics of the sensors, not shaped after any calibration model: each channel's thermal bias
depends on its own inner temperature ``T``, the rate ``dT/dt``, the inside/outside gradient
``ΔT``, their couplings, and a hidden slow package-stress state (see
:mod:`rinscal.sim.field`) that no thermometer sees. On top come a turn-on-to-turn-on
offset, white noise, a bias random walk, and rare vibration outliers.

The configuration is :mod:`rinscal.sim.config`, the two thermal laws
:mod:`rinscal.sim.polynomial` and :mod:`rinscal.sim.mechanistic`; this module
evaluates them on a thermal field (:func:`thermal_bias_r`), with hysteresis, signal errors,
turn-on offsets and the sensor noise. Everything here is in SI (rad/s for gyros, m/s² for
accelerometers) and resolved in the rotating IMU frame ``r``; the configuration file uses
deg/h and µg (see ``rinscal/data/navigation_grade.toml``).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from rinscal import units
from rinscal.errors import ConfigError
from rinscal.sim.config import ENG_TO_SI, ImuConfig
from rinscal.sim.field import (
    ThermalField,
)

__all__ = [
    "STORAGE_C",
    "SensorNoise",
    "hysteresis_play",
    "log_units_to_si",
    "play_operator",
    "signal_error_coefs",
    "signal_errors_r",
    "thermal_bias_eng",
    "thermal_bias_r",
    "to_log_units",
    "turn_on_offsets",
]


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
    """White noise, bias random walk, rare outliers and the gyros' angle noise, drawn chunk
    by chunk.

    The random-walk state is carried from one call of :meth:`draw` to the next, so a run can
    be generated in chunks of any size with bounded memory.

    Angle noise (``[noise] gyro_angle_*``, switched by ``[effects] angle_noise``) is an error
    of the gyro's *angle* ``a[k]``, white plus first-order Gauss-Markov: the sample's mean
    rate error is ``(a[k] − a[k−1]) / dt``, so it never accumulates (Allan slope −1 where
    it dominates, not the −½ of white rate noise). Its draws come after the others' and
    only when it is on, so a plant without it draws the same numbers as before.

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
        #: The bias random walk of each sample of the last :meth:`draw`, (n, 6) [rad/s,
        #: m/s²]; None when the plant has no random walk.
        self.last_walk: NDArray | None = None
        white_a, markov_a, tau_a = config.noise.angle_noise_si()
        self.angle_white_sd = white_a if config.effects.angle_noise else 0.0
        self.angle_markov_sd = markov_a if config.effects.angle_noise else 0.0
        self.angle_phi = math.exp(-dt / tau_a) if tau_a > 0 else 0.0
        # the angle noise before the first sample (a stationary start), drawn on first use
        self._angle_last: NDArray[np.float64] | None = None
        self._markov_last: NDArray[np.float64] | None = None

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
            self.last_walk = walk
            e += walk
        outlier = np.zeros((n, 6), dtype=bool)
        if self.outlier_p > 0:
            k = rng.binomial(n * 6, self.outlier_p)
            if k:
                flat = rng.choice(n * 6, size=k, replace=False)
                outlier.ravel()[flat] = True
                e.ravel()[flat] += rng.standard_normal(k) * self.outlier_sd[flat % 6]
        if self.angle_white_sd > 0 or self.angle_markov_sd > 0:
            e = e.astype(np.float64)
            e[:, :3] += np.diff(self._angle(n), axis=0) / self.dt
        return e, outlier

    def _angle(self, n: int) -> NDArray[np.float64]:
        """The gyros' angle noise at the end of the previous sample and of the next ``n``,
        shape (n + 1, 3) [rad] (its state carried to the next call)."""
        rng = self.rng
        if self._angle_last is None:  # stationary at power-on
            self._markov_last = rng.standard_normal(3) * self.angle_markov_sd
            self._angle_last = rng.standard_normal(3) * self.angle_white_sd + self._markov_last
        a = np.empty((n + 1, 3))
        a[0] = self._angle_last
        a[1:] = rng.standard_normal((n, 3)) * self.angle_white_sd
        if self.angle_markov_sd > 0:
            from scipy.signal import lfilter  # deferred: only a plant with angle noise needs it

            phi = self.angle_phi
            drive = rng.standard_normal((n, 3)) * (self.angle_markov_sd * math.sqrt(1 - phi * phi))
            m, _ = lfilter([1.0], [1.0, -phi], drive, axis=0, zi=(phi * self._markov_last)[None])
            self._markov_last = m[-1].copy()
            a[1:] += m
        self._angle_last = a[-1].copy()
        return a


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

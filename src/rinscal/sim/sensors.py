"""Sensor errors in the navigation loop: the thermal plant run alongside a scenario.

An *error source* gives the sensor errors of each sample from the time and the true
signal, ``errors(t, omega_r, f_r) -> (n, 6)``:

- ``t``: sample mid-times, shape (n,) [s] (since power-on);
- ``omega_r``: true mean angular rate ω_ir^r over each sample, shape (n, 3) [rad/s];
- ``f_r``: true mean specific force f^r over each sample, shape (n, 3) [m/s²];
- result: the mean error of each sample, gyros then accelerometers, resolved in ``r``
  [rad/s ×3, m/s² ×3].

A *compensator* has the same signature, called with the raw (measured) signal, which is
all a navigation computer has: it returns what the computer subtracts.

Error sources are called once per chunk, chunks in time order (the noise and the lever
arm's rate difference carry state from one chunk to the next; the thermal field, hysteresis
included, is computed for the whole run up front).
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal.calibration.compensator import Compensator as ThermalCompensator
from rinscal.calibration.compensator import hold
from rinscal.errors import ConfigError
from rinscal.nav.rotation import RotationSchedule
from rinscal.schema import CHANNELS
from rinscal.sensormodel import ImuCalibration, TriadErrors, triad_inverse
from rinscal.sim.config import ImuConfig
from rinscal.sim.field import ChamberProfile, ThermalField, measure, simulate_field
from rinscal.sim.plant import (
    SensorNoise,
    hysteresis_play,
    signal_error_coefs,
    signal_errors_r,
    thermal_bias_r,
    turn_on_offsets,
)
from rinscal.sim.scenario_config import ScenarioConfig
from rinscal.sim.sensor import nonlinear_drift_coefs, nonlinear_drift_r

#: ``errors(t, omega_r, f_r) -> (n, 6)`` SI in ``r`` (see the module docstring).
ErrorSource = Callable[
    [NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]
]
#: Same signature, called with the raw signal: what the navigation computer subtracts.
Compensator = ErrorSource
#: The kinds of parameter of an IMU calibration applied to the signal (not the biases).
SIGNAL_KINDS = ("sf", "sf_asym", "sf_quad", "mis")


def constant_errors(bias_r: NDArray[np.float64]) -> ErrorSource:
    """Constant sensor biases in ``r`` [rad/s ×3, m/s² ×3] as an error source."""
    b = np.asarray(bias_r, dtype=float).reshape(6)

    def errors_r(
        t: NDArray[np.float64], omega_r: NDArray | None = None, f_r: NDArray | None = None
    ) -> NDArray[np.float64]:
        return np.broadcast_to(b, (np.shape(t)[0], 6))

    return errors_r


class ThermalPlant:
    """The IMU plant of :mod:`rinscal.sim` run alongside a navigation scenario.

    The thermal field is simulated once on a 1 s grid over the whole run (cheap), with the
    turntable's encoder angle driving the body-fixed hot side and the torque motor, and
    interpolated at the sample times of each chunk; noise is drawn chunk by chunk.

    Errors of a sample, resolved in ``r``: thermal bias (polynomial, Shupe, hysteresis with
    the memory of a unit coming from the lab), scale factor and non-orthogonality against
    temperature times the true signal (and the drift of the scale factor's asymmetry and
    quadratic term, :func:`rinscal.sim.sensor.nonlinear_drift_r`: the computer holds the
    calibration made at ``t_cal``), the accelerometers' size effect
    ``e_j · (ω×(ω×ρ_j) + ω̇×ρ_j)`` from their lever arms ``ρ_j``, the turn-on offsets and the
    noise. Every effect follows the switches of ``config.effects``.

    Parameters
    ----------
    config : ImuConfig
        The plant (thermal coefficients, noise, thermal network, thermometers, effects).
    chamber : ChamberProfile
        Ambient temperature against time; the unit has soaked at its initial value and is
        switched on at t = 0.
    duration_s : float [s]
        Length of the run.
    rate_hz : float [Hz]
        IMU rate.
    seed : int
        Seed; turn-on offsets, sensor noise and thermometer noise use independent streams
        spawned from it, so switching one part off leaves the others unchanged.
    thermal, noise, turn_on : bool
        Which error parts to include (``thermal``: every temperature-driven error).
    schedule : RotationSchedule, optional
        The turntable schedule: heat fixed in the body reaches each sensor according to the
        encoder angle. None: the table holds at encoder zero.
    quantise : bool, optional
        Put out whole pulses of ``config.output``'s weights (0.1″ and 125 µg·s for the
        ``ring_laser`` preset) as a pulse counter does: the true increment plus every error
        is accumulated, the whole pulses are put out and the remainder is carried to the
        next sample, so the sum of the output over any span is the sum of the unquantised
        output to within one pulse (no drift from rounding). The counter starts half a
        pulse full. None (default): as the configuration says (``[output] mode =
        "pulses"`` and ``[effects] quantisation``).
    """

    def __init__(
        self,
        config: ImuConfig,
        chamber: ChamberProfile,
        duration_s: float,
        rate_hz: float,
        seed: int = 0,
        thermal: bool = True,
        noise: bool = True,
        turn_on: bool = True,
        schedule: RotationSchedule | None = None,
        quantise: bool | None = None,
    ) -> None:
        self.config = config
        if quantise is None:
            quantise = config.output.mode == "pulses" and config.effects.quantisation
        #: Weight of one output pulse per channel [rad, m/s], None: the output is not quantised.
        self.pulse_weights: NDArray[np.float64] | None = (
            config.output.pulse_weight_si() if quantise else None
        )
        self._counter = np.full(6, 0.5)  # the pulse counters' remainders [pulses]
        self.chamber = chamber
        self.schedule = schedule
        self.dt = 1.0 / rate_hz
        encoder = schedule.angle if schedule is not None else None
        self.field: ThermalField = simulate_field(
            chamber,
            config.thermal_network(),
            duration_s=duration_s + 2.0,
            dt_s=1.0,
            power_on_s=0.0,
            encoder=encoder,
        )
        rng_on, rng_noise, rng_thermo = np.random.default_rng(seed).spawn(3)
        self.offsets = turn_on_offsets(config, rng_on) if turn_on else np.zeros(6)
        self.noise = SensorNoise(config, rng_noise, self.dt) if noise else None
        self.thermal = thermal
        # the thermometers' noise is a function of the reading times (see
        # measured_temperatures), keyed by this draw
        self._thermo_key = int(rng_thermo.integers(2**63))
        # the bias and the temperatures on the field's 1 s grid, interpolated per chunk in
        # one pass (they vary on thermal time scales of minutes, the hot side on the
        # turntable's of a minute)
        coefs = signal_error_coefs(config)
        self._signal_coefs = coefs if thermal and np.any(coefs) else None
        self._nonlinear = nonlinear_drift_coefs(config)
        self._grid: NDArray[np.float64] | None = None
        if thermal:
            bias = thermal_bias_r(self.field, config, hysteresis_play(self.field, config))
            cols = [bias]
            if self._signal_coefs is not None:
                cols.append(self.field.sensor - config.t_cal_c)
            self._grid = np.ascontiguousarray(np.concatenate(cols, axis=1))
        arms = np.array([c.lever_arm_m for c in config.thermal[3:]], dtype=float)
        self._lever_arms = arms if config.effects.lever_arm and np.any(arms) else None
        self._last_omega: NDArray[np.float64] | None = None
        #: The accelerometers' size effect of the samples last drawn by :meth:`errors_r`,
        #: (n, 3) [m/s²]; None without lever arms.
        self.last_size_effect: NDArray[np.float64] | None = None
        # the thermal errors of the chunk last drawn, for the oracle (same sample times)
        self._last_thermal: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    @classmethod
    def for_scenario(
        cls,
        config: ImuConfig,
        scenario: ScenarioConfig,
        seed: int = 0,
        thermal: bool = True,
        noise: bool = True,
        turn_on: bool = True,
        quantise: bool | None = None,
    ) -> ThermalPlant:
        """The plant of a navigation scenario: its chamber, duration, rate and turntable."""
        if scenario.chamber is None:
            raise ConfigError(f"scenario {scenario.name!r} has no chamber profile")
        return cls(
            config,
            scenario.chamber,
            scenario.duration_s,
            scenario.rate_hz,
            seed=seed,
            thermal=thermal,
            noise=noise,
            turn_on=turn_on,
            schedule=scenario.schedule,
            quantise=quantise,
        )

    def _on_grid(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Grid columns (bias, then T − t_cal) linearly interpolated at ``t`` [s], held
        beyond the grid; one index computation for every column."""
        assert self._grid is not None
        ft = self.field.t
        k = np.clip(np.searchsorted(ft, t, side="right") - 1, 0, ft.size - 2)
        w = np.clip((t - ft[k]) / (ft[k + 1] - ft[k]), 0.0, 1.0)[:, None]
        g = self._grid
        return g[k] * (1.0 - w) + g[k + 1] * w

    def thermal_bias(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """True thermal bias at ``t`` [s], (n, 6) SI in ``r`` (zero if thermal is off)."""
        t = np.asarray(t, dtype=float)
        if self._grid is None:
            return np.zeros((t.shape[0], 6))
        return self._on_grid(t)[:, :6]

    def thermal_errors(
        self,
        t: NDArray[np.float64],
        omega_r: NDArray[np.float64],
        f_r: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Every temperature-driven error at ``t`` [s] for the signal ``omega_r`` [rad/s],
        ``f_r`` [m/s²] (n, 3): thermal bias plus scale factor and non-orthogonality.

        Returns
        -------
        ndarray, shape (n, 6) [rad/s, m/s²]
        """
        t = np.asarray(t, dtype=float)
        if self._grid is None:
            return np.zeros((t.shape[0], 6))
        g = self._on_grid(t)
        out = g[:, :6]
        if self._signal_coefs is not None:
            out += signal_errors_r(g[:, 6:], self._signal_coefs, omega_r, f_r)
            if self._nonlinear is not None:  # the asymmetry's and quadratic term's drift
                out += nonlinear_drift_r(self._nonlinear, g[:, 6:], omega_r, f_r)
        return out

    def size_effect(self, omega_r: NDArray[np.float64]) -> NDArray[np.float64]:
        """Accelerometer size effect ``e_j · (ω×(ω×ρ_j) + ω̇×ρ_j)`` per sample, (n, 3)
        [m/s²], from the mean rates ``omega_r`` (n, 3) [rad/s] of consecutive samples
        (ω̇ by backward difference, carried across chunks)."""
        assert self._lever_arms is not None
        w = np.asarray(omega_r, dtype=float)
        prev = w[:1] if self._last_omega is None else self._last_omega
        wdot = np.diff(w, axis=0, prepend=prev) / self.dt
        self._last_omega = w[-1:].copy()
        rho = self._lever_arms  # (3 accelerometers, 3): row j is ρ_j
        # e_j·(ω×(ω×ρ_j)) = ω_j (ω·ρ_j) − |ω|² ρ_jj
        out = w * (w @ rho.T) - np.einsum("ni,ni->n", w, w)[:, None] * np.diag(rho)
        # e_j·(ω̇×ρ_j) = ω̇_{j+1} ρ_j,{j+2} − ω̇_{j+2} ρ_j,{j+1} (indices cyclic)
        j = np.arange(3)
        j1, j2 = (j + 1) % 3, (j + 2) % 3
        out += wdot[:, j1] * rho[j, j2] - wdot[:, j2] * rho[j, j1]
        return out

    def errors_r(
        self, t: NDArray[np.float64], omega_r: NDArray[np.float64], f_r: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """All sensor errors at sample mid-times ``t`` (call chunks in time order)."""
        e = self.thermal_errors(t, omega_r, f_r)
        cached = e.copy()
        cached.flags.writeable = False  # handed to every oracle variant: nobody may alter it
        self._last_thermal = (np.asarray(t), cached)
        e += self.offsets
        self.last_size_effect = None
        if self._lever_arms is not None:
            self.last_size_effect = self.size_effect(omega_r)
            e[:, 3:] += self.last_size_effect
        if self.noise is not None:
            e += self.noise.draw(np.shape(t)[0])[0]
        if self.pulse_weights is not None:
            e = self.quantised(omega_r, f_r, e)
        return e

    def quantised(
        self, omega_r: NDArray[np.float64], f_r: NDArray[np.float64], e: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The errors ``e`` (n, 6) [rad/s, m/s²] of the true signal ``omega_r``, ``f_r``
        (n, 3) with the pulse counters' quantisation added: the output becomes whole pulses
        per sample, the remainder carried (call chunks in time order)."""
        assert self.pulse_weights is not None
        dt = self.dt
        signal = np.concatenate([omega_r, f_r], axis=1)
        acc = np.cumsum((signal + e) * (dt / self.pulse_weights), axis=0)
        acc += self._counter
        whole = np.floor(acc)
        counts = np.diff(whole, axis=0, prepend=np.floor(self._counter)[None])
        self._counter = acc[-1] - whole[-1]
        return counts * (self.pulse_weights / dt) - signal

    __call__ = errors_r

    def oracle(
        self, t: NDArray[np.float64], omega_r: NDArray[np.float64], f_r: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The true thermal errors as a compensator: for the samples just drawn by
        :meth:`errors_r`, exactly the thermal errors added to them (thermal bias, and the
        scale-factor and non-orthogonality errors of the true signal); at any other times,
        the same errors of the signal given."""
        last = self._last_thermal
        if last is not None and last[0].shape == np.shape(t) and np.array_equal(last[0], t):
            return last[1]
        return self.thermal_errors(t, omega_r, f_r)

    def measured_temperatures(self, t: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """Thermometer readings at ``t``: inner (n, 6) and outer (n,) [°C].

        The navigation computer reads its thermometers once: every caller asking for the
        same times gets the same readings (the noise is drawn from a stream keyed by the
        plant's seed and the times), so each compensator of a run sees the same
        thermometers whatever other compensators run beside it.
        """
        tt = np.ascontiguousarray(t, dtype=float)
        f = self.field.at(tt, nodes=False)
        th = self.config.thermometer
        key = zlib.crc32(tt.tobytes())
        rng = np.random.default_rng(np.random.SeedSequence(self._thermo_key, spawn_key=(key,)))
        return measure(f.sensor, th, rng), measure(f.outer, th, rng)


def temperature_frame(plant: ThermalPlant, step_s: float = 10.0) -> pd.DataFrame:
    """True temperatures of a plant's run for plots: ``time_s, chamber, outer,
    sensor_<channel>`` [s, °C], every ``step_s``."""
    t = np.arange(0.0, float(plant.field.t[-1]) + 1e-9, step_s)
    f = plant.field.at(t, nodes=False)
    df = pd.DataFrame({"time_s": t, "chamber": f.chamber, "outer": f.outer})
    for j, c in enumerate(CHANNELS):
        df[f"sensor_{c}"] = f.sensor[:, j]
    return df


def oracle_compensator(plant: ThermalPlant) -> Compensator:
    """Compensation by the true thermal errors (the best any thermal compensation can do);
    see :meth:`ThermalPlant.oracle`."""
    return plant.oracle


class ModelCompensator:
    """The plant's thermometers fed to the one compensator, as the navigation computer runs it.

    An adapter, not a second compensator: the thermometers (inner per sensor, outer on the
    package) are read once per ``update_s`` (noise and 0.01 °C quantisation of the plant's
    thermometer model) and handed to
    :meth:`rinscal.calibration.compensator.Compensator.record_bias_si` (its causal mode: the
    model's causal windowed slope, the bias ``(f(T, Ṫ, ΔT) − r) · unit_to_si``), whose
    result is held until the next reading (:func:`rinscal.calibration.compensator.hold`).
    Channels the model lacks are not compensated.

    Parameters
    ----------
    model : FittedModel or Compensator
        A loaded model file with units and static references (or its compensator, whose
        policy then applies).
    plant : ThermalPlant
        The plant whose thermometers feed the model.
    policy : {"clamp", "extrapolate", "error"}
        Out-of-range handling of the model inputs (a model file given).
    update_s : float [s]
        Thermometer reading and model update interval.
    imu_calibration : ImuCalibration, optional
        Scale factors, nonlinear terms and misalignments as functions of temperature to
        remove from the raw signal before the thermal bias (the order of
        :mod:`rinscal.sensormodel`), evaluated at the same held thermometer readings; default:
        the model file's own (``imu_calibration`` attribute), if it has one. Its biases are
        not applied (the thermal model holds the bias). In a simulated run the plant's
        signal errors are those left by a calibration at ``t_cal``, so pass
        :meth:`ImuCalibration.relative_to` ``(t_cal)`` of an absolute calibration.
    """

    def __init__(
        self,
        model: Any,
        plant: ThermalPlant,
        policy: str = "clamp",
        update_s: float = 1.0,
        imu_calibration: ImuCalibration | None = None,
    ) -> None:
        if not (math.isfinite(update_s) and update_s > 0):
            raise ConfigError(f"model compensator: update_s must be > 0, got {update_s}")
        comp = (
            model if isinstance(model, ThermalCompensator) else ThermalCompensator(model, policy)  # type: ignore[arg-type]
        )
        t_end = float(plant.field.t[-1])
        grid = np.arange(0.0, t_end + 1e-9, update_s)
        temp, t_out = plant.measured_temperatures(grid)
        self.bias = comp.record_bias_si(grid, temp, t_out, CHANNELS)
        self.model = comp.model
        self.grid = grid
        self._readings = np.arange(grid.size)  # index of each reading
        self.channels = tuple(comp.model.channels)
        cal = imu_calibration or getattr(comp.model, "imu_calibration", None)
        self.imu_calibration: ImuCalibration | None = cal
        # the calibration's errors on the thermometer grid, without its biases
        self._triads = None if cal is None else cal.select(SIGNAL_KINDS).triads(temp)

    def signal_errors(
        self, k: NDArray[np.intp], omega_r: NDArray[np.float64], f_r: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """What the IMU calibration says the raw signal holds beyond the true one,
        ``y − inverse(y)`` at the readings ``k`` of the grid, (n, 6) [rad/s, m/s²]."""
        assert self._triads is not None
        out = np.empty((k.shape[0], 6))
        for sl, y, e in (
            (slice(0, 3), omega_r, self._triads[0]),
            (slice(3, 6), f_r, self._triads[1]),
        ):
            at = TriadErrors(
                bias=e.bias[k], sf=e.sf[k], asym=e.asym[k], quad=e.quad[k], mis=e.mis[k]
            )
            y = np.asarray(y, dtype=float)
            out[:, sl] = y - triad_inverse(y, at)
        return out

    def __call__(
        self,
        t: NDArray[np.float64],
        omega_r: NDArray | None = None,
        f_r: NDArray | None = None,
    ) -> NDArray[np.float64]:
        """Bias estimate held from the last thermometer reading at ``t`` [s], (n, 6) SI,
        plus the IMU calibration's signal errors of the raw ``omega_r`` [rad/s] and ``f_r``
        [m/s²] (n, 3) when it has one (without the signal: the thermal bias alone)."""
        k = hold(self.grid, self._readings, t)  # the reading each sample holds
        out = self.bias[k]
        if self._triads is not None and omega_r is not None and f_r is not None:
            out = out + self.signal_errors(k, omega_r, f_r)
        return out


__all__ = [
    "SIGNAL_KINDS",
    "Compensator",
    "ErrorSource",
    "ModelCompensator",
    "ThermalPlant",
    "constant_errors",
    "oracle_compensator",
    "temperature_frame",
]

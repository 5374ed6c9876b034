"""The paper's thermal-chamber protocols, simulated run by run into calibration logs.

- ``soak`` (Table 3): the chamber is held at 0, 7, 14, 21, 28, 35 and 42 °C; the unit has
  soaked for 3 h, so each run starts in equilibrium, then cold-starts without rotation.
- ``ramp`` (Section 5.2.1): the unit soaked at −2 °C cold-starts while the chamber ramps to
  50 °C at 0.2 °C/min, then holds.
- ``repeat`` (Section 5.1.1): a repetition-priming cold start at 25 °C, i.e. one more power-on
  with its own turn-on offset, at a temperature that is not a soak set point.

The IMU sits level on the turntable at encoder zero, so its static output is Earth rate and
gravity for the configured latitude and heading, plus the sensor errors: in pulses (the raw
output) through the whole forward model of :mod:`rinscal.sim.sensor`, in physical units
(after the factory calibration at ``t_cal_c``) with each term's change since ``t_cal_c``.
The multi-position and rate-table protocol on a two-axis turntable is
:mod:`rinscal.sim.multiposition`.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import _check, units
from rinscal.earth import static_outputs_r
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS
from rinscal.sim.config import ImuConfig, resolve_imu
from rinscal.sim.field import ChamberProfile, measure, simulate_field
from rinscal.sim.plant import (
    SensorNoise,
    hysteresis_play,
    log_units_to_si,
    signal_error_coefs,
    signal_errors_r,
    thermal_bias_r,
    to_log_units,
    turn_on_offsets,
)
from rinscal.sim.sensor import (
    nonlinear_drift_coefs,
    nonlinear_drift_r,
    raw_output_r,
    sensor_law,
)

#: Chamber set points of the soak protocol (Table 3) [°C].
SOAK_SET_POINTS_C = (0.0, 7.0, 14.0, 21.0, 28.0, 35.0, 42.0)
#: Ramp of Section 5.2.1: start, end [°C] and rate [°C/min].
RAMP_START_C, RAMP_END_C, RAMP_RATE_C_PER_MIN = -2.0, 50.0, 0.2
#: Chamber temperature of the repetition-priming cold start (Section 5.1.1) [°C].
REPEAT_C = 25.0
#: Protocol names.
PROTOCOLS = ("soak", "ramp", "repeat")
#: The longest run [h] and the highest sample rate [Hz] :func:`simulate_protocol` takes (the
#: ranges of ``rinscal simulate --hours/--rate``).
MAX_HOURS = 72.0
MAX_RATE_HZ = 2000.0
#: Grid step of the thermal network [s]; temperatures are interpolated to the sample rate.
THERMAL_DT_S = 1.0


@dataclass(frozen=True)
class RunSpec:
    """One continuous recording.

    Parameters
    ----------
    name : str
        Run name in the log, e.g. ``soak_+07C``.
    profile : ChamberProfile
        Chamber temperature against time [°C].
    duration_s : float [s]
        Length of the recording from power-on.
    """

    name: str
    profile: ChamberProfile
    duration_s: float


def run_name(protocol: str, chamber_c: float) -> str:
    """Canonical run name, e.g. ``soak_+07C`` or ``repeat_+25C``."""
    return f"{protocol}_{chamber_c:+03.0f}C"


def protocol_runs(protocol: str, hours: float | None = None) -> list[RunSpec]:
    """The runs of one protocol.

    Parameters
    ----------
    protocol : {"soak", "ramp", "repeat"}
        Which protocol.
    hours : float, optional [h]
        Recording length of each run. Defaults: soak and repeat 3 h; ramp the length of the
        ramp (4 h 20 min) plus 30 min of hold.

    Returns
    -------
    list of RunSpec
    """
    if protocol not in PROTOCOLS:
        raise ConfigError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
    if hours is not None and not (np.isfinite(hours) and hours > 0):
        raise ConfigError(f"hours must be > 0, got {hours}")
    if protocol == "soak":
        d = 3 * units.HOUR_TO_S if hours is None else hours * units.HOUR_TO_S
        return [
            RunSpec(run_name("soak", c), ChamberProfile.constant(c), d) for c in SOAK_SET_POINTS_C
        ]
    if protocol == "repeat":
        d = 3 * units.HOUR_TO_S if hours is None else hours * units.HOUR_TO_S
        return [RunSpec(run_name("repeat", REPEAT_C), ChamberProfile.constant(REPEAT_C), d)]
    profile = ChamberProfile.ramp(RAMP_START_C, RAMP_END_C, RAMP_RATE_C_PER_MIN)
    d = profile.times_s[-1] + 1800.0 if hours is None else hours * units.HOUR_TO_S
    return [RunSpec(run_name("ramp", RAMP_START_C), profile, d)]


@dataclass
class SimulatedRun:
    """One simulated run: the log rows, the truth rows, and what is constant over the run.

    Attributes
    ----------
    name : str
        Run name.
    log : pandas.DataFrame
        Canonical calibration-log rows of this run.
    truth : pandas.DataFrame
        ``time_s``, ``run`` and ``bias_<channel>``: the true thermal bias of every sample in
        the log's unit (turn-on offset and static output excluded), the change of the
        signal errors with temperature included (the signal is static).
    offset : ndarray, shape (6,)
        Turn-on offset of this power-on, in the log's unit.
    static : ndarray, shape (6,)
        Static output in the log's unit. Physical units: Earth rate and gravity. Pulses (the
        raw output): Earth rate and gravity through the unit's forward model at ``t_cal``
        (scale factor, nonlinear terms and misalignment of :func:`~rinscal.sim.sensor.
        sensor_law` at ``t_cal_c``), so that ``static + offset + truth`` is the noiseless
        output in both units.
    memory : ndarray, shape (6,) [°C]
        Hysteresis (play) state at the end of the run: what the next run remembers.
    """

    name: str
    log: pd.DataFrame
    truth: pd.DataFrame
    offset: NDArray[np.float64]
    static: NDArray[np.float64]
    memory: NDArray[np.float64]

    def without_samples(self) -> SimulatedRun:
        """The same run with empty tables (keeps what :func:`log_meta` needs)."""
        return replace(self, log=self.log.iloc[:0], truth=self.truth.iloc[:0])


def _run_rng(seed: int, protocol: str, index: int) -> np.random.Generator:
    tag = PROTOCOLS.index(protocol)
    return np.random.default_rng(np.random.SeedSequence([int(seed), tag, index]))


def simulate_run(
    spec: RunSpec,
    config: ImuConfig,
    rate_hz: float,
    rng: np.random.Generator,
    memory: NDArray[np.float64] | None = None,
) -> SimulatedRun:
    """Simulate one static cold start on the turntable (no rotation, encoder at zero).

    Parameters
    ----------
    spec : RunSpec
        Chamber profile and duration.
    config : ImuConfig
        The plant.
    rate_hz : float [Hz]
        Output sample rate.
    rng : numpy.random.Generator
        Source of every random number of the run.
    memory : ndarray, shape (6,), optional [°C]
        Hysteresis state left by the unit's previous run (default: a unit from the lab).

    Returns
    -------
    SimulatedRun
    """
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ConfigError(f"rate must be > 0 Hz, got {rate_hz}")
    dt = 1.0 / rate_hz
    n = int(np.floor(spec.duration_s * rate_hz + 1e-9))
    if n < 2:
        raise ConfigError(f"run {spec.name}: {spec.duration_s} s at {rate_hz} Hz gives < 2 samples")
    # time stamps are the ends of the sample intervals; the first sample is at dt
    t = (np.arange(n) + 1.0) * dt
    coarse = simulate_field(spec.profile, config.thermal_network(), t[-1], THERMAL_DT_S)
    # The output over an interval is its mean: take the bias at the interval's middle. The
    # bias is evaluated on the thermal grid and interpolated (its curvature over 1 s is
    # negligible), which is far cheaper than evaluating it at every sample. The signal is
    # static, so the scale-factor and non-orthogonality errors are a thermal bias too.
    t_mid = t - 0.5 * dt
    play = hysteresis_play(coarse, config, memory)
    omega_r, f_r = static_outputs_r(config.latitude, config.heading, config.altitude_m)
    static_si = np.concatenate([omega_r, f_r])
    bias_coarse = thermal_bias_r(coarse, config, play)
    if config.output.mode == "physical":
        # after the factory calibration at t_cal: each term's change since t_cal
        bias_coarse += signal_errors_r(
            coarse.sensor - config.t_cal_c, signal_error_coefs(config), omega_r, f_r
        )
        drift = nonlinear_drift_coefs(config)
        if drift is not None:
            bias_coarse += nonlinear_drift_r(drift, coarse.sensor - config.t_cal_c, omega_r, f_r)
    else:
        # raw: the whole forward model; its value at t_cal is part of the static output
        law = sensor_law(config)
        raw_cal = raw_output_r(law, np.full(6, config.t_cal_c), omega_r, f_r)
        bias_coarse += raw_output_r(law, coarse.sensor, omega_r, f_r) - raw_cal
        static_si = raw_cal
    offset = turn_on_offsets(config, rng)
    noise, _ = SensorNoise(config, rng, dt).draw(n)
    scale = log_units_to_si(config, dt)
    run = pd.Categorical.from_codes(np.zeros(n, dtype=np.int8), categories=[spec.name])
    cols: dict[str, object] = {"time_s": t, "run": run}
    truth_cols: dict[str, object] = {"time_s": t, "run": run}
    bias_cols = [np.interp(t_mid, coarse.t, bias_coarse[:, j]) for j in range(6)]
    if config.output.mode == "physical":
        # channel by channel: one strided pass over the noise, no (n, 6) temporaries
        for j, ch in enumerate(CHANNELS):
            col = noise[:, j] + bias_cols[j]
            col += static_si[j] + offset[j]
            col *= 1.0 / scale[j]
            cols[ch] = col
    else:
        out_si = noise
        out_si += np.stack(bias_cols, axis=1)
        out_si += static_si + offset
        out, _ = to_log_units(out_si, config, dt)
        for j, ch in enumerate(CHANNELS):
            cols[ch] = np.ascontiguousarray(out[:, j])
    del noise
    for j, ch in enumerate(CHANNELS):
        cols[f"temp_{ch}"] = measure(
            np.interp(t, coarse.t, coarse.sensor[:, j]), config.thermometer, rng
        )
    cols["temp_out"] = measure(np.interp(t, coarse.t, coarse.outer), config.thermometer, rng)
    cols["chamber_temp"] = spec.profile(t)
    log = pd.DataFrame(cols, copy=False)  # keep one block per column: no consolidation copy
    for j, ch in enumerate(CHANNELS):
        bias_cols[j] *= 1.0 / scale[j]
        truth_cols[f"bias_{ch}"] = bias_cols[j]
    truth = pd.DataFrame(truth_cols, copy=False)
    return SimulatedRun(
        name=spec.name,
        log=log,
        truth=truth,
        offset=offset / scale,
        static=static_si / scale,
        memory=play[-1].copy(),
    )


def iter_protocol(
    protocol: str,
    config: ImuConfig,
    hours: float | None = None,
    rate_hz: float = 10.0,
    seed: int = 0,
) -> Iterator[SimulatedRun]:
    """Simulate the runs of a protocol one at a time (bounded memory).

    Each run's random numbers come from ``(seed, protocol, run index)``. The unit's
    hysteresis memory is carried from one run to the next, in order: the order of the soak
    runs matters, as on a real unit, and a run depends on the runs before it in its
    protocol. Each protocol starts from a unit that comes from the lab
    (:data:`rinscal.sim.plant.STORAGE_C`).
    """
    memory = None
    for i, spec in enumerate(protocol_runs(protocol, hours)):
        run = simulate_run(spec, config, rate_hz, _run_rng(seed, protocol, i), memory)
        memory = run.memory
        yield run


def base_meta(protocol: str, config: ImuConfig, rate_hz: float, seed: int) -> dict[str, object]:
    """The sidecar keys every simulated log has: generator, protocol, IMU, units and their
    SI factors, the site, the sample rate [Hz] and the seed."""
    scale = log_units_to_si(config, 1.0 / rate_hz)
    return {
        "generator": "rinscal simulate",
        "protocol": protocol,
        "imu": config.name,
        "units": dict(zip(CHANNELS, config.log_units(), strict=True)),
        "unit_to_si": dict(zip(CHANNELS, scale.tolist(), strict=True)),
        "latitude_deg": config.latitude_deg,
        "heading_deg": config.heading_deg,
        "altitude_m": config.altitude_m,
        "rate_hz": rate_hz,
        "seed": seed,
    }


def log_meta(
    protocol: str,
    config: ImuConfig,
    rate_hz: float,
    seed: int,
    runs: list[SimulatedRun],
) -> dict[str, object]:
    """The sidecar metadata of a simulated log (units, site, offsets, static outputs)."""
    return {
        **base_meta(protocol, config, rate_hz, seed),
        "static_output": dict(zip(CHANNELS, runs[0].static.tolist(), strict=True)) if runs else {},
        "turn_on_offset": {
            r.name: dict(zip(CHANNELS, r.offset.tolist(), strict=True)) for r in runs
        },
    }


class Simulation(NamedTuple):
    """A simulated log with what produced it; unpacks as ``log, truth, meta``.

    ``log`` the calibration log (the simulator's units: deg/h and µg, or pulses),
    ``truth`` the true thermal bias of every sample (same units), ``meta`` its metadata
    (units, site, the IMU's name).
    """

    log: pd.DataFrame
    truth: pd.DataFrame
    meta: dict[str, object]


def simulate_protocol(
    protocol: str,
    hours: float | None = None,
    rate_hz: float = 10.0,
    seed: int = 0,
    imu: str | os.PathLike[str] | ImuConfig | None = None,
    *,
    config: str | os.PathLike[str] | ImuConfig | None = None,
) -> Simulation:
    """Simulate a whole protocol into one stacked log (:func:`rinscal.simulate`).

    Parameters
    ----------
    protocol : {"soak", "ramp", "repeat"}
        Which protocol.
    hours : float, optional [h]
        Recording length per run (see :func:`protocol_runs`), at most :data:`MAX_HOURS`.
    rate_hz : float [Hz]
        Sample rate, at most :data:`MAX_RATE_HZ`.
    seed : int
        Seed of every random number.
    imu : str, PathLike or ImuConfig, optional
        The plant: a preset name (:data:`~rinscal.presets.PRESETS`), an IMU TOML
        file or a configuration; default the paper's own (``paper``, Tables 1-2), the
        default of :func:`rinscal.navigate` and of the command line too.
    config : str, PathLike or ImuConfig, optional
        The older spelling of ``imu`` (give one of them).

    Returns
    -------
    Simulation
        Unpacks as ``log, truth, meta``:
    log : pandas.DataFrame
        The canonical calibration log, runs stacked.
    truth : pandas.DataFrame
        True thermal bias of every sample (``bias_<channel>``), in the log's unit.
    meta : dict
        Sidecar metadata (see :func:`log_meta`).
    """
    _check.one_of("protocol", protocol, PROTOCOLS)
    # the ranges of `rinscal simulate` (--hours 0.01-72, --rate 0.01-2000): beyond them the
    # time grid alone would not fit in memory (hours=1e9 was a numpy MemoryError)
    hours = _check.number("hours", hours, above=0.0, max=MAX_HOURS, optional=True, unit="h")
    rate_hz = _check.number("rate_hz", rate_hz, above=0.0, max=MAX_RATE_HZ, unit="Hz")
    seed = _check.number("seed", seed, min=0, integer=True)
    config = resolve_imu(imu, config)
    runs = list(iter_protocol(protocol, config, hours, rate_hz, seed))
    log = pd.concat([r.log for r in runs], ignore_index=True)
    truth = pd.concat([r.truth for r in runs], ignore_index=True)
    for df in (log, truth):
        df["run"] = df["run"].astype(str)
    return Simulation(log, truth, log_meta(protocol, config, rate_hz, seed, runs))


__all__ = [
    "PROTOCOLS",
    "REPEAT_C",
    "SOAK_SET_POINTS_C",
    "RunSpec",
    "SimulatedRun",
    "Simulation",
    "base_meta",
    "iter_protocol",
    "log_meta",
    "protocol_runs",
    "run_name",
    "simulate_protocol",
    "simulate_run",
]

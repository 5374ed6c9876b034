"""Navigation scenarios: trajectory + turntable + thermal plant + compensation + alignment.

A scenario runs chunk by chunk (bounded memory for runs of many hours)::

    ideal r-frame increments (imu.py)
      + sensor errors in r      errors(t, ω, f) -> (n, 6) [rad/s, m/s²]  (thermal plant, noise)
      − compensation in r       compensator(t, ω̃, f̃) -> (n, 6)          (model file, oracle)
      -> self-alignment (align.py) -> free strapdown navigation (strapdown.py)
      -> position error against the true trajectory

the last three (and the compensation) in :func:`rinscal.nav.engine.navigate_pieces`, the loop
a recording's pieces run through too.

Several compensators ("variants") run side by side on the *same* erroneous increments, so
their position errors differ only by the compensation.

Calibration reference (the critical physics point): a calibration log recorded at rest
contains Earth rate and gravity. A model fitted to such a log predicts the *whole* static
output ``b(x) + s`` (thermal bias plus the static reference ``s`` of the calibration site and
orientation). Navigation must subtract only the bias: the compensator subtracts
``model(x) − s``, where ``s`` is recorded in the model file (Earth rate and gravity at the
calibration latitude and heading, in log units) — see
:class:`rinscal.sim.sensors.ModelCompensator`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import _check, units
from rinscal.errors import ConfigError
from rinscal.nav.align import AlignConfig, Aligner, align_from_noise
from rinscal.nav.attitude import C_nb_from_euler
from rinscal.nav.engine import NavResult, PieceCorrection, navigate_pieces
from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.nav.strapdown import Strapdown
from rinscal.schema import NavSamples
from rinscal.sim.config import ImuConfig
from rinscal.sim.field import ChamberProfile
from rinscal.sim.ideal_imu import ImuChunk, ImuSynthesizer
from rinscal.sim.scenario_config import ScenarioConfig
from rinscal.sim.sensors import (
    Compensator,
    ErrorSource,
    ModelCompensator,
    ThermalPlant,
    constant_errors,
    oracle_compensator,
    temperature_frame,
)
from rinscal.sim.trajectory import (
    StaticMotion,
    SwingMotion,
    Trajectory,
    vehicle_route,
)

#: Scenario names understood by :func:`preset`.
SCENARIOS = ("quasi-static", "swing", "vehicle", "ramp")
#: Default length of each scenario [h] (vehicle: driving time after the alignment).
DEFAULT_HOURS = {"quasi-static": 4.0, "swing": 2.0, "vehicle": 1.9, "ramp": 4.5}
#: The longest scenario [h] and the highest IMU rate [Hz] :func:`preset` takes (the ranges of
#: ``rinscal navigate --hours/--rate``).
MAX_HOURS = 72.0
MAX_RATE_HZ = 2000.0
#: Lab temperature of the quasi-static and swing cold starts [°C].
LAB_C = 20.0
#: Vehicle cold start: the cabin warms from this ambient [°C] ...
VEHICLE_AMBIENT_C = 5.0
#: ... to this temperature [°C] ...
VEHICLE_CABIN_C = 20.0
#: ... in this time [s] (heater on).
VEHICLE_WARMUP_S = 3600.0


def preset(
    name: str,
    hours: float | None = None,
    rate_hz: float = 100.0,
    align: AlignConfig | None = None,
    schedule: RotationSchedule | None = None,
) -> ScenarioConfig:
    """The paper's scenarios (Section 5.2).

    ``quasi-static``
        Turntable held at heading 45° (Table 9), cold start in the lab at 20 °C.
    ``swing``
        Heading/pitch/roll swinging 2°/2°/8° with periods 3/3/5 s (our reading of
        Table 9), cold start in the lab at 20 °C.
    ``vehicle``
        Land vehicle (Section 5.2.2): stands still until the alignment ends
        (``align.start_s + align.total_s``), then drives the route of
        :func:`rinscal.sim.trajectory.vehicle_route` for ``hours`` (default 1.9 h); cold
        start in a cabin warming from 5 °C to 20 °C within the first hour.
    ``ramp``
        Quasi-static in the chamber ramping −2 → 50 °C at 0.2 °C/min (Figure 9); the unit
        soaked at −2 °C cold-starts as the ramp begins.

    All use the four-position modulation unless ``schedule`` is given.

    Parameters
    ----------
    name : str
        One of :data:`SCENARIOS`.
    hours : float, optional [h]
        Length of the run (vehicle: of the drive), at most :data:`MAX_HOURS`; default
        :data:`DEFAULT_HOURS`.
    rate_hz : float [Hz]
        IMU rate, at most :data:`MAX_RATE_HZ`.
    align : AlignConfig, optional
        Alignment settings (default :class:`AlignConfig`).
    schedule : RotationSchedule, optional
        Turntable schedule (default four-position, 60 s dwell, 10 °/s).
    """
    _check.text("name", name)
    if name not in SCENARIOS:
        raise ConfigError(f"unknown scenario {name!r}; choose one of {', '.join(SCENARIOS)}")
    _check.number("hours", hours, optional=True, max=MAX_HOURS, unit="h")  # > 0 below
    _check.number("rate_hz", rate_hz, above=0.0, max=MAX_RATE_HZ, unit="Hz")
    _check.instance("align", align, AlignConfig, "an AlignConfig", optional=True)
    _check.instance("schedule", schedule, RotationSchedule, "a RotationSchedule", optional=True)
    hours = DEFAULT_HOURS[name] if hours is None else float(hours)
    if not (math.isfinite(hours) and hours > 0):
        raise ConfigError(f"hours must be > 0, got {hours}")
    align = AlignConfig() if align is None else align
    schedule = RotationSchedule.four_position() if schedule is None else schedule
    duration = hours * units.HOUR_TO_S
    if name == "quasi-static":
        traj: Trajectory = StaticMotion()
        chamber = ChamberProfile.constant(LAB_C)
    elif name == "swing":
        traj = SwingMotion()
        chamber = ChamberProfile.constant(LAB_C)
    elif name == "vehicle":
        route = vehicle_route(duration_s=duration, stationary_s=align.end_s)
        traj = route
        duration = route.duration_s
        chamber = ChamberProfile((0.0, VEHICLE_WARMUP_S), (VEHICLE_AMBIENT_C, VEHICLE_CABIN_C))
    else:
        traj = StaticMotion()
        chamber = ChamberProfile.ramp(-2.0, 50.0, 0.2)
    return ScenarioConfig(
        name=name,
        trajectory=traj,
        schedule=schedule,
        duration_s=duration,
        rate_hz=rate_hz,
        align=align,
        chamber=chamber,
    )


def daily_ambient(
    mean_c: float, amplitude_c: float, duration_s: float, step_s: float = 600.0
) -> ChamberProfile:
    """An outdoor ambient: ``mean_c + amplitude_c · sin(2π t / 24 h)`` [°C], sampled every
    ``step_s`` [s] over ``duration_s`` [s] as a chamber profile (break points 10 min apart
    are within 0.03 % of the amplitude of the sinusoid). The unit has soaked at ``mean_c``
    before power-on (t = 0); ``amplitude_c`` 0: a constant ambient."""
    if not amplitude_c:
        return ChamberProfile.constant(mean_c)
    if not (duration_s > 0 and step_s > 0):
        raise ConfigError(
            f"daily ambient: duration_s and step_s must be > 0, got {duration_s}, {step_s}"
        )
    t = np.arange(0.0, duration_s + step_s, step_s)
    y = mean_c + amplitude_c * np.sin(2.0 * np.pi * t / 86400.0)
    return ChamberProfile(tuple(float(v) for v in t), tuple(float(v) for v in y))


def align_for(
    imu: ImuConfig,
    total_s: float = 600.0,
    coarse_s: float = 60.0,
    start_s: float = 0.0,
    *,
    gyro_bias_tau_s: float | None = None,
    gyro_bias_markov_sd: float | None = None,
    accel_bias_tau_s: float | None = None,
    accel_bias_markov_sd: float | None = None,
) -> AlignConfig:
    """Alignment settings whose filter noise matches an IMU plant.

    Parameters
    ----------
    imu : ImuConfig
        The plant (its white-noise densities set the filter's measurement-side process
        noise; its bias random walk the floor of the bias states' process noise).
    total_s : float [s]
        Coarse plus fine alignment time.
    coarse_s : float [s]
        Coarse stage (at most a third of ``total_s``).
    start_s : float [s]
        Time after power-on at which the alignment begins (see :class:`AlignConfig`).
    gyro_bias_tau_s, accel_bias_tau_s : float, optional [s]
        Correlation times of the Gauss-Markov bias states; default those of
        :class:`AlignConfig`.
    gyro_bias_markov_sd, accel_bias_markov_sd : float, optional [rad/s, m/s²]
        Their steady-state standard deviations. Default: those of :class:`AlignConfig`,
        raised where needed so that the driving noise ``2σ²/τ`` is at least the plant's own
        bias random walk (``σ ≥ q √(τ/2)``): a filter must never believe its biases steadier
        than the sensor's data sheet. Given values are used as they are (0: random
        constants).
    """
    wd = imu.noise.white_density_si()
    rw = imu.noise.bias_rw_si()
    return align_from_noise(
        float(wd[0]),
        float(wd[3]),
        float(rw[0]),
        float(rw[3]),
        total_s=total_s,
        coarse_s=coarse_s,
        start_s=start_s,
        gyro_bias_tau_s=gyro_bias_tau_s,
        gyro_bias_markov_sd=gyro_bias_markov_sd,
        accel_bias_tau_s=accel_bias_tau_s,
        accel_bias_markov_sd=accel_bias_markov_sd,
    )


# --------------------------------------------------------------------------- the run
def _true_initial_nav(config: ScenarioConfig) -> Strapdown:
    tr = config.trajectory
    kin = tr.kinematics(np.zeros(1))
    C_nr = C_nb_from_euler(kin.euler[0]) @ C_br(config.schedule.angle(0.0)[0])
    return Strapdown(tr.lat0, tr.lon0, tr.alt0, kin.v_n[0], C_nr, config.dt, config.vertical)


@dataclass(frozen=True)
class _SimSamples(NavSamples):
    """A simulated piece: the erroneous increments with the chunk of truth they came from."""

    chunk: ImuChunk | None = None


@dataclass(frozen=True)
class _ChunkTruth:
    """The simulator's truth at a chunk's samples (:class:`rinscal.nav.engine.PieceTruth`)."""

    chunk: ImuChunk

    @property
    def alt(self) -> NDArray[np.float64]:
        return self.chunk.alt

    @property
    def vu(self) -> NDArray[np.float64]:
        return self.chunk.v_n[:, 2]

    def rows(self, sel: NDArray[np.bool_]) -> NDArray[np.float64]:
        ch = self.chunk
        return np.column_stack(
            [ch.t[sel], ch.lat[sel], ch.lon[sel], ch.alt[sel], ch.v_n[sel], ch.euler[sel],
             ch.encoder[sel], np.ones(int(sel.sum()))]
        )  # fmt: skip


def _piece_correction(comp: Compensator | None, dt: float) -> PieceCorrection | None:
    """A scenario's compensator ``comp(t_mid, omega_raw, f_raw)`` as a piece correction."""
    if comp is None:
        return None

    def correct(s: NavSamples) -> NDArray[np.float64]:
        return comp(s.t - 0.5 * dt, s.dtheta / dt, s.dv / dt)

    return correct


def imu_samples(
    config: ScenarioConfig,
    errors: ErrorSource | None = None,
    split_at: tuple[float, ...] = (),
) -> Iterator[tuple[ImuChunk, NDArray[np.float64], NDArray[np.float64]]]:
    """A scenario's raw IMU output from power-on, chunk by chunk, without navigating it:
    the trajectory's ideal r-frame increments (:class:`rinscal.sim.ideal_imu.ImuSynthesizer`)
    plus the sensor errors.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario (trajectory, turntable, duration, rate, chunk length).
    errors : callable, optional
        Sensor errors in ``r``, ``errors(t, omega_r, f_r) -> (n, 6)`` [rad/s, m/s²] at the
        sample mid-times [s] from the true mean rate [rad/s] and specific force [m/s²] of each
        sample (e.g. a :class:`ThermalPlant`); called once per chunk, in time order. None:
        an ideal IMU.
    split_at : tuple of float [s]
        Times at which a chunk must end.

    Yields
    ------
    chunk : ImuChunk
        The truth of the chunk (ideal increments, encoder, position, attitude).
    dtheta, dv : ndarray, shape (n, 3) [rad, m/s]
        The raw increments the IMU put out (errors included).
    """
    dt = config.dt
    synth = ImuSynthesizer(config.trajectory, config.schedule, config.rate_hz)
    for ch in synth.chunks(config.duration_s, config.chunk_s, split_at=split_at):
        raw_th, raw_v = ch.dtheta, ch.dv
        if errors is not None:  # called on every chunk, in time order (state carries)
            e = np.asarray(errors(ch.t - 0.5 * dt, ch.dtheta / dt, ch.dv / dt), dtype=float)
            if e.shape != (ch.n, 6):
                raise ConfigError(f"errors_r returned shape {e.shape}, expected ({ch.n}, 6)")
            raw_th = raw_th + e[:, :3] * dt
            raw_v = raw_v + e[:, 3:] * dt
        yield ch, raw_th, raw_v


def run_scenario(
    config: ScenarioConfig,
    errors: ErrorSource | None = None,
    compensators: Mapping[str, Compensator | None] | None = None,
    progress: Callable[[float, float], None] | None = None,
    recorder: Callable[[ImuChunk, NDArray, NDArray], None] | None = None,
    n_jobs: int | None = 1,
) -> NavResult:
    """Run a navigation scenario (the simulator's chunks through
    :func:`rinscal.nav.engine.navigate_pieces`).

    Parameters
    ----------
    config : ScenarioConfig
        The scenario (see :func:`preset`).
    errors : callable, optional
        Sensor errors in ``r``, ``errors(t, omega_r, f_r) -> (n, 6)`` SI at the sample
        mid-times from the true mean rate and specific force of each sample (see
        :mod:`rinscal.nav.sensors`; e.g. a :class:`ThermalPlant` or
        :func:`constant_errors`); None for an ideal IMU. Called once per chunk, in time
        order.
    compensators : mapping of str to callable or None, optional
        Variants to navigate side by side on the same raw output: each subtracts its
        ``compensator(t, omega_raw, f_raw) -> (n, 6)`` SI, called with the raw (measured)
        signal from the alignment start on (None: no compensation). Default
        ``{"none": None}``.
    progress : callable, optional
        ``progress(done_s, total_s)`` after each chunk.
    recorder : callable, optional
        ``recorder(chunk, dtheta, dv)`` with every chunk from power-on on: the truth and
        the raw increments the IMU put out [rad, m/s] (see
        :func:`rinscal.nav.recorded.frame.recording_frame`).
    n_jobs : int or None
        Threads the variants of each chunk are navigated on (None or 0: every core; the
        chunks themselves are simulated in order on the caller's thread). The compensators
        must not share state that a call changes (the plant's oracle and model compensators
        only read it); the result does not depend on it.

    Returns
    -------
    NavResult
        Errors reported from the start of free navigation (``config.nav_start_s``) on.
    """
    comps = {"none": None} if compensators is None else dict(compensators)
    if not comps:
        raise ConfigError("run_scenario: need at least one variant")
    tr = config.trajectory
    dt = config.dt
    # samples since power-on at the alignment start and at the navigation start
    n_start = 0 if config.align is None else round(config.align.start_s * config.rate_hz)
    n_nav = n_start
    aligner = None
    if config.align is not None:
        align = config.align

        def aligner(k0: int) -> Aligner:
            return Aligner(tr.lat0, tr.lon0, tr.alt0, dt, align, config.vertical, k0=k0)

        n_nav = n_start + aligner(n_start).n_total

    def pieces() -> Iterator[_SimSamples]:
        splits = () if config.align is None else (n_start * dt, n_nav * dt)
        for ch, raw_th, raw_v in imu_samples(config, errors, split_at=splits):
            if recorder is not None:
                recorder(ch, raw_th, raw_v)
            yield _SimSamples(ch.t, np.full(ch.n, dt), raw_th, raw_v, chunk=ch)

    run = navigate_pieces(
        pieces(),
        lambda s: _ChunkTruth(s.chunk),  # type: ignore[attr-defined]
        {name: _piece_correction(comp, dt) for name, comp in comps.items()},
        dt=dt,
        start_s=n_start * dt,
        out_every=config.out_every,
        aligner=aligner,
        initial=None if aligner is not None else (lambda: _true_initial_nav(config)),
        correct_warm_up=False,
        progress=None if progress is None else (lambda t: progress(t, config.duration_s)),
        n_jobs=n_jobs,
    )
    truth = run.truth
    truth_df = pd.DataFrame(
        {
            "time_s": truth[:, 0],
            "lat_deg": truth[:, 1] / units.DEG_TO_RAD,
            "lon_deg": truth[:, 2] / units.DEG_TO_RAD,
            "alt_m": truth[:, 3],
            "v_e": truth[:, 4],
            "v_n": truth[:, 5],
            "v_u": truth[:, 6],
            "heading_deg": truth[:, 7] / units.DEG_TO_RAD,
            "pitch_deg": truth[:, 8] / units.DEG_TO_RAD,
            "roll_deg": truth[:, 9] / units.DEG_TO_RAD,
            "encoder_deg": truth[:, 10] / units.DEG_TO_RAD,
        }
    )
    return NavResult(config, truth_df, run.errors, run.alignment)


def with_duration(config: ScenarioConfig, duration_s: float) -> ScenarioConfig:
    """A copy of ``config`` with another duration [s]."""
    return replace(config, duration_s=duration_s)


__all__ = [
    "DEFAULT_HOURS",
    "SCENARIOS",
    "Compensator",
    "ErrorSource",
    "ModelCompensator",
    "NavResult",
    "ScenarioConfig",
    "ThermalPlant",
    "align_for",
    "align_from_noise",
    "constant_errors",
    "daily_ambient",
    "imu_samples",
    "oracle_compensator",
    "preset",
    "run_scenario",
    "temperature_frame",
    "with_duration",
]

"""Navigation scenarios: trajectory + turntable + thermal plant + compensation + alignment.

A scenario runs chunk by chunk (bounded memory for runs of many hours)::

    ideal r-frame increments (imu.py)
      + sensor errors in r      errors(t, ω, f) -> (n, 6) [rad/s, m/s²]  (thermal plant, noise)
      − compensation in r       compensator(t, ω̃, f̃) -> (n, 6)          (model file, oracle)
      -> self-alignment (align.py) -> free strapdown navigation (strapdown.py)
      -> position error against the true trajectory

Several compensators ("variants") run side by side on the *same* erroneous increments, so
their position errors differ only by the compensation.

Calibration reference (the critical physics point): a calibration log recorded at rest
contains Earth rate and gravity. A model fitted to such a log predicts the *whole* static
output ``b(x) + s`` (thermal bias plus the static reference ``s`` of the calibration site and
orientation). Navigation must subtract only the bias: the compensator subtracts
``model(x) − s``, where ``s`` is recorded in the model file (Earth rate and gravity at the
calibration latitude and heading, in log units) — see
:class:`rinscal.nav.sensors.ModelCompensator`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import _check, earth, units
from rinscal.errors import ConfigError
from rinscal.nav.align import AlignConfig, Aligner, AlignResult, feed_and_hand_over
from rinscal.nav.config import ScenarioConfig
from rinscal.nav.imu import ImuChunk, ImuSynthesizer
from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.nav.sensors import (
    Compensator,
    ErrorSource,
    ModelCompensator,
    ThermalPlant,
    constant_errors,
    oracle_compensator,
    temperature_frame,
)
from rinscal.nav.strapdown import Strapdown, quat_to_dcm
from rinscal.nav.trajectory import (
    C_nb_from_euler,
    StaticMotion,
    SwingMotion,
    Trajectory,
    euler_from_C_nb,
    vehicle_route,
)
from rinscal.thermal.config import ImuConfig
from rinscal.thermal.field import ChamberProfile

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
        :func:`rinscal.nav.trajectory.vehicle_route` for ``hours`` (default 1.9 h); cold
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


def align_from_noise(
    gyro_density: float,
    accel_density: float,
    gyro_bias_rw: float,
    accel_bias_rw: float,
    total_s: float = 600.0,
    coarse_s: float = 60.0,
    start_s: float = 0.0,
    *,
    gyro_bias_tau_s: float | None = None,
    gyro_bias_markov_sd: float | None = None,
    accel_bias_tau_s: float | None = None,
    accel_bias_markov_sd: float | None = None,
) -> AlignConfig:
    """Alignment settings from the sensor noise itself (:func:`align_for` of a plant's).

    Parameters
    ----------
    gyro_density : float [rad/√s]
        Gyro angle random walk (white-noise density).
    accel_density : float [m/s²/√Hz]
        Accelerometer velocity random walk.
    gyro_bias_rw : float [rad/s/√s]
        Gyro bias random walk (0: none known); floors the bias states' process noise.
    accel_bias_rw : float [m/s²/√s]
        Accelerometer bias random walk (0: none known).
    total_s, coarse_s, start_s, gyro_bias_tau_s, ... :
        As for :func:`align_for`.
    """
    if not (math.isfinite(total_s) and total_s > 0):
        raise ConfigError(f"alignment time must be > 0 s, got {total_s}")
    coarse = min(coarse_s, total_s / 3)
    d = AlignConfig()
    tau_g = d.gyro_bias_tau_s if gyro_bias_tau_s is None else gyro_bias_tau_s
    tau_a = d.accel_bias_tau_s if accel_bias_tau_s is None else accel_bias_tau_s

    def floor(sd: float, q: float, tau: float) -> float:
        return sd if not (math.isfinite(tau) and tau > 0) else max(sd, q * math.sqrt(tau / 2))

    sd_g = (
        floor(d.gyro_bias_markov_sd, gyro_bias_rw, tau_g)
        if gyro_bias_markov_sd is None
        else gyro_bias_markov_sd
    )
    sd_a = (
        floor(d.accel_bias_markov_sd, accel_bias_rw, tau_a)
        if accel_bias_markov_sd is None
        else accel_bias_markov_sd
    )
    return AlignConfig(
        coarse_s=coarse,
        fine_s=total_s - coarse,
        gyro_noise_density=gyro_density,
        accel_noise_density=accel_density,
        start_s=start_s,
        gyro_bias_tau_s=tau_g,
        gyro_bias_markov_sd=sd_g,
        accel_bias_tau_s=tau_a,
        accel_bias_markov_sd=sd_a,
    )


# --------------------------------------------------------------------------- results
@dataclass
class NavResult:
    """Outcome of a navigation scenario.

    Attributes
    ----------
    config : ScenarioConfig
        What was run.
    truth : pandas.DataFrame
        True state at the reported times: ``time_s, lat_deg, lon_deg, alt_m, v_e, v_n,
        v_u`` [s, deg, deg, m, m/s ×3], ``heading_deg, pitch_deg, roll_deg, encoder_deg``.
    errors : dict of str to pandas.DataFrame
        Per variant, from the start of free navigation on: ``time_s``, position error
        ``east_m, north_m, horizontal_m, horizontal_nmi, up_m``, INS position ``lat_deg,
        lon_deg``, velocity error ``v_e_err, v_n_err`` [m/s], attitude error of the body
        frame ``att_e, att_n, att_u`` [rad] (small angles, ENU) and the same as Euler-angle
        errors, INS minus truth, ``heading_err, pitch_err, roll_err`` [rad] (heading
        clockwise from north, wrapped to ±π).
    alignment : dict of str to AlignResult or None
        Per variant.
    """

    config: ScenarioConfig
    truth: pd.DataFrame
    errors: dict[str, pd.DataFrame]
    alignment: dict[str, AlignResult | None]

    def max_error_m(self, variant: str) -> float:
        """Maximum horizontal position error of a variant [m]."""
        return float(self.errors[variant]["horizontal_m"].max())

    def summary(self) -> dict[str, Any]:
        """JSON-able summary: per variant max/final/RMS error [m, nmi] and alignment.

        Per variant: ``max_error_m``, ``max_error_nmi``, ``time_of_max_s``,
        ``final_error_m``, ``rms_error_m``, ``attitude_error_at_nav_start`` (``{"heading_arcsec",
        "pitch_arcsec", "roll_arcsec"}``: INS body heading, pitch and roll minus the truth at
        the first navigation output, heading clockwise from north, wrapped to ±180°), with an
        alignment also ``alignment`` (bias estimates, filter attitude sd and the small-angle
        ``attitude_error_arcsec``), and ``improvement_vs_none_pct`` beside a ``none`` variant.
        """
        c = self.config
        out: dict[str, Any] = {
            "scenario": c.name,
            "duration_s": c.duration_s,
            "rate_hz": c.rate_hz,
            "rotation": c.schedule.name,
            "alignment_s": None if c.align is None else c.align.total_s,
            "alignment_start_s": c.align_start_s,
            "navigation_start_s": c.nav_start_s,
            "variants": {},
        }
        for name, df in self.errors.items():
            h = df["horizontal_m"].to_numpy()
            i = int(np.argmax(h)) if h.size else 0
            v: dict[str, Any] = {
                "max_error_m": float(h.max()) if h.size else float("nan"),
                "max_error_nmi": float(h.max() / units.NMI_TO_M) if h.size else float("nan"),
                "time_of_max_s": float(df["time_s"].iloc[i]) if h.size else float("nan"),
                "final_error_m": float(h[-1]) if h.size else float("nan"),
                "rms_error_m": float(np.sqrt(np.mean(h**2))) if h.size else float("nan"),
            }
            eul = df[["heading_err", "pitch_err", "roll_err"]].to_numpy()
            e0 = eul[0] / units.ARCSEC_TO_RAD if h.size else np.full(3, np.nan)
            # a recording knows at most its heading: an unknown truth is left out, not NaN
            v["attitude_error_at_nav_start"] = {
                f"{k}_arcsec": float(x)
                for k, x in zip(("heading", "pitch", "roll"), e0, strict=True)
                if math.isfinite(x)
            }
            a = self.alignment.get(name)
            if a is not None:
                v["alignment"] = {
                    "gyro_bias_dph": (a.gyro_bias / units.DPH_TO_RPS).tolist(),
                    "accel_bias_ug": (a.accel_bias / units.UG_TO_MPS2).tolist(),
                    "attitude_sd_arcsec": (a.attitude_sd / units.ARCSEC_TO_RAD).tolist(),
                }
                att = df[["att_e", "att_n", "att_u"]].to_numpy()
                if att.shape[0] and np.isfinite(att[0]).all():
                    v["alignment"]["attitude_error_arcsec"] = (
                        att[0] / units.ARCSEC_TO_RAD
                    ).tolist()
            out["variants"][name] = v
        if "none" in out["variants"]:
            base = out["variants"]["none"]["max_error_m"]
            for name, v in out["variants"].items():
                if name != "none" and base > 0:
                    v["improvement_vs_none_pct"] = 100.0 * (1.0 - v["max_error_m"] / base)
        return out


@dataclass
class _Variant:
    compensator: Compensator | None
    aligner: Aligner | None
    nav: Strapdown | None
    gyro_bias: NDArray[np.float64]
    accel_bias: NDArray[np.float64]
    rows: list[NDArray[np.float64]]


def _true_initial_nav(config: ScenarioConfig) -> Strapdown:
    tr = config.trajectory
    kin = tr.kinematics(np.zeros(1))
    C_nr = C_nb_from_euler(kin.euler[0]) @ C_br(config.schedule.angle(0.0)[0])
    return Strapdown(tr.lat0, tr.lon0, tr.alt0, kin.v_n[0], C_nr, config.dt, config.vertical)


def _attitude_error(C_true: NDArray, C_est: NDArray) -> NDArray[np.float64]:
    """Small-angle φ with C_est = (I − [φ×]) C_true, shape (m, 3) [rad]."""
    M = np.einsum("mij,mkj->mik", C_true, C_est)
    return 0.5 * np.stack(
        [M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0], M[:, 1, 0] - M[:, 0, 1]], axis=1
    )


def run_scenario(
    config: ScenarioConfig,
    errors: ErrorSource | None = None,
    compensators: Mapping[str, Compensator | None] | None = None,
    progress: Callable[[float, float], None] | None = None,
    recorder: Callable[[ImuChunk, NDArray, NDArray], None] | None = None,
) -> NavResult:
    """Run a navigation scenario.

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
    synth = ImuSynthesizer(tr, config.schedule, config.rate_hz)
    # samples since power-on at the alignment start and at the navigation start
    n_start = 0 if config.align is None else round(config.align.start_s * config.rate_hz)
    n_nav = n_start
    variants: dict[str, _Variant] = {}
    for name, comp in comps.items():
        if config.align is not None:
            al = Aligner(tr.lat0, tr.lon0, tr.alt0, dt, config.align, config.vertical, k0=n_start)
            n_nav = n_start + al.n_total
            variants[name] = _Variant(comp, al, None, np.zeros(3), np.zeros(3), [])
        else:
            variants[name] = _Variant(
                comp, None, _true_initial_nav(config), np.zeros(3), np.zeros(3), []
            )
    out_every = config.out_every
    truth_rows: list[NDArray[np.float64]] = []

    splits = () if config.align is None else (n_start * dt, n_nav * dt)
    for ch in synth.chunks(config.duration_s, config.chunk_s, split_at=splits):
        t_mid = ch.t - 0.5 * dt
        raw_th = ch.dtheta
        raw_v = ch.dv
        if errors is not None:  # called on every chunk, in time order (state carries)
            e = np.asarray(errors(t_mid, ch.dtheta / dt, ch.dv / dt), dtype=float)
            if e.shape != (ch.n, 6):
                raise ConfigError(f"errors_r returned shape {e.shape}, expected ({ch.n}, 6)")
            raw_th = raw_th + e[:, :3] * dt
            raw_v = raw_v + e[:, 3:] * dt
        if recorder is not None:
            recorder(ch, raw_th, raw_v)
        if ch.k0 + ch.n <= n_start:  # warming up before the alignment: nobody navigates
            if progress is not None:
                progress(float(ch.t[-1]), config.duration_s)
            continue
        gidx = ch.k0 + np.arange(1, ch.n + 1)
        sel = (gidx % out_every == 0) & (gidx > n_nav)
        if np.any(sel):
            truth_rows.append(_truth_rows(ch, sel))
        raw_rate = raw_accel = None  # the raw signal the compensators see, once per chunk
        for v in variants.values():
            d_th, d_v = raw_th, raw_v
            if v.compensator is not None:
                if raw_rate is None:
                    raw_rate, raw_accel = raw_th / dt, raw_v / dt
                c = np.asarray(v.compensator(t_mid, raw_rate, raw_accel), dtype=float)
                d_th = d_th - c[:, :3] * dt
                d_v = d_v - c[:, 3:] * dt
            i0 = 0
            if v.aligner is not None and not v.aligner.done:
                i0 = feed_and_hand_over(v, d_th, d_v)
            if i0 < ch.n:
                assert v.nav is not None
                out = v.nav.run(
                    d_th[i0:] - v.gyro_bias * dt,
                    d_v[i0:] - v.accel_bias * dt,
                    alt_ref=ch.alt[i0:],
                    vu_ref=ch.v_n[i0:, 2],
                    out_every=out_every,
                )
                if out.shape[0]:
                    v.rows.append(out)
        if progress is not None:
            progress(float(ch.t[-1]), config.duration_s)

    truth = np.concatenate(truth_rows) if truth_rows else np.empty((0, 11))
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
    err: dict[str, pd.DataFrame] = {}
    for name, v in variants.items():
        rows = np.concatenate(v.rows) if v.rows else np.empty((0, 10))
        err[name] = _error_frame(truth, rows)
    alignment = {
        name: (v.aligner.result() if v.aligner is not None and v.aligner.done else None)
        for name, v in variants.items()
    }
    return NavResult(config, truth_df, err, alignment)


def _truth_rows(ch: ImuChunk, sel: NDArray[np.bool_]) -> NDArray[np.float64]:
    return np.column_stack(
        [
            ch.t[sel],
            ch.lat[sel],
            ch.lon[sel],
            ch.alt[sel],
            ch.v_n[sel],
            ch.euler[sel],
            ch.encoder[sel],
        ]
    )


def _error_frame(truth: NDArray[np.float64], ins: NDArray[np.float64]) -> pd.DataFrame:
    if ins.shape[0] != truth.shape[0]:
        raise AssertionError("internal: INS and truth rows differ")  # pragma: no cover
    lat_t, lon_t, alt_t = truth[:, 1], truth[:, 2], truth[:, 3]
    rn, re = earth.principal_radii(lat_t)
    north = (ins[:, 0] - lat_t) * (rn + alt_t)
    east = (ins[:, 1] - lon_t) * (re + alt_t) * np.cos(lat_t)
    horiz = np.hypot(east, north)
    C_true = C_nb_from_euler(truth[:, 7:10])
    C_est = quat_to_dcm(ins[:, 6:10]) @ np.swapaxes(C_br(truth[:, 10]), -1, -2)  # C_nr C_rb
    att = _attitude_error(C_true, C_est) if truth.shape[0] else np.empty((0, 3))
    eul = euler_from_C_nb(C_est) - truth[:, 7:10] if truth.shape[0] else np.empty((0, 3))
    eul = (eul + np.pi) % (2 * np.pi) - np.pi  # heading (and roll) wrap to ±π
    return pd.DataFrame(
        {
            "time_s": truth[:, 0],
            "east_m": east,
            "north_m": north,
            "horizontal_m": horiz,
            "horizontal_nmi": horiz / units.NMI_TO_M,
            "up_m": ins[:, 2] - alt_t,
            "lat_deg": ins[:, 0] / units.DEG_TO_RAD,
            "lon_deg": ins[:, 1] / units.DEG_TO_RAD,
            "v_e_err": ins[:, 3] - truth[:, 4],
            "v_n_err": ins[:, 4] - truth[:, 5],
            "att_e": att[:, 0],
            "att_n": att[:, 1],
            "att_u": att[:, 2],
            "heading_err": eul[:, 0],
            "pitch_err": eul[:, 1],
            "roll_err": eul[:, 2],
        }
    )


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
    "oracle_compensator",
    "preset",
    "run_scenario",
    "temperature_frame",
    "with_duration",
]

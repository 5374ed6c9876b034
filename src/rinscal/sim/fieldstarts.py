"""Parked cold starts, simulated: the runs a field calibration learns from.

A parked cold start: the RINS powers on at rest on a static base (the quasi-static
scenario's site), its body parked at a heading drawn uniformly per start with a small tilt
(pitch and roll each N(0, 0.5°)), the unit soaked at the ambient before power-on and the
ambient held there (optionally with a daily sinusoid about it), the turntable indexing
through the four positions (−135°, 45°, 135°, −45°) from power-on as the quasi-static
scenario's schedule does. Turn-on offsets and noise are drawn per start, independently.

The samples are made as a scenario's are (:func:`rinscal.sim.scenario.imu_samples`:
trajectory → ideal increments → plant errors) without navigating them, and streamed in the
recorded-navigation log's format (:func:`rinscal.sim.workflow.recording`) without any
``ref_*`` column; the metadata holds no ``heading_deg`` (a parked vehicle's heading is
unknown: the calibration must estimate it) and a ``field_start`` block.

The truth ``start_<k>.truth.parquet`` is on a 1 s grid, one row per sample ending at a whole
second ``time_s`` [s]:

``error_gyro_x … error_accel_z``
    the total equivalent error of that sample in ``r`` [rad/s, m/s²]: the thermal bias, the
    scale-factor and misalignment terms of the true signal
    (:meth:`rinscal.sim.sensors.ThermalPlant.thermal_errors`), the turn-on offsets, the bias
    random walk at that sample and the accelerometers' size effect (zero at rest); not the
    white noise, outliers, angle noise or the pulse quantisation. The recorded output of a
    sample is its true signal plus this error plus the noise.
``thermal_gyro_x … thermal_accel_z``
    the thermal part alone [rad/s, m/s²].
``heading_deg, pitch_deg, roll_deg``
    the body's attitude [deg] (constant over a start).
``table_deg``
    the encoder angle [deg], wrapped to ±180°, as the log's.
``static_gyro_x … static_accel_z``
    the total equivalent error *on the static base* [rad/s, m/s²], what a field calibration
    estimates (:mod:`rinscal.nav.fieldbias`): the errors of a *level* IMU's signal (gravity
    and the vertical Earth rate along z: thermal bias, the scale-factor and misalignment
    terms of those, turn-on offset, random walk). Left out: the gyros' part proportional to
    the table rate (``rate_error_* · φ̇``, a move's, not a bias) and the parts proportional
    to the horizontal signal of the body's tilt and heading (scale factor × ``g`` tilt),
    which turn with the table as a tilt or a heading error does and are one. Added to the
    horizontal accelerometers: ``−g k`` of the x and y gyros' misalignment towards the table
    axis ``k``, since each move tilts the platform by ``k Δφ`` and on one axis that tilt is
    exactly an accelerometer bias ``−g k`` (the two cannot be told apart).
``rate_error_gyro_x … rate_error_gyro_z``
    each gyro's error per unit of table rate [rad/rad] (z: scale-factor error; x, y:
    misalignment towards the table axis).
``temp_chamber``
    the ambient [°C].
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import _check, earth, units
from rinscal.errors import ConfigError
from rinscal.nav.rotation import RotationSchedule
from rinscal.presets import DEFAULT_PRESET
from rinscal.schema import CHANNELS
from rinscal.sim.config import ImuConfig, resolve_imu
from rinscal.sim.scenario import MAX_HOURS, MAX_RATE_HZ, daily_ambient, imu_samples
from rinscal.sim.scenario_config import ScenarioConfig
from rinscal.sim.sensors import ThermalPlant
from rinscal.sim.trajectory import StaticMotion
from rinscal.sim.workflow import recording, recording_meta

__all__ = [
    "DEFAULT_AMBIENTS_C",
    "TILT_SD_DEG",
    "FieldStart",
    "field_start_files",
    "field_starts",
    "simulate_field_start",
    "simulate_field_starts",
]

#: The ambients of :func:`simulate_field_starts` by default [°C].
DEFAULT_AMBIENTS_C = (0.0, 7.0, 14.0, 21.0, 28.0, 35.0, 42.0)
#: Standard deviation of a parked body's pitch and roll [deg].
TILT_SD_DEG = 0.5
#: Samples per chunk (bounded memory; large enough that per-chunk costs vanish) [s].
_CHUNK_S = 600.0


@dataclass(frozen=True)
class FieldStart:
    """One parked cold start.

    Parameters
    ----------
    index : int
        Its number ``k`` in the set (``start_<k>``).
    ambient_c : float [°C]
        The ambient, and the temperature the unit soaked at before power-on.
    daily_cycle_c : float [°C]
        Amplitude of the daily sinusoid about ``ambient_c`` (0: constant).
    hours : float [h]
        Length from power-on.
    rate_hz : float [Hz]
        IMU rate.
    seed : int
        The set's seed; the start's own draws come from ``(seed, index)``.
    heading_deg, pitch_deg, roll_deg : float [deg]
        The parked body's attitude.
    """

    index: int
    ambient_c: float
    daily_cycle_c: float
    hours: float
    rate_hz: float
    seed: int
    heading_deg: float
    pitch_deg: float
    roll_deg: float

    @property
    def plant_seed(self) -> int:
        """Seed of the start's plant (offsets, noise, thermometers), from ``(seed, index)``."""
        return int(np.random.SeedSequence((self.seed, self.index, 1)).generate_state(1)[0])

    def scenario(self) -> ScenarioConfig:
        """The start as a scenario: static at the quasi-static site, four positions, the
        ambient as chamber, no alignment."""
        duration = self.hours * units.HOUR_TO_S
        return ScenarioConfig(
            name="field-start",
            trajectory=StaticMotion(
                heading_deg=self.heading_deg, pitch_deg=self.pitch_deg, roll_deg=self.roll_deg
            ),
            schedule=RotationSchedule.four_position(),
            duration_s=duration,
            rate_hz=self.rate_hz,
            align=None,
            chamber=daily_ambient(self.ambient_c, self.daily_cycle_c, duration),
            chunk_s=_CHUNK_S,
        )

    def meta(self) -> dict[str, Any]:
        """The metadata's ``field_start`` block (no attitude: it is the truth's)."""
        return {
            "index": self.index,
            "ambient_c": self.ambient_c,
            "daily_cycle_c": self.daily_cycle_c,
            "hours": self.hours,
            "seed": self.seed,
        }


def _whole_rate(rate_hz: Any) -> float:
    rate_hz = _check.number("rate_hz", rate_hz, above=0.0, max=MAX_RATE_HZ, unit="Hz")
    if rate_hz < 1.0 or abs(rate_hz - round(rate_hz)) > 1e-9:
        raise ConfigError(
            f"rate_hz must be a whole number of Hz (the truth's 1 s grid is a whole number "
            f"of samples), got {rate_hz}"
        )
    return float(round(rate_hz))


def field_starts(
    runs: int = 7,
    ambient_c: Sequence[float] = DEFAULT_AMBIENTS_C,
    hours: float = 4.0,
    rate_hz: float = 100.0,
    seed: int = 0,
    daily_cycle_c: float = 0.0,
    season: tuple[float, float] | None = None,
) -> list[FieldStart]:
    """The starts of a set: run ``k`` at ``ambient_c[k % len(ambient_c)]`` [°C], or, with
    ``season`` (low, high) [°C], at an ambient drawn uniformly from it; headings uniform in
    [0°, 360°), pitch and roll N(0, :data:`TILT_SD_DEG`), all drawn from ``(seed, k)``.
    ``hours`` [h], ``rate_hz`` [Hz] (whole), ``daily_cycle_c`` [°C] as :class:`FieldStart`.
    """
    runs = _check.number("runs", runs, min=1, max=10000, integer=True)
    hours = _check.number("hours", hours, above=0.0, max=MAX_HOURS, unit="h")
    rate_hz = _whole_rate(rate_hz)
    seed = _check.number("seed", seed, min=0, integer=True)
    daily_cycle_c = _check.number("daily_cycle_c", daily_cycle_c, min=0.0, max=40.0, unit="°C")
    if season is None:
        ambients = _check.numbers_of("ambient_c", ambient_c)
        for a in ambients:
            _check.number("ambient_c", a, min=-60.0, max=100.0, unit="°C")
    else:
        low, high = _check.numbers_of("season", season, length=2)
        for a in (low, high):
            _check.number("season", a, min=-60.0, max=100.0, unit="°C")
        if not low < high:
            raise ConfigError(f"season: give (low, high) with low < high, got {season}")
    out = []
    for k in range(runs):
        rng = np.random.default_rng(np.random.SeedSequence((seed, k, 0)))
        heading = float(rng.uniform(0.0, 360.0))
        pitch, roll = (float(v) for v in rng.normal(0.0, TILT_SD_DEG, 2))
        if season is None:
            amb = float(ambients[k % len(ambients)])
        else:
            amb = float(round(rng.uniform(low, high), 3))
        out.append(FieldStart(k, amb, daily_cycle_c, hours, rate_hz, seed, heading, pitch, roll))
    return out


def field_start_files(out: str | os.PathLike[str], index: int) -> tuple[Path, Path, Path]:
    """The files of start ``index`` in ``out``: the log, its metadata, its truth."""
    # deferred: the I/O helpers only when writing
    from rinscal.io.metadata import meta_path, truth_path

    log = Path(out) / f"start_{index}.parquet"
    return log, meta_path(log), truth_path(log)


def simulate_field_start(
    start: FieldStart,
    out: str | os.PathLike[str],
    *,
    imu: str | os.PathLike[str] | ImuConfig = DEFAULT_PRESET,
    progress: Callable[[float, float], None] | None = None,
) -> Path:
    """Simulate one parked cold start into ``out/start_<k>.parquet`` with its metadata and
    truth (see the module docstring); returns the log's path.

    Parameters
    ----------
    start : FieldStart
        The start (:func:`field_starts`).
    out : str or PathLike
        An existing folder; none of the three files may exist.
    imu : str, PathLike or ImuConfig
        The plant: preset name, IMU TOML file or configuration. Its output mode decides the
        columns: rates (deg/h, µg) or, for a pulse-output IMU, counts with weights.
    progress : callable, optional
        ``progress(done_s, total_s)`` [s] after each chunk.
    """
    _check.instance("start", start, FieldStart, "a FieldStart")
    plant_cfg = resolve_imu(imu)
    log, meta_file, truth = field_start_files(out, start.index)
    for p in (log, meta_file, truth):
        if p.exists():
            raise ConfigError(f"{p} exists: field starts never overwrite a file")
    cfg = start.scenario()
    plant = ThermalPlant.for_scenario(plant_cfg, cfg, seed=start.plant_seed)
    per_s = round(cfg.rate_hz)
    dt = cfg.dt
    tr = cfg.trajectory
    g = float(earth.gravity(tr.lat0, tr.alt0))
    w_up = earth.RATE * math.sin(tr.lat0)
    rows: list[NDArray[np.float64]] = []
    with recording(log, plant, heading=False) as rec:
        for ch, dth, dv in imu_samples(cfg, plant):
            rec(ch, dth, dv)
            k = ch.k0 + 1 + np.arange(ch.n)
            sel = np.flatnonzero(k % per_s == 0)
            if sel.size:
                rows.append(_truth_rows(plant, ch, sel, dt, g, w_up))
            if progress is not None:
                progress(float(ch.t[-1]), cfg.duration_s)
    # deferred: the writers only when writing
    from rinscal.io.metadata import write_meta
    from rinscal.io.streaming import LogStreamWriter

    table = np.concatenate(rows) if rows else np.empty((0, 29))
    cols = ["time_s", *(f"error_{c}" for c in CHANNELS), *(f"thermal_{c}" for c in CHANNELS),
            "heading_deg", "pitch_deg", "roll_deg", "table_deg",
            *(f"static_{c}" for c in CHANNELS),
            *(f"rate_error_{c}" for c in CHANNELS[:3])]  # fmt: skip
    df = pd.DataFrame(table, columns=cols)
    df["temp_chamber"] = cfg.chamber(df["time_s"].to_numpy()) if cfg.chamber else np.nan
    with LogStreamWriter(truth, validate=False) as w:
        w.write(df)
    meta = recording_meta(
        cfg,
        plant,
        f"rinscal simulate field-starts --seed {start.seed} (start {start.index})",
        increments=False,
    )
    meta["field_start"] = start.meta()
    meta["truth_file"] = truth.name
    write_meta(meta, log)
    return log


def _truth_rows(
    plant: ThermalPlant, ch: Any, sel: NDArray[np.intp], dt: float, g: float, w_up: float
) -> NDArray[np.float64]:
    """The truth of the samples ``sel`` of a chunk just drawn by the plant (its cached
    thermal errors, offsets, random walk and size effect of those very samples); ``g`` the
    site's gravity [m/s²], ``w_up`` the vertical Earth rate there [rad/s]."""
    t_mid = ch.t - 0.5 * dt
    thermal = plant.oracle(t_mid, ch.dtheta / dt, ch.dv / dt)[sel]
    not_thermal = plant.offsets  # turn-on offsets and the bias random walk
    if plant.noise is not None and plant.noise.last_walk is not None:
        not_thermal = not_thermal + plant.noise.last_walk[sel]
    err = thermal + not_thermal
    if plant.last_size_effect is not None:
        err[:, 3:] += plant.last_size_effect[sel]
    table = (np.rad2deg(ch.encoder[sel]) + 180.0) % 360.0 - 180.0
    # each gyro's error per unit of table rate (z: scale factor; x, y: misalignment towards
    # the table axis), from the plant's own law at a small rate (its nonlinear terms aside)
    n = sel.size
    w = np.zeros((n, 3))
    w[:, 2] = _PROBE_RATE
    zero = np.zeros((n, 3))
    t_sel = t_mid[sel]
    k = (plant.thermal_errors(t_sel, w, zero) - plant.thermal_errors(t_sel, zero, zero))[:, :3]
    k /= _PROBE_RATE
    # on the static base: the errors of a level IMU's signal (gravity and the vertical
    # Earth rate along z; the parts proportional to the horizontal signal of the body's
    # tilt and heading turn with the table like a tilt or a heading error, and are one)
    level_w = np.zeros((n, 3))
    level_w[:, 2] = w_up
    level_f = np.zeros((n, 3))
    level_f[:, 2] = g
    static = plant.thermal_errors(t_sel, level_w, level_f) + not_thermal
    static[:, 3:5] -= g * k[:, :2]  # the tilt each move leaves, an accelerometer bias
    return np.column_stack([ch.t[sel], err, thermal, np.rad2deg(ch.euler[sel]), table, static, k])


#: Table rate at which the plant's error per unit of table rate is probed [rad/s].
_PROBE_RATE = 0.01


def simulate_field_starts(
    out: str | os.PathLike[str],
    runs: int = 7,
    ambient_c: Sequence[float] = DEFAULT_AMBIENTS_C,
    hours: float = 4.0,
    rate_hz: float = 100.0,
    imu: str | os.PathLike[str] | ImuConfig = DEFAULT_PRESET,
    seed: int = 0,
    daily_cycle_c: float = 0.0,
    season: tuple[float, float] | None = None,
    progress: Callable[[int, float, float], None] | None = None,
) -> list[Path]:
    """Simulate ``runs`` parked cold starts into ``out``: ``start_<k>.parquet``, its
    ``.meta.json`` and ``start_<k>.truth.parquet`` each, nothing else.

    Parameters
    ----------
    out : str or PathLike
        The folder (created if missing); none of the files may exist in it already.
    runs : int
        Number of starts.
    ambient_c : sequence of float [°C]
        Ambients, cycled over the runs (run ``k`` at ``ambient_c[k % len]``).
    hours : float [h]
        Length of each start from power-on.
    rate_hz : float [Hz]
        IMU rate (a whole number of Hz).
    imu : str, PathLike or ImuConfig
        The plant (default the paper's); the same unit for every start, each start with its
        own turn-on offsets and noise.
    seed : int
        Seed of every draw (start ``k`` draws from ``(seed, k)``).
    daily_cycle_c : float [°C]
        Amplitude of a daily sinusoid about each ambient (0: constant ambient).
    season : (float, float), optional [°C]
        Draw each ambient uniformly from (low, high) instead of ``ambient_c``.
    progress : callable, optional
        ``progress(k, done_s, total_s)`` after each chunk of start ``k``.

    Returns
    -------
    list of Path
        The logs written, in order.

    Examples
    --------
    >>> import rinscal
    >>> logs = rinscal.simulate_field_starts("fs", runs=7, hours=4.0)  # doctest: +SKIP
    """
    out = Path(_check.path_like("out", out))
    starts = field_starts(runs, ambient_c, hours, rate_hz, seed, daily_cycle_c, season)
    existing = [p for s in starts for p in field_start_files(out, s.index) if p.exists()]
    if existing:
        raise ConfigError(
            f"{existing[0]} exists ({len(existing)} of the files to write do): field starts "
            "never overwrite a file; give another folder"
        )
    plant_cfg = resolve_imu(imu)
    out.mkdir(parents=True, exist_ok=True)
    logs = []
    for s in starts:
        tick = None if progress is None else (lambda d, t, k=s.index: progress(k, d, t))
        logs.append(simulate_field_start(s, out, imu=plant_cfg, progress=tick))
    return logs

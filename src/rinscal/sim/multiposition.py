"""The multi-position and rate-table protocol: the IMU on a two-axis turntable in the thermal
chamber, simulated into a calibration log and the truth of its sensor-error parameters.

Why one module: the sequences, the turntable's commanded and actual motion, the plant along
that motion and the truth table are one protocol; split, each part would only be read
through the others (the motion's segments are what the truth averages over).

The turntable (:mod:`rinscal.turntable`): outer axis horizontal at the azimuth
``heading_deg`` of the configuration, inner axis = IMU z; the IMU's "up" components are
``x: −sin o·cos i``, ``y: sin o·sin i``, ``z: cos o`` for outer angle ``o``, inner ``i``.

Sequences (lists of ``(outer_deg, inner_deg)``):

- ``"12"``: each IMU axis up and down, each twice, 180° apart about the vertical (so the
  horizontal Earth rate reverses between the two): z up (0, 0), (0, 180); z down (180, 0),
  (180, 180); x up (−90, 0), (90, 180); x down (90, 0), (−90, 180); y up (90, 90),
  (−90, −90); y down (90, −90), (−90, 90). Every axis is horizontal in eight of them.
- ``"18"``: the 12 plus six 45° tilts, two in each plane of two axes: x–z (45, 0) (z up
  45°, x down 45°) and (−45, 0) (both up 45°); y–z (45, 90) and (−45, 90); x–y (90, 45)
  (y up, x down, 45°) and (90, 135) (both up 45°).
- ``"19"``: the 18 plus the body diagonal up, (−54.7356°, −45°): x, y and z each see g/√3.
  Each axis is up, down, horizontal, at 45° and at 54.7° from the vertical, so each
  accelerometer's bias, scale factor and quadratic term (three distinct |f|: g, g/√2,
  g/√3, besides 0) and every misalignment are observable.
- any sequence from a TOML file: ``positions = [[outer, inner], ...]`` [deg].

Rate tests: for each IMU axis, ±ω at each rate of ``rates_dps``: about z the inner axis
turns with the outer at 0 (z up); about x the outer axis turns with the inner at 90°; about
y the outer axis turns with the inner at 0. The steady part of each segment (its rows with
one constant commanded rate) lasts a whole number of revolutions: ``n·dt·|ω| = N·360°``
over its ``n`` samples (each sample is the mean over its interval), at least
:data:`RATE_SEGMENT_S`, so Earth rate and gravity perpendicular to the axis average to zero.
Two rates or more separate the asymmetry (∝ |u|) from the quadratic term (∝ u²).

The table moves between positions at up to :data:`SLEW_RATE_DPS` and
:data:`SLEW_ACCEL_DPS2` (a triangle in rate, both axes together, lasting an odd number of
samples so that no two neighbouring rows of a move share a commanded rate), and
accelerates into a rate segment at :data:`RATE_ACCEL_DPS2`; those rows are transitions.

Each set point is one power-on: the unit soaked at the chamber temperature is switched on at
``time_s = 0``, parked at the first position for ``warmup_s`` (not logged: the unit soaks
powered), then the sequence, then the rate tests. A cold start warms the unit for hours (the
housing's time constant is 2.5 h); after the default 10 h warm-up the true thermal bias
changes over the logged 34 min (19 positions of 60 s, rate tests at 10, 50, 200 deg/s, 10
Hz) by at most 1e-5 deg/h and 1.4 µg on the ``paper`` unit (its accelerometers' large
temperature and gradient terms) and 9e-5 deg/h and 0.12 µg on ``navigation_grade`` (peak to
peak over the logged part, worst channel and set point of 0, 12, 24, 36, 48 °C), against the
issue's tolerances of 0.005 deg/h and 10 µg; after 6 h it would still be 6.4 µg on ``paper``
(see ``docs/plant.md``). The turntable's
motors are not the unit's: the unit's thermal field is that of a powered, resting unit
(no encoder heat, no torque motor).

Ramp (``ramp=True``): one run ``cal_ramp``: warm-up at the first set point, then the chamber
ramps to the last at ``ramp_rate_c_per_min`` while the sequence and rate tests repeat
back to back until the ramp has ended.

Turntable errors (``turntable_error=True``; Table 2 of the paper: ±5′ angular position):
each stop (static position, rate-test orientation) is reached at actual axis angles off by
a uniform draw in ±``position_error_arcmin`` per axis, the error changing linearly over
each move; each rate segment's actual rate is off by a relative uniform draw in
±``rate_error_ppm``. Table 2 gives no rate figure; the default 10 ppm is the rate accuracy
averaged over a revolution that two-axis test tables of this class specify (1e-5 to
1e-6), the looser end, so that its effect on the gyro scale factor (5 ppm tolerance) shows.
The log holds the COMMANDED angles and rates; the plant feels the actual ones.

The plant: the true rate and specific force (:func:`rinscal.turntable.reference_r` at the
actual angles and rates) through :func:`rinscal.sensormodel.triad_forward` with every
parameter at the sample's channel temperature (:func:`rinscal.sim.sensor.sensor_law`),
the thermal bias of :func:`rinscal.sim.plant.thermal_bias_r` plus the turn-on offset as
its bias, white noise, bias random walk and outliers (:class:`SensorNoise`). A sample is its
interval's mean (sub-steps of at most 0.25° of table motion); pulses integrate it. In
physical units the output is after the factory calibration at ``t_cal_c``: the same model
with each parameter replaced by its change since ``t_cal_c``. The accelerometers sit at the
table's centre (no size effect on the calibration table).

Truth (:func:`truth_table`): per set point and each of the 33 parameters of
:data:`rinscal.sensormodel.PARAMETERS`, ``temperature_c`` the set point (for a ramp: the
mean chamber temperature of one repetition, rounded to 0.01 °C). Biases are the actual bias
averaged over the run's calibration samples (static and steady-rate rows): thermal bias +
turn-on offset + the mean of the bias random walk; the other parameters are the law at the
run's mean true channel temperature over those samples (in physical units: their change
since ``t_cal_c``).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import _check, turntable
from rinscal.errors import ConfigError
from rinscal.io.params import PARAMS_COLUMNS, check_params_table
from rinscal.schema import CHANNELS
from rinscal.sensormodel import PARAMETERS, ImuCalibration, triad_forward
from rinscal.sim.config import ImuConfig, resolve_imu
from rinscal.sim.field import ChamberProfile, measure, simulate_field
from rinscal.sim.plant import (
    SensorNoise,
    hysteresis_play,
    thermal_bias_r,
    to_log_units,
    turn_on_offsets,
)
from rinscal.sim.protocols import THERMAL_DT_S, Simulation, base_meta, run_name
from rinscal.sim.sensor import drift_law, sensor_law

__all__ = [
    "DEFAULT_DWELL_S",
    "DEFAULT_RATES_DPS",
    "DEFAULT_SET_POINTS_C",
    "DEFAULT_WARMUP_S",
    "SEQUENCES",
    "MultipositionRun",
    "iter_multiposition",
    "load_sequence",
    "simulate_multiposition",
    "truth_table",
]

_DIAG_O = -math.degrees(math.acos(1.0 / math.sqrt(3.0)))  # −54.7356°

#: Built-in position sequences, ``(outer_deg, inner_deg)`` (see the module docstring).
SEQUENCES: dict[str, tuple[tuple[float, float], ...]] = {
    "12": (
        (0.0, 0.0), (0.0, 180.0), (180.0, 0.0), (180.0, 180.0),
        (-90.0, 0.0), (90.0, 180.0), (90.0, 0.0), (-90.0, 180.0),
        (90.0, 90.0), (-90.0, -90.0), (90.0, -90.0), (-90.0, 90.0),
    ),
}  # fmt: skip
SEQUENCES["18"] = SEQUENCES["12"] + (
    (45.0, 0.0),
    (-45.0, 0.0),
    (45.0, 90.0),
    (-45.0, 90.0),
    (90.0, 45.0),
    (90.0, 135.0),
)
SEQUENCES["19"] = SEQUENCES["18"] + ((_DIAG_O, -45.0),)

#: Chamber set points of the default calibration [°C] (across the paper's −2..50 °C).
DEFAULT_SET_POINTS_C = (0.0, 12.0, 24.0, 36.0, 48.0)
#: Rate-test rates [deg/s]: three magnitudes, so asymmetry and quadratic term separate.
DEFAULT_RATES_DPS = (10.0, 50.0, 200.0)
#: Dwell at each static position [s]: 120 s puts the paper IMU's accelerometer bias
#: estimate at ~2.5 µg sd (its white noise is ~78 µg/√Hz), so the issue's 10 µg holds at every
#: set point with margin (60 s gave up to 8.8 µg over seeds 0 and 3).
DEFAULT_DWELL_S = 120.0
#: Powered warm-up before the logged part of a run [s] (see the module docstring).
DEFAULT_WARMUP_S = 10 * 3600.0
#: Default chamber ramp rate of ``ramp=True`` [°C/min].
DEFAULT_RAMP_RATE_C_PER_MIN = 0.1
#: Shortest steady part of a rate segment [s]; it is then rounded up to whole revolutions.
RATE_SEGMENT_S = 36.0
#: Longest steady part of a rate segment [s] (a rate too slow for a whole revolution in it,
#: or whose revolutions never fill whole samples, is refused).
RATE_SEGMENT_MAX_S = 3600.0
#: Highest slew rate between positions [deg/s] and its acceleration [deg/s²].
SLEW_RATE_DPS, SLEW_ACCEL_DPS2 = 20.0, 10.0
#: Acceleration into and out of a rate segment [deg/s²].
RATE_ACCEL_DPS2 = 50.0
#: Largest table motion within one sub-step of the interval mean [deg].
_SUBSTEP_DEG = 0.25
#: Row kinds.
TRANSITION, STATIC, RATE = 0, 1, 2
#: Orientation and turning axis (0 outer, 1 inner) of the rate test about IMU x, y, z.
_RATE_SETUP = (((0.0, 90.0), 0), ((0.0, 0.0), 0), ((0.0, 0.0), 1))
_TAG = 17  # seed tag of this protocol (the soak/ramp/repeat protocols use 0-2)


# --------------------------------------------------------------------------- sequences
def load_sequence(spec: str | Path | Sequence[Sequence[float]]) -> tuple[str, NDArray]:
    """A position sequence: a built-in name, a TOML file or explicit pairs.

    Parameters
    ----------
    spec : str, Path or sequence of (outer_deg, inner_deg)
        ``"12"``, ``"18"``, ``"19"``; a ``.toml`` file with ``positions = [[o, i], ...]``
        [deg]; or the pairs themselves.

    Returns
    -------
    name : str
        The built-in name, the file's path, or ``"custom"``.
    positions : ndarray, shape (k, 2) [deg]
    """
    if isinstance(spec, str) and spec in SEQUENCES:
        return spec, np.array(SEQUENCES[spec], dtype=float)
    if isinstance(spec, str | Path):
        path = Path(spec)
        if path.suffix.lower() != ".toml":
            raise ConfigError(
                f"sequence {str(spec)!r} is neither built in ({', '.join(SEQUENCES)}) nor a "
                ".toml file"
            )
        try:
            with path.open("rb") as fh:
                data = tomllib.load(fh)
        except FileNotFoundError:
            raise ConfigError(f"{path}: sequence file not found") from None
        except tomllib.TOMLDecodeError as e:
            raise ConfigError(f"{path}: not valid TOML: {e}") from None
        extra = set(data) - {"positions"}
        if extra:
            raise ConfigError(f"{path}: unknown key(s) {sorted(extra)}; expected 'positions'")
        if "positions" not in data:
            raise ConfigError(f"{path}: missing 'positions = [[outer_deg, inner_deg], ...]'")
        return str(path), _check_positions(data["positions"], str(path))
    if isinstance(spec, np.ndarray):
        spec = spec.tolist()
    return "custom", _check_positions(spec, "sequence")


def _check_positions(raw: object, source: str) -> NDArray:
    if not isinstance(raw, list | tuple) or len(raw) < 1:
        raise ConfigError(f"{source}: positions must be a non-empty list of [outer, inner]")
    out = []
    for k, entry in enumerate(raw):
        ok = isinstance(entry, list | tuple) and len(entry) == 2
        vals = []
        if ok:
            for v in entry:
                if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                    ok = False
                else:
                    vals.append(float(v))
        if not ok or any(abs(v) > 360.0 for v in vals):
            raise ConfigError(
                f"{source}: positions entry {k + 1} ({entry!r}) must be [outer_deg, inner_deg], "
                "two finite angles within ±360°"
            )
        out.append(vals)
    return np.array(out, dtype=float)


# --------------------------------------------------------------------------- motion
@dataclass
class _Motion:
    """Piecewise constant-acceleration motion of both axes: knot times [s] and, per knot
    and axis, angle [deg], rate [deg/s], acceleration [deg/s²]; commanded and actual."""

    t: list[float]
    cmd: list[NDArray]  # each (2, 3): axis × (angle, rate, acc)
    act: list[NDArray]

    def evaluate(self, times: NDArray, actual: bool) -> tuple[NDArray, NDArray]:
        """Angles and rates at ``times``: shape (n, 2) each [deg, deg/s]."""
        tk = np.asarray(self.t)
        k = np.clip(np.searchsorted(tk, times, side="right") - 1, 0, tk.size - 1)
        tab = np.asarray(self.act if actual else self.cmd)[k]  # (n, 2, 3)
        tau = (times - tk[k])[:, None]
        ang = tab[..., 0] + tab[..., 1] * tau + 0.5 * tab[..., 2] * tau * tau
        rate = tab[..., 1] + tab[..., 2] * tau
        return ang, rate


class _Builder:
    """Lays out one run's motion sample by sample (every row group a whole number of
    samples) with its commanded and actual knots and the kind of each row."""

    def __init__(self, start: NDArray, err: NDArray, dt: float) -> None:
        self.dt = dt
        self.n = 0  # samples so far
        self.ang = start.astype(float).copy()  # commanded angles now
        self.err = err.astype(float).copy()  # actual − commanded now
        self.motion = _Motion([], [], [])
        self.kind: list[NDArray] = []
        self.segment: list[NDArray] = []
        self.n_segments = 0

    def _knot(self, t: float, rate: NDArray, acc: NDArray, eps: NDArray, edot: NDArray) -> None:
        cmd = np.stack([self.ang, rate, acc], axis=1)
        act = np.stack([self.ang + self.err, rate * (1 + eps) + edot, acc * (1 + eps)], axis=1)
        self.motion.t.append(t)
        self.motion.cmd.append(cmd)
        self.motion.act.append(act)

    def _advance(
        self, dur: float, rate: NDArray, acc: NDArray, eps: NDArray, edot: NDArray
    ) -> None:
        d = rate * dur + 0.5 * acc * dur * dur
        self.ang = self.ang + d
        self.err = self.err + eps * d + edot * dur

    def _rows(self, n: int, kind: int) -> None:
        self.kind.append(np.full(n, kind, dtype=np.int8))
        self.segment.append(np.full(n, self.n_segments, dtype=np.int32))
        self.n_segments += 1
        self.n += n

    def hold(self, n: int) -> None:
        z = np.zeros(2)
        self._knot(self.n * self.dt, z, z, z, z)
        self._rows(n, STATIC)

    def move(self, target: NDArray, err_target: NDArray) -> None:
        """Slew both axes to ``target`` [deg] (the nearest equivalent angle) with a triangle
        in rate (accelerate, then decelerate, both axes together), lasting an odd number of
        samples: no two neighbouring rows share a rate, so no slew looks like a rate
        segment, and the move never depends on the turntable's errors."""
        d = target - self.ang
        d = d - 360.0 * np.round(d / 360.0)
        dist = float(np.max(np.abs(d)))
        if dist < 1e-9:
            self.err = err_target.astype(float).copy()
            return
        need = max(2.0 * dist / SLEW_RATE_DPS, 2.0 * math.sqrt(dist / SLEW_ACCEL_DPS2))
        n = max(3, math.ceil(need / self.dt - 1e-9))
        n += 1 - n % 2
        big_t = n * self.dt
        half = big_t / 2.0
        a = d / (half * half)
        edot = (err_target - self.err) / big_t
        t0 = self.n * self.dt
        z = np.zeros(2)
        for start, rate, acc in ((0.0, z, a), (half, a * half, -a)):
            self._knot(t0 + start, rate, acc, z, edot)
            self._advance(half, rate, acc, z, edot)
        self.ang = target + np.round((self.ang - target) / 360.0) * 360.0  # exact
        self.err = err_target.astype(float).copy()
        self._rows(n, TRANSITION)

    def spin(self, axis: int, rate_dps: float, eps: float) -> tuple[int, int]:
        """Accelerate ``axis`` to ``rate_dps``, hold it a whole number of revolutions,
        decelerate to rest; returns (samples, revolutions) of the steady part."""
        n_acc = max(1, math.ceil(abs(rate_dps) / RATE_ACCEL_DPS2 / self.dt - 1e-9))
        t_acc = n_acc * self.dt
        n_steady, revs = _whole_revolutions(abs(rate_dps), self.dt)
        e = np.zeros(2)
        e[axis] = eps
        r = np.zeros(2)
        r[axis] = rate_dps
        a = r / t_acc
        z = np.zeros(2)
        for n, rate, acc, kind in ((n_acc, z, a, TRANSITION), (n_steady, r, z, RATE),
                                   (n_acc, r, -a, TRANSITION)):  # fmt: skip
            self._knot(self.n * self.dt, rate, acc, e, z)
            self._advance(n * self.dt, rate, acc, e, z)
            self._rows(n, kind)
        return n_steady, revs


def _whole_revolutions(rate_dps: float, dt: float) -> tuple[int, int]:
    """Samples ``n`` and revolutions ``N`` with ``n·dt·rate = N·360°`` exactly (to 1e-9 of a
    sample), ``n·dt >=`` :data:`RATE_SEGMENT_S`."""
    per_rev = 360.0 / (rate_dps * dt)  # samples per revolution
    first = max(1, math.ceil(RATE_SEGMENT_S * rate_dps / 360.0 - 1e-9))
    revs = first
    while revs * per_rev * dt <= RATE_SEGMENT_MAX_S:
        n = revs * per_rev
        if abs(n - round(n)) < 1e-6:
            return round(n), revs
        revs += 1
    raise ConfigError(
        f"rate {rate_dps:g} deg/s at {1 / dt:g} Hz: no whole number of revolutions fills a "
        f"whole number of samples within {RATE_SEGMENT_MAX_S:g} s; choose a rate such that "
        "360·rate_hz/rate is a whole number or a simple fraction"
    )


# --------------------------------------------------------------------------- one run
@dataclass
class MultipositionRun:
    """One simulated power-on of the multi-position protocol.

    Attributes
    ----------
    name : str
        Run name (``cal_+12C``, ``cal_ramp``).
    log : pandas.DataFrame
        Canonical log rows with the turntable columns (commanded values).
    truth : pandas.DataFrame
        Parameter-table rows (:data:`rinscal.io.params.PARAMS_COLUMNS`) of this run.
    kind : ndarray, shape (n,) of int8
        Row kind: 0 transition, 1 static, 2 steady rate.
    errors : dict
        The turntable's drawn errors: ``position_arcmin`` (k, 2) per stop and
        ``rate_ppm`` per rate segment (zeros on an ideal table).
    repetitions : list of dict
        Ramp only: ``start_s``, ``end_s``, ``temperature_c`` of each repetition.
    memory : ndarray, shape (6,) [°C]
        Hysteresis state at the end of the run.
    """

    name: str
    log: pd.DataFrame
    truth: pd.DataFrame
    kind: NDArray[np.int8]
    errors: dict[str, NDArray]
    repetitions: list[dict[str, float]]
    memory: NDArray[np.float64]


def _layout(
    positions: NDArray,
    rates: Sequence[float],
    dwell_n: int,
    dt: float,
    repeats: int | None,
    until_s: float,
    rng: np.random.Generator,
    pos_err_deg: float,
    rate_err: float,
) -> tuple[_Builder, list[tuple[int, int]], dict[str, NDArray]]:
    """Lay out the motion of one run; returns the builder, the sample ranges of each
    repetition and the drawn turntable errors."""

    def draw_pos() -> NDArray:
        return rng.uniform(-pos_err_deg, pos_err_deg, 2)

    errs: list[NDArray] = []
    rate_errs: list[float] = []
    first = draw_pos()
    errs.append(first)
    b = _Builder(positions[0], first, dt)
    reps: list[tuple[int, int]] = []
    k = 0
    while True:
        start = b.n
        for j, pos in enumerate(positions):
            if not (k == 0 and j == 0):
                e = draw_pos()
                errs.append(e)
                b.move(pos, e)
            b.hold(dwell_n)
        for (orient, axis_turning), _ in zip(_RATE_SETUP, range(3), strict=True):
            e = draw_pos()
            errs.append(e)
            b.move(np.asarray(orient, dtype=float), e)
            for w in rates:
                for sign in (1.0, -1.0):
                    eps = float(rng.uniform(-rate_err, rate_err))
                    rate_errs.append(eps)
                    b.spin(axis_turning, sign * w, eps)
        reps.append((start, b.n))
        k += 1
        if repeats is not None and k >= repeats:
            break
        if repeats is None and b.n * dt >= until_s:
            break
    return (
        b,
        reps,
        {
            "position_arcmin": np.array(errs) * 60.0,
            "rate_ppm": np.array(rate_errs) * 1e6,
        },
    )


def _simulate_run(
    name: str,
    profile: ChamberProfile,
    config: ImuConfig,
    law: ImuCalibration,
    positions: NDArray,
    rates: Sequence[float],
    dwell_s: float,
    warmup_s: float,
    rate_hz: float,
    seed_seq: np.random.SeedSequence,
    ramp_until_s: float | None,
    pos_err_arcmin: float,
    rate_err_ppm: float,
    memory: NDArray | None,
    set_point_c: float | None,
) -> MultipositionRun:
    dt = 1.0 / rate_hz
    rng_table, rng_noise, rng_temp = (np.random.default_rng(s) for s in seed_seq.spawn(3))
    dwell_n = max(1, round(dwell_s * rate_hz))
    b, reps, errors = _layout(
        positions,
        rates,
        dwell_n,
        dt,
        None if ramp_until_s is not None else 1,
        0.0 if ramp_until_s is None else ramp_until_s - warmup_s,
        rng_table,
        pos_err_arcmin / 60.0,
        rate_err_ppm * 1e-6,
    )
    kind = np.concatenate(b.kind)
    n = kind.size
    t_rel = (np.arange(n) + 1.0) * dt  # ends of the intervals, from the log's start
    t_begin = np.arange(n) * dt  # their starts, as the knots' times are written
    t = warmup_s + t_rel
    motion = b.motion
    # commanded: angles at the interval's end; rates: the interval's mean
    ang_end, _ = motion.evaluate(t_rel, actual=False)
    ang_start, _ = motion.evaluate(t_begin, actual=False)
    rate_cmd = (ang_end - ang_start) / dt
    rate_cmd[kind == STATIC] = 0.0
    ang_end[kind == STATIC] = ang_start[kind == STATIC]
    steady = kind == RATE
    if np.any(steady):
        tk = np.asarray(motion.t)
        k = np.searchsorted(tk, t_begin[steady] + 0.5 * dt, side="right") - 1
        rate_cmd[steady] = np.asarray(motion.cmd)[k][:, :, 1]
    # sub-steps: the actual motion through each interval
    step = np.max(np.abs(ang_end - ang_start), axis=1)
    m = np.where(kind == STATIC, 1, np.maximum(4, np.ceil(step / _SUBSTEP_DEG))).astype(int)
    first = np.concatenate([[0], np.cumsum(m)[:-1]])
    owner = np.repeat(np.arange(n), m)
    frac = (np.arange(owner.size) - first[owner] + 0.5) / m[owner]
    t_sub = t_begin[owner] + frac * dt
    ang_act, rate_act = motion.evaluate(t_sub, actual=True)
    omega_r, f_r = turntable.reference_r(
        ang_act[:, 0],
        ang_act[:, 1],
        config.latitude,
        config.heading,
        config.altitude_m,
        rate_act[:, 0],
        rate_act[:, 1],
    )
    # the thermal field from power-on; the bias at each interval's middle
    coarse = simulate_field(profile, config.thermal_network(), t[-1], THERMAL_DT_S)
    play = hysteresis_play(coarse, config, memory)
    t_mid = t - 0.5 * dt
    bias_coarse = thermal_bias_r(coarse, config, play)
    thermal = np.stack([np.interp(t_mid, coarse.t, bias_coarse[:, j]) for j in range(6)], 1)
    temp_mid = np.stack([np.interp(t_mid, coarse.t, coarse.sensor[:, j]) for j in range(6)], 1)
    offset = turn_on_offsets(config, rng_noise)
    bias = thermal + offset
    gyro, accel = law.triads(temp_mid)
    y_sub = np.concatenate(
        [
            triad_forward(omega_r, _rows_of(gyro, owner)),
            triad_forward(f_r, _rows_of(accel, owner)),
        ],
        axis=1,
    )
    y = np.add.reduceat(y_sub, first, axis=0) / m[:, None] + bias
    quiet = replace(config.noise, gyro_bias_rw_dph_rth=0.0, accel_bias_rw_ug_rth=0.0)
    walk_only = replace(
        config.noise, gyro_arw_deg_rth=0.0, accel_vrw_ug_rthz=0.0, outlier_rate_hz=0.0
    )
    white, _ = SensorNoise(replace(config, noise=quiet), rng_noise, dt).draw(n)
    walk, _ = SensorNoise(replace(config, noise=walk_only), rng_noise, dt).draw(n)
    y += white
    y += walk
    out, _ = to_log_units(y, config, dt)
    cols: dict[str, object] = {
        "time_s": t,
        "run": pd.Categorical.from_codes(np.zeros(n, dtype=np.int8), categories=[name]),
    }
    for j, ch in enumerate(CHANNELS):
        cols[ch] = np.ascontiguousarray(out[:, j])
    for j, ch in enumerate(CHANNELS):
        cols[f"temp_{ch}"] = measure(
            np.interp(t, coarse.t, coarse.sensor[:, j]), config.thermometer, rng_temp
        )
    cols["temp_out"] = measure(np.interp(t, coarse.t, coarse.outer), config.thermometer, rng_temp)
    cols["chamber_temp"] = profile(t)
    cols["table_outer_deg"] = ang_end[:, 0] + 0.0
    cols["table_inner_deg"] = ang_end[:, 1] + 0.0
    cols["table_outer_rate_dps"] = rate_cmd[:, 0] + 0.0
    cols["table_inner_rate_dps"] = rate_cmd[:, 1] + 0.0
    log = pd.DataFrame(cols, copy=False)
    # truth: per repetition (one for a soak run), over its calibration samples
    actual_bias = bias + walk
    blocks = []
    repetitions = []
    chamber = profile(t)
    for a, z in reps:
        sel = np.zeros(n, dtype=bool)
        sel[a:z] = True
        sel &= kind != TRANSITION
        if set_point_c is None:
            temp_c = round(float(chamber[sel].mean()), 2)
            repetitions.append(
                {"start_s": float(t[a] - dt), "end_s": float(t[z - 1]), "temperature_c": temp_c}
            )
        else:
            temp_c = float(set_point_c)
        blocks.append(
            truth_table(law, temp_mid[sel].mean(axis=0), actual_bias[sel].mean(axis=0), temp_c)
        )
    return MultipositionRun(
        name=name,
        log=log,
        truth=pd.concat(blocks, ignore_index=True),
        kind=kind,
        errors=errors,
        repetitions=repetitions,
        memory=play[-1].copy(),
    )


def _rows_of(e: object, owner: NDArray) -> object:
    """Per-sample :class:`TriadErrors` repeated onto the sub-steps."""
    return replace(
        e,  # type: ignore[type-var]
        **{k: getattr(e, k)[owner] for k in ("bias", "sf", "asym", "quad", "mis")},
    )


def truth_table(
    law: ImuCalibration,
    temp_c: NDArray[np.float64],
    bias_si: NDArray[np.float64],
    temperature_c: float,
) -> pd.DataFrame:
    """The 33 parameters at one set point as parameter-table rows.

    Parameters
    ----------
    law : ImuCalibration
        The plant's laws (biases excluded).
    temp_c : ndarray, shape (6,) [°C]
        Mean true temperature of each channel over the calibration samples.
    bias_si : ndarray, shape (6,) [rad/s, m/s²]
        Mean actual bias of each channel over those samples.
    temperature_c : float [°C]
        The set point written in ``temperature_c``.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`rinscal.io.params.PARAMS_COLUMNS`, one row per parameter, sd 0.
    """
    rows = []
    for p in PARAMETERS:
        if p.kind == "bias":
            v = bias_si[p.channel] / p.to_si
        else:
            v = float(law.value(p.name, temp_c[p.channel]))
        rows.append((float(temperature_c), p.name, float(v), 0.0, p.unit))
    return pd.DataFrame(rows, columns=list(PARAMS_COLUMNS))


# --------------------------------------------------------------------------- protocol
def iter_multiposition(
    config: ImuConfig,
    *,
    sequence: str | Path | Sequence[Sequence[float]] = "19",
    set_points_c: Sequence[float] = DEFAULT_SET_POINTS_C,
    rates_dps: Sequence[float] = DEFAULT_RATES_DPS,
    dwell_s: float = DEFAULT_DWELL_S,
    ramp: bool = False,
    ramp_rate_c_per_min: float = DEFAULT_RAMP_RATE_C_PER_MIN,
    warmup_s: float = DEFAULT_WARMUP_S,
    turntable_error: bool = False,
    position_error_arcmin: float = 5.0,
    rate_error_ppm: float = 10.0,
    rate_hz: float = 10.0,
    seed: int = 0,
) -> Iterator[MultipositionRun]:
    """Simulate the protocol one run at a time (bounded memory); arguments as
    :func:`simulate_multiposition`. The hysteresis memory is carried from run to run."""
    _, positions = load_sequence(sequence)
    _check_args(set_points_c, rates_dps, dwell_s, warmup_s, rate_hz, ramp, ramp_rate_c_per_min,
                position_error_arcmin, rate_error_ppm)  # fmt: skip
    law = sensor_law(config) if config.output.mode == "pulses" else drift_law(config)
    pe = position_error_arcmin if turntable_error else 0.0
    re = rate_error_ppm if turntable_error else 0.0
    memory = None
    if ramp:
        lo, hi = float(set_points_c[0]), float(set_points_c[-1])
        profile = ChamberProfile.ramp(lo, hi, ramp_rate_c_per_min, hold_before_s=warmup_s)
        ss = np.random.SeedSequence([int(seed), _TAG, 0])
        until = profile.times_s[-1]
        yield _simulate_run("cal_ramp", profile, config, law, positions, rates_dps, dwell_s,
                            warmup_s, rate_hz, ss, until, pe, re, None, None)  # fmt: skip
        return
    for k, c in enumerate(set_points_c):
        ss = np.random.SeedSequence([int(seed), _TAG, k])
        run = _simulate_run(run_name("cal", c), ChamberProfile.constant(c), config, law,
                            positions, rates_dps, dwell_s, warmup_s, rate_hz, ss, None, pe, re,
                            memory, float(c))  # fmt: skip
        memory = run.memory
        yield run


def _check_args(
    set_points_c: Sequence[float],
    rates_dps: Sequence[float],
    dwell_s: float,
    warmup_s: float,
    rate_hz: float,
    ramp: bool,
    ramp_rate: float,
    pe: float,
    re: float,
) -> None:
    def finite(name: str, v: float, low: float, strict: bool = True) -> None:
        ok = math.isfinite(v) and (v > low if strict else v >= low)
        if not ok:
            raise ConfigError(f"{name} must be {'>' if strict else '>='} {low:g}, got {v}")

    if len(set_points_c) < 1 or (ramp and len(set_points_c) < 2):
        raise ConfigError("set_points_c: need at least one set point (two for a ramp)")
    for c in set_points_c:
        finite("set_points_c: a set point [°C]", float(c), -70.0)
        if c > 150:
            raise ConfigError(f"set point {c} °C outside the chamber range -70..150 °C")
    if len({run_name("cal", c) for c in set_points_c}) != len(set_points_c):
        raise ConfigError(f"set_points_c {list(set_points_c)}: two round to the same °C")
    for w in rates_dps:
        finite("rates_dps=: a rate test's rate [deg/s]", float(w), 0.0)
    finite("dwell_s", dwell_s, 0.0)
    finite("warmup_s", warmup_s, 0.0, strict=False)
    finite("rate_hz", rate_hz, 0.0)
    finite("ramp_rate_c_per_min", ramp_rate, 0.0)
    finite("position_error_arcmin", pe, 0.0, strict=False)
    finite("rate_error_ppm", re, 0.0, strict=False)


def simulate_multiposition(
    imu: str | os.PathLike[str] | ImuConfig | None = None,
    *,
    config: str | os.PathLike[str] | ImuConfig | None = None,
    sequence: str | Path | Sequence[Sequence[float]] = "19",
    set_points_c: Sequence[float] = DEFAULT_SET_POINTS_C,
    rates_dps: Sequence[float] = DEFAULT_RATES_DPS,
    dwell_s: float = DEFAULT_DWELL_S,
    ramp: bool = False,
    ramp_rate_c_per_min: float = DEFAULT_RAMP_RATE_C_PER_MIN,
    warmup_s: float = DEFAULT_WARMUP_S,
    turntable_error: bool = False,
    position_error_arcmin: float = 5.0,
    rate_error_ppm: float = 10.0,
    rate_hz: float = 10.0,
    seed: int = 0,
) -> Simulation:
    """Simulate a multi-position and rate-table calibration on a two-axis turntable.

    Parameters
    ----------
    imu : str, PathLike or ImuConfig, optional
        The plant (a preset name, an IMU TOML file or a configuration; default the paper's
        own, ``paper``); its ``output.mode`` chooses pulses (raw) or physical units.
    config : str, PathLike or ImuConfig, optional
        The older spelling of ``imu`` (give one of them).
    sequence : str, Path or sequence of (outer_deg, inner_deg)
        ``"12"``, ``"18"``, ``"19"``, a TOML file or the positions [deg].
    set_points_c : sequence of float [°C]
        Chamber set points, one power-on run each; for a ramp its start and end.
    rates_dps : sequence of float [deg/s]
        Rate-test magnitudes; each is run +ω and −ω about every IMU axis.
    dwell_s : float [s]
        Dwell at each static position.
    ramp : bool
        One run along a chamber ramp instead of soaks.
    ramp_rate_c_per_min : float [°C/min]
        Chamber rate of the ramp.
    warmup_s : float [s]
        Powered warm-up before the logged part of each run.
    turntable_error : bool
        Draw the turntable's position and rate errors.
    position_error_arcmin : float [arcmin]
        Half-width of the uniform position error per axis and stop (Table 2: 5′).
    rate_error_ppm : float [ppm]
        Half-width of the uniform relative rate error per rate segment.
    rate_hz : float [Hz]
        Sample rate.
    seed : int
        Seed of every random number (run ``k`` draws from ``(seed, protocol, k)``).

    Returns
    -------
    Simulation
        Unpacks as ``log, truth, meta``:
    log : pandas.DataFrame
        The canonical log with the turntable columns, runs stacked.
    truth : pandas.DataFrame
        The parameter table of the truth (one row per set point × parameter).
    meta : dict
        Sidecar metadata (the log contract's keys).
    """
    numeric = {
        "dwell_s": dwell_s,
        "warmup_s": warmup_s,
        "rate_hz": rate_hz,
        "ramp_rate_c_per_min": ramp_rate_c_per_min,
        "rate_error_ppm": rate_error_ppm,
        "position_error_arcmin": position_error_arcmin,
    }
    for name, v in numeric.items():
        _check.number(name, v)  # the types here, the ranges in _check_args
    _check.number("seed", seed, min=0, integer=True)
    _check.numbers_of("set_points_c", set_points_c)
    _check.numbers_of("rates_dps", rates_dps, nonempty=False)
    _check.flag("ramp", ramp)
    _check.flag("turntable_error", turntable_error)
    config = resolve_imu(imu, config)
    runs = []
    for run in iter_multiposition(
        config,
        sequence=sequence,
        set_points_c=set_points_c,
        rates_dps=rates_dps,
        dwell_s=dwell_s,
        ramp=ramp,
        ramp_rate_c_per_min=ramp_rate_c_per_min,
        warmup_s=warmup_s,
        turntable_error=turntable_error,
        position_error_arcmin=position_error_arcmin,
        rate_error_ppm=rate_error_ppm,
        rate_hz=rate_hz,
        seed=seed,
    ):
        runs.append(run)
    log = pd.concat([r.log for r in runs], ignore_index=True)
    log["run"] = log["run"].astype(str)
    truth = check_params_table(
        pd.concat([r.truth for r in runs], ignore_index=True), "multiposition truth"
    )
    name, positions = load_sequence(sequence)
    meta = multiposition_meta(
        config,
        sequence=name,
        positions=positions,
        set_points_c=() if ramp else set_points_c,
        rates_dps=rates_dps,
        dwell_s=dwell_s,
        warmup_s=warmup_s,
        turntable_error=turntable_error,
        position_error_arcmin=position_error_arcmin,
        rate_error_ppm=rate_error_ppm,
        rate_hz=rate_hz,
        seed=seed,
        runs=runs,
    )
    return Simulation(log, truth, meta)


def multiposition_meta(
    config: ImuConfig,
    *,
    sequence: str,
    positions: NDArray,
    set_points_c: Sequence[float],
    rates_dps: Sequence[float],
    dwell_s: float,
    warmup_s: float,
    turntable_error: bool,
    position_error_arcmin: float,
    rate_error_ppm: float,
    rate_hz: float,
    seed: int,
    runs: Sequence[MultipositionRun],
) -> dict[str, object]:
    """The sidecar metadata of a multi-position log (see the log contract in the module
    docstring of :mod:`rinscal.sim.multiposition`)."""
    meta: dict[str, object] = {
        **base_meta("multiposition", config, rate_hz, seed),
        "set_points_c": {run_name("cal", c): float(c) for c in set_points_c},
        "sequence": sequence,
        "positions_deg": positions.tolist(),
        "rates_dps": [float(w) for w in rates_dps],
        "dwell_s": float(dwell_s),
        "warmup_s": float(warmup_s),
        "turntable": {
            "position_error_arcmin": float(position_error_arcmin) if turntable_error else 0.0,
            "rate_error_ppm": float(rate_error_ppm) if turntable_error else 0.0,
            "ideal": not turntable_error,
        },
    }
    reps = [dict(r, run=run.name) for run in runs for r in run.repetitions]
    if reps:
        meta["repetitions"] = reps
    return meta

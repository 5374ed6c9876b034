"""Navigate a recording: alignment window, causal compensation, free navigation.

The recording arrives as :class:`rinscal.schema.NavSamples` pieces (SI increments in the
IMU frame r, read by :mod:`rinscal.io.navopen`); nothing here reads a file. Two passes over the
pieces:

1. :class:`BlockStats` sums every second of the recording: the specific force magnitude
   ``|f|`` (its mean and spread), the mean rate and force vectors, the spread of first
   differences (white noise) and the encoder's turn. From these :func:`find_window` finds
   the alignment window, :func:`estimate_noise` the filter's sensor noise if nobody gave
   it, :func:`check_at_rest` whether the units are plausible and :func:`seen_schedule`
   what the turntable did.
2. :func:`navigate_recording` runs the variants (uncompensated, one per model) side by
   side: every variant's compensator sees every sample from the first on (its temperature
   history is causal), the aligner the window, the strapdown everything after it.

What "quiet" means. The inertial-frame coarse alignment and the zero-velocity filter need
the IMU's *centre* at rest; angular motion (the turntable turning, a base swinging about
the IMU) is allowed, since the gyros follow it. So a second of data is quiet when ``|f|``
is steady (rotation about the centre leaves it at g): its spread within the second is at
most :data:`QUIET_FACTOR` × the recording's floor (the 10th percentile of every second's
spread, i.e. the sensor noise where at least a tenth of the recording is at rest) and its
mean moved by no more than that from the previous second. People walking around a vehicle
shake the IMU's centre by millimetres at a few hertz, milli-g of acceleration, which this
sees; a smooth constant acceleration it would not (a vehicle never drives that smoothly).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import earth, units
from rinscal.errors import ConfigError, LogError
from rinscal.nav.align import AlignConfig, Aligner, AlignResult, feed_and_hand_over
from rinscal.nav.strapdown import Strapdown, VerticalMode
from rinscal.schema import CHANNELS, GAP_FACTOR, NavSamples

#: Length of the blocks the first pass sums over [s].
BLOCK_S = 1.0
#: A block is quiet when the spread of ``|f|`` within it is at most this many times the floor.
QUIET_FACTOR = 3.0
#: Shortest stretch the window finder accepts [s] (the issue's "at least 300 s").
MIN_WINDOW_S = 300.0
#: Percentile of the per-second spread of ``|f|`` taken as the noise floor.
FLOOR_PERCENTILE = 10.0
#: An encoder step in one sample that differs from the gyro's turn about z by more than
#: this [deg] (or than this rate [deg/s] times the interval, if larger) is a jump.
ENCODER_JUMP_DEG = 5.0
ENCODER_JUMP_DPS = 200.0
#: The latitude the gyros measure at rest may differ from the site's by this much [deg]
#: before the site is questioned (a 0.1 °/h gyro bias moves it by about 0.4°).
LATITUDE_TOL_DEG = 2.0


# --------------------------------------------------------------------------- recording
def recording_frame(
    chunk: Any,
    dtheta: NDArray[np.float64],
    dv: NDArray[np.float64],
    *,
    increments: bool = False,
    readings: tuple[NDArray, NDArray, NDArray] | None = None,
    track: bool = False,
) -> pd.DataFrame:
    """The raw recording of a simulated chunk, in the recorded-navigation log's columns.

    Parameters
    ----------
    chunk : rinscal.nav.imu.ImuChunk
        Truth of the chunk (times, encoder, position, attitude).
    dtheta, dv : ndarray, shape (n, 3) [rad, m/s]
        The IMU's raw increments (errors included).
    increments : bool
        Write ``dtheta_*`` [rad] and ``dvel_*`` [m/s]; else mean rates over each interval
        ``gyro_*`` [deg/h] and ``accel_*`` [µg].
    readings : (grid, inner, outer), optional
        Thermometer readings [s, °C (m, 6), °C (m,)]: each sample carries the last reading
        taken at or before the middle of its interval (what a navigation computer logs).
    track : bool
        Write the true position as ``ref_lat_deg, ref_lon_deg, ref_h_m`` (a moving carrier).

    Returns
    -------
    DataFrame
        ``time_s`` (end of each interval), the IMU, ``table_deg`` (wrapped to ±180°),
        temperatures, the reference track and ``ref_heading_deg`` (true body heading).
    """
    from rinscal.schema import DTHETA, DVEL, REF_HEADING, REF_TRACK, TABLE, TEMP_OUT

    t = chunk.t
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 1.0))
    cols: dict[str, Any] = {"time_s": t}
    if increments:
        for j, c in enumerate(DTHETA):
            cols[c] = dtheta[:, j]
        for j, c in enumerate(DVEL):
            cols[c] = dv[:, j]
    else:
        for j in range(3):
            cols[CHANNELS[j]] = dtheta[:, j] / dt / units.DPH_TO_RPS
        for j in range(3):
            cols[CHANNELS[3 + j]] = dv[:, j] / dt / units.UG_TO_MPS2
    cols[TABLE] = (np.rad2deg(chunk.encoder) + 180.0) % 360.0 - 180.0
    if readings is not None:
        grid, inner, outer = readings
        k = np.clip(np.searchsorted(grid, t - 0.5 * dt, side="right") - 1, 0, grid.size - 1)
        for j, c in enumerate(CHANNELS):
            cols[f"temp_{c}"] = inner[k, j]
        cols[TEMP_OUT] = outer[k]
    if track:
        cols[REF_TRACK[0]] = np.rad2deg(chunk.lat)
        cols[REF_TRACK[1]] = np.rad2deg(chunk.lon)
        cols[REF_TRACK[2]] = chunk.alt
    cols[REF_HEADING] = np.rad2deg(chunk.euler[:, 0])
    return pd.DataFrame(cols)


# --------------------------------------------------------------------------- pass 1
@dataclass(frozen=True)
class Blocks:
    """Per-second sums of a recording (the first pass).

    Attributes
    ----------
    t0, t1 : ndarray [s]
        Start (end of the sample before) and end of the block's samples.
    n : ndarray [-]
        Samples in each block.
    fmag_mean, fmag_sd : ndarray [m/s²]
        Mean and standard deviation of ``|f|`` within each block.
    f_mean, w_mean : ndarray, shape (m, 3) [m/s², rad/s]
        Mean specific force and rate in r.
    f_dvar, w_dvar : ndarray, shape (m, 3) [(m/s²)², (rad/s)²]
        Half the mean square of first differences of the force and rate within the block:
        the white-noise variance of one sample (smooth motion hardly enters at 100 Hz).
    table_turn : ndarray [rad]
        Encoder turn within the block (unwrapped; 0 without encoder).
    table_start : float [rad]
        The encoder's first reading.
    dt : float [s]
        Nominal sample interval: the mean of the intervals that are not gaps.
    dt_jitter : float [-]
        Standard deviation of those intervals over their mean.
    gaps : ndarray of bool, optional
        Blocks holding an interval longer than :data:`GAP_FACTOR` × the usual.
    has_table : bool
    """

    t0: NDArray[np.float64]
    t1: NDArray[np.float64]
    n: NDArray[np.float64]
    fmag_mean: NDArray[np.float64]
    fmag_sd: NDArray[np.float64]
    f_mean: NDArray[np.float64]
    w_mean: NDArray[np.float64]
    f_dvar: NDArray[np.float64]
    w_dvar: NDArray[np.float64]
    table_turn: NDArray[np.float64]
    dt: float
    has_table: bool
    table_start: float = 0.0
    dt_jitter: float = 0.0
    gaps: NDArray[np.bool_] | None = None

    @property
    def size(self) -> int:
        return int(self.n.size)

    def select(self, start_s: float, end_s: float) -> NDArray[np.bool_]:
        """Blocks lying within ``[start_s, end_s]`` (to half a block)."""
        return (self.t0 >= start_s - 0.5 * BLOCK_S) & (self.t1 <= end_s + 0.5 * BLOCK_S)


class TableUnwrap:
    """Unwraps an encoder angle across pieces (±180° or 0-360° wrap-around): a step of more
    than half a turn between two samples is taken as the wrap."""

    def __init__(self) -> None:
        self._raw: float | None = None
        self._unwrapped = 0.0

    def __call__(self, angle: NDArray[np.float64]) -> NDArray[np.float64]:
        """Continuous angle [rad] from wrapped readings [rad]."""
        a = np.asarray(angle, dtype=float)
        if a.size == 0:
            return a
        if self._raw is None:
            u = np.unwrap(a)
        else:
            u = np.unwrap(np.concatenate([[self._raw], a]))
            u = u[1:] - u[0] + self._unwrapped
        self._raw, self._unwrapped = float(a[-1]), float(u[-1])
        return u


class BlockStats:
    """First pass: per-second sums of the recording (bounded memory: a few numbers a second)."""

    def __init__(self) -> None:
        self._parts: list[dict[str, NDArray]] = []
        self._origin: float | None = None
        self._prev_w: NDArray | None = None
        self._prev_f: NDArray | None = None
        self._unwrap = TableUnwrap()
        self._prev_table: float | None = None
        self._has_table: bool | None = None
        self._table_start = 0.0
        #: encoder jumps seen: (time [s], data row, size [deg]), the first 20, and their count
        self.jumps: list[tuple[float, int, float]] = []
        self.n_jumps = 0
        self._dt_sum = 0.0
        self._dt_sq = 0.0
        self._dt_n = 0

    def add(self, s: NavSamples) -> None:
        """Add one piece (in time order)."""
        if s.n == 0:
            return
        if self._origin is None:
            self._origin = float(s.t[0] - s.dt[0])
            self._has_table = s.table is not None
        dt = s.dt
        w = s.dtheta / dt[:, None]
        f = s.dv / dt[:, None]
        fm = np.sqrt(np.einsum("ij,ij->i", f, f))
        ids = np.floor((s.t - 0.5 * dt - self._origin) / BLOCK_S).astype(np.int64)
        lo = int(ids[0])
        k = ids - lo
        m = int(k[-1]) + 1

        def bsum(x: NDArray) -> NDArray:
            if x.ndim == 1:
                return np.bincount(k, weights=x, minlength=m)
            return np.stack([np.bincount(k, weights=x[:, j], minlength=m) for j in range(3)], 1)

        pw = w[:1] if self._prev_w is None else self._prev_w
        pf = f[:1] if self._prev_f is None else self._prev_f
        dw = np.diff(w, axis=0, prepend=pw)
        df = np.diff(f, axis=0, prepend=pf)
        self._prev_w, self._prev_f = w[-1:].copy(), f[-1:].copy()
        if s.table is not None:
            u = self._unwrap(s.table)
            if self._prev_table is None:
                self._table_start = float(u[0])
            prev = u[0] if self._prev_table is None else self._prev_table
            turn = np.diff(u, prepend=prev)
            self._prev_table = float(u[-1])
            # an encoder jump: the table turned in one sample by more than the gyro about
            # the same axis saw (plus a vehicle's own yaw, at most ENCODER_JUMP_DPS)
            lim = np.maximum(ENCODER_JUMP_DEG, ENCODER_JUMP_DPS * dt) * units.DEG_TO_RAD
            bad = np.flatnonzero(np.abs(turn - s.dtheta[:, 2]) > lim)
            if bad.size:
                step = np.abs(turn[bad] - s.dtheta[:, 2][bad])
                for i, d in zip(bad[:20].tolist(), step[:20].tolist(), strict=True):
                    if len(self.jumps) < 20:
                        self.jumps.append((float(s.t[i]), s.first_row + i, d / units.DEG_TO_RAD))
                self.n_jumps += int(bad.size)
        else:
            turn = np.zeros(s.n)
        # k is sorted (time increases): each block's first and last sample by bisection
        lo_i = np.searchsorted(k, np.arange(m), side="left")
        hi_i = np.searchsorted(k, np.arange(m), side="right") - 1
        empty = hi_i < lo_i
        first = np.where(empty, np.inf, (s.t - dt)[np.minimum(lo_i, s.n - 1)])
        last = np.where(empty, -np.inf, s.t[np.maximum(hi_i, 0)])
        self._parts.append(
            {
                "id": np.arange(lo, lo + m),
                "t0": first,
                "t1": last,
                "n": np.bincount(k, minlength=m).astype(float),
                "fm": bsum(fm),
                "fm2": bsum(fm * fm),
                "f": bsum(f),
                "w": bsum(w),
                "df2": bsum(df * df),
                "dw2": bsum(dw * dw),
                "turn": bsum(turn),
            }
        )
        # the nominal step: the mean of the intervals that are not gaps (a clock in whole
        # ms gives 7 and 8 ms intervals for 128 Hz: the median would be 8 ms)
        med = float(np.median(dt))
        ok = dt <= GAP_FACTOR * med
        self._dt_sum += float(dt[ok].sum())
        self._dt_sq += float((dt[ok] ** 2).sum())
        self._dt_n += int(ok.sum())
        self._parts[-1]["gap"] = np.bincount(k, weights=(~ok).astype(float), minlength=m)

    def finish(self) -> Blocks:
        """The per-second table (blocks split between pieces merged)."""
        if not self._parts:
            raise LogError("the recording has no samples")
        ids = np.concatenate([p["id"] for p in self._parts])
        u, inv = np.unique(ids, return_inverse=True)
        m = u.size

        def merge(key: str, how: str = "sum") -> NDArray:
            x = np.concatenate([p[key] for p in self._parts])
            if how == "min":
                out = np.full(m, np.inf)
                np.minimum.at(out, inv, x)
                return out
            if how == "max":
                out = np.full(m, -np.inf)
                np.maximum.at(out, inv, x)
                return out
            if x.ndim == 1:
                return np.bincount(inv, weights=x, minlength=m)
            return np.stack([np.bincount(inv, weights=x[:, j], minlength=m) for j in range(3)], 1)

        n = merge("n")
        keep = n > 0
        n = n[keep]
        fm = merge("fm")[keep] / n
        var = np.maximum(merge("fm2")[keep] / n - fm * fm, 0.0)
        return Blocks(
            t0=merge("t0", "min")[keep],
            t1=merge("t1", "max")[keep],
            n=n,
            fmag_mean=fm,
            fmag_sd=np.sqrt(var),
            f_mean=merge("f")[keep] / n[:, None],
            w_mean=merge("w")[keep] / n[:, None],
            f_dvar=0.5 * merge("df2")[keep] / n[:, None],
            w_dvar=0.5 * merge("dw2")[keep] / n[:, None],
            table_turn=merge("turn")[keep],
            dt=self._dt_sum / max(self._dt_n, 1),
            dt_jitter=math.sqrt(
                max(
                    self._dt_sq / max(self._dt_n, 1) - (self._dt_sum / max(self._dt_n, 1)) ** 2, 0.0
                )
            )
            / max(self._dt_sum / max(self._dt_n, 1), 1e-300),
            gaps=merge("gap")[keep] > 0,
            has_table=bool(self._has_table),
            table_start=self._table_start,
        )


# --------------------------------------------------------------------------- the window
@dataclass(frozen=True)
class Window:
    """The alignment window and how it was chosen.

    Attributes
    ----------
    start_s, length_s : float [s]
        Start (time since the recording's time origin) and length.
    how : {"found", "given"}
        Found by :func:`find_window` or set by hand.
    quality : dict
        ``floor_ug`` (the recording's noise floor of ``|f|`` per sample), ``threshold_ug``,
        ``sd_ug_median`` and ``sd_ug_max`` (spread of ``|f|`` within the window's seconds),
        ``quiet_fraction`` (of its seconds), ``stretch_s`` (length of the quiet stretch it
        starts, when found).
    """

    start_s: float
    length_s: float
    how: str
    quality: dict[str, float] = field(default_factory=dict)

    @property
    def end_s(self) -> float:
        return self.start_s + self.length_s


def quiet_blocks(blocks: Blocks) -> tuple[NDArray[np.bool_], float, float]:
    """Which seconds are quiet, the floor and the threshold of ``|f|``'s spread [m/s²].

    A block holding fewer than half the usual samples (the recording's ends) or a gap is
    never quiet. One loud second between quiet ones (a turntable starting with a jerk) is
    forgiven.
    """
    full = blocks.n >= 0.5 * np.median(blocks.n)
    if blocks.gaps is not None:  # the aligner steps by the nominal interval: no gap in it
        full = full & ~blocks.gaps
    sd = blocks.fmag_sd
    floor = float(np.percentile(sd[full], FLOOR_PERCENTILE)) if full.any() else float("nan")
    thr = QUIET_FACTOR * max(floor, 1e-9)
    jump = np.abs(np.diff(blocks.fmag_mean, prepend=blocks.fmag_mean[:1]))
    quiet = full & (sd <= thr) & (jump <= thr)
    lone = np.zeros_like(quiet)
    lone[1:-1] = ~quiet[1:-1] & quiet[:-2] & quiet[2:] & full[1:-1]
    return quiet | lone, floor, thr


def _stretches(quiet: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """[a, b) index ranges of consecutive True."""
    q = np.concatenate([[False], quiet, [False]]).astype(np.int8)
    d = np.diff(q)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def find_window(
    blocks: Blocks,
    align_s: float,
    min_s: float = MIN_WINDOW_S,
    start_s: float | None = None,
) -> Window:
    """The alignment window: the earliest quiet stretch of at least ``min_s``, up to ``align_s``.

    Parameters
    ----------
    blocks : Blocks
        The first pass.
    align_s : float [s]
        Longest alignment wanted (the window is cut to it).
    min_s : float [s]
        Shortest acceptable window (at most ``align_s``).
    start_s : float, optional [s]
        Set the window by hand: ``[start_s, start_s + align_s)``; it is checked (its quiet
        fraction reported) but not moved.

    Raises
    ------
    LogError
        When no quiet stretch is long enough (naming the quietest found), or a given window
        lies outside the recording.
    """
    if not (math.isfinite(align_s) and align_s > 0):
        raise ConfigError(f"alignment length must be > 0 s, got {align_s}")
    quiet, floor, thr = quiet_blocks(blocks)
    ug = units.UG_TO_MPS2
    base = {"floor_ug": floor / ug, "threshold_ug": thr / ug}
    t_first, t_last = float(blocks.t0[0]), float(blocks.t1[-1])

    def rate(sel: NDArray[np.bool_]) -> dict[str, float]:
        sd = blocks.fmag_sd[sel]
        return {
            **base,
            "sd_ug_median": float(np.median(sd)) / ug if sd.size else float("nan"),
            "sd_ug_max": float(np.max(sd)) / ug if sd.size else float("nan"),
            "quiet_fraction": float(np.mean(quiet[sel])) if sd.size else 0.0,
        }

    if start_s is not None:
        end = start_s + align_s
        if start_s < t_first - 1e-9 or end > t_last + 1e-6:
            raise LogError(
                f"alignment window {start_s:g}-{end:g} s lies outside the recording "
                f"({t_first:g}-{t_last:g} s)"
            )
        return Window(start_s, align_s, "given", rate(blocks.select(start_s, end)))
    min_s = min(min_s, align_s)
    best: tuple[float, float] = (float("nan"), 0.0)
    for a, b in _stretches(quiet):
        t0, t1 = float(blocks.t0[a]), float(blocks.t1[b - 1])
        if t1 - t0 > best[1]:
            best = (t0, t1 - t0)
        if t1 - t0 >= min_s - 0.5 * blocks.dt:
            length = min(t1 - t0, align_s)
            q = rate(blocks.select(t0, t0 + length))
            q["stretch_s"] = t1 - t0
            return Window(t0, length, "found", q)
    what = (
        f"the longest quiet stretch is {best[1]:.0f} s from {best[0]:.0f} s"
        if best[1] > 0
        else "no second of it is quiet"
    )
    raise LogError(
        f"no static window of at least {min_s:g} s to align on: {what} (quiet: the spread of "
        f"|f| within a second at most {thr / ug:.0f} µg, {QUIET_FACTOR:g} × the recording's "
        f"floor of {floor / ug:.0f} µg); set one by hand with --align-start-s and --align-s"
    )


# --------------------------------------------------------------------------- noise, checks
@dataclass(frozen=True)
class Noise:
    """White-noise densities and bias random walks the alignment filter assumes.

    Attributes
    ----------
    gyro_density : float [rad/√s]
    accel_density : float [m/s²/√Hz]
    gyro_bias_rw : float [rad/s/√s]
    accel_bias_rw : float [m/s²/√s]
    source : str
        ``"metadata"``, ``"--imu NAME"`` or ``"estimated on the window"``.
    """

    gyro_density: float
    accel_density: float
    gyro_bias_rw: float = 0.0
    accel_bias_rw: float = 0.0
    source: str = "given"

    def to_dict(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "gyro_arw_deg_per_rth": self.gyro_density / units.DPRH_TO_RPRS,
            "accel_vrw_ug_per_rthz": self.accel_density / units.UG_TO_MPS2,
        }


def estimate_noise(blocks: Blocks, window: Window) -> Noise:
    """White-noise densities from the first differences within the window's seconds.

    The per-sample variance is half the mean square of first differences (white noise:
    ``var(x_k − x_{k−1}) = 2σ²``; a smooth motion adds ``O((a·dt)²)``), the median over the
    window's seconds (a turntable's start and stop spoil a few). Density = σ·√dt.
    """
    sel = blocks.select(window.start_s, window.end_s)
    if not sel.any():
        raise LogError("the alignment window holds no complete second to estimate noise on")
    dt = blocks.dt
    w_sd = np.sqrt(np.median(blocks.w_dvar[sel], axis=0))
    f_sd = np.sqrt(np.median(blocks.f_dvar[sel], axis=0))
    # x and y: the table turns about z, whose rate changes at the stops
    return Noise(
        gyro_density=float(np.mean(w_sd[:2]) * math.sqrt(dt)),
        accel_density=float(np.mean(f_sd) * math.sqrt(dt)),
        source="estimated on the window",
    )


def check_at_rest(
    blocks: Blocks, window: Window, lat: float, h: float
) -> tuple[dict[str, Any], list[str]]:
    """Plausibility of the units on the alignment window: |f| against g, |ω| against Earth rate.

    Returns the measured values and warnings; raises for a factor no sensor error explains
    (a wrong unit: deg/s read as rad/s, counts without weights, increments read as rates).

    Parameters
    ----------
    lat : float [rad]
    h : float [m]

    Raises
    ------
    LogError
        When ``|f|`` differs from local gravity by more than 10 % or the rate at rest from
        the Earth rate by more than a factor 20.
    """
    sel = blocks.select(window.start_s, window.end_s)
    if not sel.any():
        raise LogError("the alignment window holds no complete second")
    g = float(earth.gravity(lat, h))
    n = blocks.n[sel]
    fbar = float(np.sum(blocks.fmag_mean[sel] * n) / np.sum(n))
    out: dict[str, Any] = {"f_mps2": fbar, "g_mps2": g, "f_over_g": fbar / g}
    warn: list[str] = []
    ratio = fbar / g
    if not 0.9 <= ratio <= 1.1:
        raise LogError(
            f"at rest the accelerometers read |f| = {fbar:.6g} m/s² where local gravity is "
            f"{g:.5f} m/s² (× {ratio:.4g}): wrong accelerometer units"
            f"{_factor_hint(ratio, blocks.dt, 'accel')}"
        )
    if abs(ratio - 1) > 0.01:
        warn.append(f"at rest |f| is {100 * (ratio - 1):+.2f} % from local gravity")
    # rate at rest: the turntable's turn (encoder) removed from z, seconds it stood still
    w = blocks.w_mean[sel].copy()
    span = blocks.t1[sel] - blocks.t0[sel]
    if blocks.has_table:
        w[:, 2] -= blocks.table_turn[sel] / np.maximum(span, 1e-9)
        still = np.ones(w.shape[0], dtype=bool)
    else:  # no encoder: the seconds whose rate is smallest (the table's dwells)
        mag = np.linalg.norm(w, axis=1)
        still = mag <= np.percentile(mag, 25)
        turns = np.abs(w[:, 2]) > 5 * earth.RATE
        if np.mean(turns) > 0.5 and np.median(np.abs(w[:, 2]) / np.maximum(mag, 1e-30)) > 0.99:
            out["omega_checked"] = False
            warn.append(
                "the gyros were not checked against the Earth rate: the table turns all "
                "through the window and the log has no encoder angle"
            )
            return out, warn
    wbar = float(np.median(np.linalg.norm(w[still], axis=1)))
    rr = wbar / earth.RATE
    out.update({"omega_dph": wbar / units.DPH_TO_RPS, "earth_rate_dph": earth.RATE /
                units.DPH_TO_RPS, "omega_over_earth_rate": rr, "omega_checked": True})  # fmt: skip
    if not 1 / 20 <= rr <= 20:
        raise LogError(
            f"at rest the gyros read |ω| = {wbar / units.DPH_TO_RPS:.6g} °/h where the Earth "
            f"turns at {earth.RATE / units.DPH_TO_RPS:.4f} °/h (× {rr:.4g}): wrong gyro "
            f"units{_factor_hint(rr, blocks.dt, 'gyro')}, or a gyro whose bias is beyond "
            "20 × the Earth rate (a consumer MEMS cannot find north by itself)"
        )
    if not 0.5 <= rr <= 2:
        warn.append(
            f"at rest |ω| is {rr:.2f} × the Earth rate (a gyro bias of that size spoils "
            "the heading of any alignment)"
        )
        return out, warn
    # the latitude the IMU measures: the angle between the Earth rate and gravity
    f = blocks.f_mean[sel][still]
    ws = w[still]
    cosang = np.einsum("ij,ij->i", ws, f) / (np.linalg.norm(ws, axis=1) * np.linalg.norm(f, axis=1))
    lat_meas = float(np.median(np.arcsin(np.clip(cosang, -1.0, 1.0))))
    out["latitude_measured_deg"] = math.degrees(lat_meas)
    if abs(lat_meas - lat) > math.radians(LATITUDE_TOL_DEG):
        warn.append(
            f"the gyros at rest measure latitude {math.degrees(lat_meas):.2f}° (the angle "
            f"between the Earth rate and gravity), the site says {math.degrees(lat):.2f}°: "
            "is the site right (the sign of its latitude)?"
        )
    return out, warn


def check_encoder(blocks: Blocks) -> list[str]:
    """The encoder against the z gyro over the seconds the table turns: same sense, same unit.

    A wrong ``table_sign`` or ``table_unit`` does not touch the navigation (it runs in the
    IMU frame) but turns every heading error into nonsense; the gyro knows the truth. The
    sense is judged where both turn (a vehicle's own yaw is in the gyro, not the encoder);
    the unit where the gyro turns, only when the ratio is a degree-radian factor.
    """
    if not blocks.has_table:
        return []
    span = np.maximum(blocks.t1 - blocks.t0, 1e-9)
    gyro = blocks.w_mean[:, 2] * span
    fast = 1.0 * units.DEG_TO_RAD * span
    both = (np.abs(gyro) > fast) & (np.abs(blocks.table_turn) > fast)
    out = []
    if both.sum() >= 3 and float(np.sum(np.sign(blocks.table_turn[both]) * gyro[both])) < 0:
        out.append(
            "the encoder turns against the z gyro (the IMU's own turn): its sign is wrong "
            "(table_sign in the mapping); positive table_deg turns the IMU counter-clockwise "
            "seen from above, as the z gyro reads it"
        )
    turning = np.abs(gyro) > fast
    if turning.sum() >= 3:
        size = float(np.sum(np.abs(blocks.table_turn[turning])) / np.sum(np.abs(gyro[turning])))
        for k in (units.DEG_TO_RAD, 1 / units.DEG_TO_RAD):
            if abs(math.log(size / k)) < math.log(1.1):
                out.append(
                    f"the encoder turns {size:.3g} × what the z gyro turns while the table "
                    "moves: its unit is wrong (table_unit in the mapping: deg or rad)"
                )
    return out


#: Factors a wrong unit gives, by sensor: what is read as what.
_UNIT_FACTORS: dict[str, tuple[tuple[float, str], ...]] = {
    "gyro": (
        (1 / units.DEG_TO_RAD, "deg/s read as rad/s"),
        (units.DEG_TO_RAD, "rad/s read as deg/s"),
        (3600.0, "deg/h read as deg/s"),
        (1 / 3600.0, "deg/s read as deg/h"),
        (1 / units.DPH_TO_RPS, "deg/h read as rad/s"),
        (units.DPH_TO_RPS, "rad/s read as deg/h"),
    ),
    "accel": (
        (1 / units.UG_TO_MPS2, "µg read as m/s²"),
        (1 / units.MG_TO_MPS2, "mg read as m/s²"),
        (units.G0, "m/s² read as g"),
        (1 / units.G0, "g read as m/s²"),
        (1e3, "µg read as mg"),
        (1e-3, "mg read as µg"),
    ),
}


def _factor_hint(ratio: float, dt: float, sensor: str) -> str:
    """Name the unit mix-up a measured/expected ratio points to, if one is near (10 %)."""
    cands = [
        *_UNIT_FACTORS[sensor],
        (dt, "increments read as rates (× the interval)"),
        (1 / dt, "rates read as increments"),
    ]
    for k, what in cands:
        if abs(math.log(ratio / k)) < math.log(1.1):
            return f" ({what}?)"
    return " (counts without pulse weights, or a unit mix-up)"


def seen_schedule(blocks: Blocks) -> dict[str, Any]:
    """What the encoder says the turntable did: positions held, dwell, turning rate."""
    if not blocks.has_table:
        return {"source": "none (no encoder angle: the IMU is fixed to the body)"}
    span = np.maximum(blocks.t1 - blocks.t0, 1e-9)
    rate = blocks.table_turn / span
    angle = blocks.table_start + np.cumsum(blocks.table_turn)  # at each block's end
    still = np.abs(rate) < 0.1 * units.DEG_TO_RAD
    dwell = [(a, b) for a, b in _stretches(still) if b - a >= 2]
    pos = sorted({round(float(np.rad2deg(angle[a:b].mean())) % 360.0) % 360 for a, b in dwell})
    moving = ~still
    return {
        "source": "encoder",
        "positions_deg": [p if p <= 180 else p - 360 for p in pos][:24],
        "dwells": len(dwell),
        "dwell_s_median": float(np.median([blocks.t1[b - 1] - blocks.t0[a] for a, b in dwell]))
        if dwell
        else 0.0,
        "turning_rate_dps_median": float(np.median(np.abs(rate[moving])) / units.DEG_TO_RAD)
        if moving.any()
        else 0.0,
        "total_turn_deg": float(np.sum(np.abs(blocks.table_turn)) / units.DEG_TO_RAD),
    }


def align_config(
    noise: Noise, window: Window, coarse_s: float = 60.0, base: AlignConfig | None = None
) -> AlignConfig:
    """Alignment settings for a window and a noise (bias Markov floors as :func:`align_for`)."""
    from rinscal.nav.scenario import align_from_noise

    return align_from_noise(
        noise.gyro_density,
        noise.accel_density,
        noise.gyro_bias_rw,
        noise.accel_bias_rw,
        total_s=window.length_s,
        coarse_s=coarse_s,
        start_s=max(window.start_s, 0.0),  # informative only: a log's clock may start < 0
    )


# --------------------------------------------------------------------------- compensation
class PieceCompensator(Protocol):
    """Causal compensation of a recording piece by piece: bias (n, 6) SI to subtract."""

    channels: tuple[str, ...]

    def __call__(self, s: NavSamples) -> NDArray[np.float64]: ...


class CausalModelCompensator:
    """A thermal model run as the navigation computer runs it, piece by piece.

    The thermometers are read once per ``update_s`` (the first sample whose interval's
    middle falls in a new tick: its temperature columns, dated at the tick); the
    temperature rate is the model's causal windowed slope over these readings (the
    compiled :class:`~rinscal.calibration.thermal.rate.CausalSlope` of ``compensate --causal``);
    the bias ``(f(T, Ṫ, ΔT) − r)`` in SI is held until the next reading. A reading with a
    NaN temperature keeps the last one. Channels the model lacks are not compensated.

    Parameters
    ----------
    model : ThermalModelFile
    policy : {"clamp", "fallback", "extrapolate", "error"}
    update_s : float [s]
        Thermometer reading interval (the simulator's is 1 s).
    """

    def __init__(self, model: Any, policy: str = "clamp", update_s: float = 1.0) -> None:
        from rinscal.calibration.thermal.rate import CausalSlope

        if not (math.isfinite(update_s) and update_s > 0):
            raise ConfigError(f"model update interval must be > 0 s, got {update_s}")
        idx = []
        for c in model.channels:
            if c not in CHANNELS:
                raise ConfigError(f"model channel {c!r} is not one of {CHANNELS}")
            idx.append(CHANNELS.index(c))
        self.model = model
        self.policy = policy
        self.update_s = float(update_s)
        self.channels = tuple(model.channels)
        self._idx = np.array(idx, dtype=np.int64)
        self._slope = CausalSlope(model.derivative_window_s, len(idx))
        self._tick = -(2**62)
        self._bias = np.zeros(6)
        self._last_temp: NDArray | None = None
        self._last_out: float = float("nan")
        self.readings = 0
        #: thermometer readings skipped because no thermometer had read yet
        self.skipped = 0
        #: the model uses the gradient ΔT (needs the outer temperature)
        self.needs_outer = bool(getattr(model, "use_gradient", False)) and any(
            getattr(model.models[c], "n_inputs", 3) >= 3 for c in model.channels
        )

    def __call__(self, s: NavSamples) -> NDArray[np.float64]:
        from rinscal.units import MIN_TO_S

        if s.temps is None:
            raise ConfigError(
                f"a thermal model needs temperatures, and the recording has none for "
                f"{', '.join(self.channels)} (columns temp_<channel> or temp_in)"
            )
        tick = np.floor((s.t - 0.5 * s.dt) / self.update_s + 1e-9).astype(np.int64)
        new = np.flatnonzero(np.diff(tick, prepend=self._tick) != 0)
        out = np.empty((s.n, 6))
        if new.size:
            temp = s.temps[new][:, self._idx].copy()
            t_out = None if s.temp_out is None else s.temp_out[new].copy()
            self._hold(temp, t_out)
            # no reading yet (a thermometer empty from the start): the model waits for one
            ok = np.isfinite(temp).all(axis=1)
            if self.needs_outer:
                if t_out is None:
                    raise ConfigError(
                        f"the model uses the gradient ΔT = T − temp_out for "
                        f"{', '.join(self.channels)}, and the recording has no outer "
                        "temperature (a temp_out column, or a mapping onto it)"
                    )
                ok &= np.isfinite(t_out)
            if not ok.all():
                self.skipped += int((~ok).sum())
                new, temp = new[ok], temp[ok]
                t_out = None if t_out is None else t_out[ok]
        if new.size:
            times = tick[new] * self.update_s
            rate = self._slope.update(times.astype(float), temp) * MIN_TO_S
            bias = np.zeros((new.size, 6))
            bias[:, self._idx] = self.model.predict_bias_si(temp, rate, t_out, policy=self.policy)
            # each sample takes the last reading at or before it (row 0: the one held before)
            seg = np.zeros(s.n, dtype=np.int64)
            seg[new] = 1
            np.cumsum(seg, out=seg)
            np.take(np.vstack([self._bias, bias]), seg, axis=0, out=out)
            self._bias = bias[-1]
            self.readings += new.size
        else:
            out[:] = self._bias
        self._tick = int(tick[-1])
        return out

    def _hold(self, temp: NDArray, t_out: NDArray | None) -> None:
        """Replace NaN readings by the last finite one (forward fill across pieces)."""
        for j in range(temp.shape[1]):
            col = temp[:, j]
            last = np.nan if self._last_temp is None else self._last_temp[j]
            temp[:, j] = _ffill(col, last)
        self._last_temp = temp[-1].copy()
        if t_out is not None:
            t_out[:] = _ffill(t_out, self._last_out)
            self._last_out = float(t_out[-1])


def _ffill(x: NDArray, last: float) -> NDArray:
    ok = np.isfinite(x)
    if ok.all():
        return x
    idx = np.where(ok, np.arange(x.size), -1)
    np.maximum.accumulate(idx, out=idx)
    return np.where(idx >= 0, x[np.maximum(idx, 0)], last)


# --------------------------------------------------------------------------- reference
@dataclass(frozen=True)
class Reference:
    """Where the IMU really was: a static site, or a track interpolated onto the IMU times.

    Attributes
    ----------
    lat, lon : float [rad]
        The site (or the track's first point).
    h : float [m]
    heading : float, optional [rad]
        True heading of the body at the alignment, clockwise from north; held as the
        reference while the base is static (no track).
    track : tuple of ndarray, optional
        ``(t [s], lat [rad], lon [rad], h [m])`` of a reference track.
    """

    lat: float
    lon: float
    h: float
    heading: float | None = None
    track: tuple[NDArray, NDArray, NDArray, NDArray] | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lat) and abs(self.lat) <= math.pi / 2):
            raise ConfigError(f"latitude must lie within ±90°, got {math.degrees(self.lat):g}°")

    def at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """``lat, lon, h, v_e, v_n, v_u`` (n, 6) at ``t`` [s]: rad, rad, m, m/s."""
        n = t.size
        if self.track is None:
            out = np.zeros((n, 6))
            out[:, 0], out[:, 1], out[:, 2] = self.lat, self.lon, self.h
            return out
        tt, la, lo, hh = self.track
        lat = np.interp(t, tt, la)
        lon = np.interp(t, tt, lo)
        h = np.interp(t, tt, hh)
        rn, re = earth.principal_radii(lat)
        dt = np.gradient(tt) if tt.size > 1 else np.ones(1)
        vn = np.interp(t, tt, np.gradient(la) / dt) * (rn + h)
        ve = np.interp(t, tt, np.gradient(lo) / dt) * (re + h) * np.cos(lat)
        vu = np.interp(t, tt, np.gradient(hh) / dt)
        return np.column_stack([lat, lon, h, ve, vn, vu])

    def covers(self, t: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Where the reference exists: everywhere for a site, within a track's span."""
        if self.track is None:
            return np.ones(t.shape, dtype=bool)
        tt = self.track[0]
        return (t >= tt[0]) & (t <= tt[-1])

    def overlap(self, t0: float, t1: float) -> None:
        """Refuse a track that does not cover ``[t0, t1]`` (the part navigated)."""
        if self.track is None:
            return
        tt = self.track[0]
        if tt[0] > t1 or tt[-1] < t0:
            raise LogError(
                f"the reference track ({tt[0]:.1f}-{tt[-1]:.1f} s) does not overlap the "
                f"recording's navigated part ({t0:.1f}-{t1:.1f} s)"
            )


# --------------------------------------------------------------------------- pass 2
@dataclass(frozen=True)
class RecordedRun:
    """What a recorded run was (the attributes the navigation plots and summary read).

    Times are on the recording's clock; ``time_origin_s`` is the start of its first
    sample's interval (``duration_s`` counts from there). ``notes`` says what the reference
    did not cover.
    """

    name: str
    duration_s: float
    rate_hz: float
    align_start_s: float
    nav_start_s: float
    align: AlignConfig
    schedule: Any
    trajectory: Any
    time_origin_s: float = 0.0
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class _Named:
    name: str


@dataclass(frozen=True)
class _Site:
    lat0: float
    lon0: float


@dataclass
class _Variant:
    comp: PieceCompensator | None
    aligner: Aligner
    nav: Strapdown | None = None
    gyro_bias: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    accel_bias: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    rows: list[NDArray[np.float64]] = field(default_factory=list)


def navigate_recording(
    pieces: Iterable[NavSamples],
    reference: Reference,
    window: Window,
    align: AlignConfig,
    dt: float,
    compensators: Mapping[str, PieceCompensator | None] | None = None,
    *,
    name: str = "recording",
    out_dt_s: float = 1.0,
    vertical: VerticalMode = "hold",
    schedule: str = "encoder",
    use_heading_column: bool = True,
    progress: Callable[[float], None] | None = None,
) -> Any:
    """Navigate a recording's variants side by side (the second pass).

    Parameters
    ----------
    pieces : iterable of NavSamples
        The recording, in time order (read again: the first pass found the window).
    reference : Reference
        Static site or track (a track in the pieces' ``ref`` columns wins).
    window : Window
        Alignment window (:func:`find_window`).
    align : AlignConfig
        Alignment settings (its ``start_s`` and length those of the window).
    dt : float [s]
        Nominal sample interval (the aligner's and strapdown's step; a longer interval, a
        gap, is integrated with its own length).
    compensators : mapping of str to PieceCompensator or None
        Variants; default ``{"none": None}``.
    out_dt_s : float [s]
        Interval of the reported errors (a whole number of samples).
    vertical : {"hold", "damped", "free"}
        Vertical channel, held or damped to the reference height.
    use_heading_column : bool
        Take the body's true heading from the pieces' ``ref_heading`` (else only the
        reference's ``heading``, e.g. one given on the command line).

    Returns
    -------
    NavResult
        ``errors`` per variant from the navigation start, where the reference exists
        (a track's span, its finite values), ``truth`` (the reference) at the same times,
        ``alignment`` per variant; ``config`` a :class:`RecordedRun`.

    Raises
    ------
    LogError
        When the alignment does not end before the recording does, nothing is left to
        navigate, or the reference covers none of the navigated part.
    """
    from rinscal.nav.scenario import NavResult, _error_frame

    comps = {"none": None} if compensators is None else dict(compensators)
    if not comps:
        raise ConfigError("navigate_recording: need at least one variant")
    out_every = round(out_dt_s / dt)
    if out_every < 1:
        raise ConfigError(f"output interval {out_dt_s} s is shorter than a sample ({dt} s)")
    variants: dict[str, _Variant] = {}
    n_start = n_nav = None
    truth_rows: list[NDArray] = []
    consumed = 0
    t_origin: float | None = None
    unwrap = TableUnwrap()
    track = _LogTrack(reference)
    t_last = float("nan")
    t_align = t_nav = float("nan")
    for s in pieces:
        if s.n == 0:
            continue
        if t_origin is None:
            t_origin = float(s.t[0] - s.dt[0])
        if n_start is None:
            # the window starts at the first sample whose interval starts at window.start_s
            n_before = int(np.searchsorted(s.t - s.dt, window.start_s - 0.25 * dt))
            if n_before < s.n:
                n_start = consumed + n_before
                for vname, comp in comps.items():
                    al = Aligner(
                        reference.lat, reference.lon, reference.h, dt, align, vertical,
                        k0=n_start,
                    )  # fmt: skip
                    variants[vname] = _Variant(comp, al)
                n_nav = n_start + next(iter(variants.values())).aligner.n_total
        gidx = consumed + np.arange(1, s.n + 1)
        consumed += s.n
        t_last = float(s.t[-1])
        ref, valid = track(s)
        if n_start is not None and gidx[0] <= n_start + 1 <= gidx[-1]:
            i = n_start - (gidx[0] - 1)
            t_align = float(s.t[i] - s.dt[i])
        if n_nav is not None and gidx[0] <= n_nav <= gidx[-1]:
            t_nav = float(s.t[n_nav - gidx[0]])
        table = unwrap(s.table) if s.table is not None else np.zeros(s.n)
        if n_start is None or gidx[-1] <= n_start:
            comps_run = [c for c in comps.values() if c is not None]
            for c in comps_run:  # the compensators' temperature history runs from power-on
                c(s)
            if progress is not None:
                progress(t_last)
            continue
        assert n_nav is not None
        sel = (gidx % out_every == 0) & (gidx > n_nav)
        if sel.any():
            column = s.ref_heading if use_heading_column else None
            head = np.full(s.n, np.nan) if column is None else column
            static = reference.track is None and s.ref is None
            if column is None and reference.heading is not None:
                if static:  # the body stands: its heading is the one given, all along
                    head = np.full(s.n, reference.heading)
                elif not truth_rows:  # a track: the heading given holds at the start only
                    head[np.flatnonzero(sel)[0]] = reference.heading
            truth_rows.append(
                np.column_stack(
                    [
                        s.t[sel],
                        ref[sel],
                        head[sel],
                        np.full((sel.sum(), 2), np.nan),
                        table[sel],
                        valid[sel],
                    ]
                )
            )
        i_first = max(0, n_start - (gidx[0] - 1))
        for v in variants.values():
            d_th, d_v = s.dtheta, s.dv
            if v.comp is not None:
                c = v.comp(s)
                d_th = d_th - c[:, :3] * s.dt[:, None]
                d_v = d_v - c[:, 3:] * s.dt[:, None]
            i0 = i_first
            if not v.aligner.done:
                i0 += feed_and_hand_over(v, d_th[i_first:], d_v[i_first:])
            if i0 < s.n:
                assert v.nav is not None
                step = s.dt[i0:, None]  # the estimates are rates: over each sample's own interval
                out = _run_nav(
                    v.nav, d_th[i0:] - v.gyro_bias * step, d_v[i0:] - v.accel_bias * step,
                    s.dt[i0:], dt, ref[i0:, 2], ref[i0:, 5], out_every,
                )  # fmt: skip
                if out.shape[0]:
                    v.rows.append(out)
        if progress is not None:
            progress(t_last)
    if n_start is None or t_origin is None:
        raise LogError(f"the alignment window ({window.start_s:g} s) starts after the recording")
    if not all(v.aligner.done for v in variants.values()):
        raise LogError(
            f"the recording ends at {t_last:.1f} s, before the alignment "
            f"({window.start_s:g} s + {window.length_s:g} s) does"
        )
    truth = np.concatenate(truth_rows) if truth_rows else np.empty((0, 12))
    if truth.shape[0] == 0:
        raise LogError(
            f"the recording ends at {t_last:.1f} s, when the alignment "
            f"({window.start_s:g} s + {window.length_s:g} s) does: nothing is left to "
            "navigate (a shorter --align-s, or a longer recording)"
        )
    reference.overlap(float(truth[0, 0]), float(truth[-1, 0]))
    keep = truth[:, 11] > 0
    notes: list[str] = []
    if not keep.any():
        raise LogError(
            f"the reference has no value at any navigated time ({truth[0, 0]:.1f}-"
            f"{truth[-1, 0]:.1f} s): nothing to measure the errors against"
        )
    if not keep.all():
        notes.append(
            f"the reference covers {int(keep.sum())} of the {keep.size} output times "
            f"({truth[keep, 0][0]:.1f}-{truth[keep, 0][-1]:.1f} s): errors are reported there only"
        )
    truth_df = pd.DataFrame(
        {
            "time_s": truth[:, 0],
            "lat_deg": np.rad2deg(truth[:, 1]),
            "lon_deg": np.rad2deg(truth[:, 2]),
            "alt_m": truth[:, 3],
            "v_e": truth[:, 4],
            "v_n": truth[:, 5],
            "v_u": truth[:, 6],
            "heading_deg": np.rad2deg(truth[:, 7]),
            "encoder_deg": np.rad2deg(truth[:, 10]),
        }
    )
    errors = {}
    for vname, v in variants.items():
        rows = np.concatenate(v.rows) if v.rows else np.empty((0, 10))
        errors[vname] = _error_frame(truth[keep, :11], rows[keep]).reset_index(drop=True)
    truth_df = truth_df[keep].reset_index(drop=True)
    alignment: dict[str, AlignResult | None] = {k: v.aligner.result() for k, v in variants.items()}
    run = RecordedRun(
        name=name,
        duration_s=t_last - t_origin,
        rate_hz=1.0 / dt,
        align_start_s=t_align,
        nav_start_s=t_nav,
        align=align,
        schedule=_Named(schedule),
        trajectory=_Site(reference.lat, reference.lon),
        time_origin_s=t_origin,
        notes=tuple(notes),
    )
    return NavResult(run, truth_df, errors, alignment)  # type: ignore[arg-type]


class _LogTrack:
    """The reference at every sample of a piece: ``lat, lon, h, v_e, v_n, v_u`` and whether
    it exists there. From the piece's own ``ref`` columns (velocities by second-order
    backward differences, an empty cell holding the last value for the vertical hold), else
    from :class:`Reference` (a track file exists over its span only)."""

    def __init__(self, reference: Reference) -> None:
        self.reference = reference
        self._prev: NDArray | None = None  # the last two rows (lat, lon, h), finite

    def __call__(self, s: NavSamples) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        ref = self.reference
        if s.ref is None:
            out = ref.at(s.t)
            return out, ref.covers(s.t)
        r = np.array(s.ref, dtype=float)
        valid = np.isfinite(r).all(axis=1)
        if not valid.all():
            last = (
                self._prev[-1]
                if self._prev is not None
                else (r[valid][0] if valid.any() else np.array([ref.lat, ref.lon, ref.h]))
            )
            for j in range(3):
                r[:, j] = _ffill(r[:, j], float(last[j]))
        x = np.concatenate([np.repeat(r[:1], 2, axis=0) if self._prev is None else self._prev, r])
        self._prev = x[-2:].copy()
        rate = (3 * x[2:] - 4 * x[1:-1] + x[:-2]) / (2 * s.dt[:, None])
        rn, re = earth.principal_radii(r[:, 0])
        out = np.empty((s.n, 6))
        out[:, :3] = r
        out[:, 3] = rate[:, 1] * (re + r[:, 2]) * np.cos(r[:, 0])
        out[:, 4] = rate[:, 0] * (rn + r[:, 2])
        out[:, 5] = rate[:, 2]
        return out, valid


def _run_nav(
    nav: Strapdown,
    d_th: NDArray,
    d_v: NDArray,
    dts: NDArray,
    dt: float,
    alt_ref: NDArray,
    vu_ref: NDArray,
    out_every: int,
) -> NDArray[np.float64]:
    """Strapdown over a stretch; an interval longer than 1.5 steps (a gap) with its own length."""
    gaps = np.flatnonzero(dts > GAP_FACTOR * dt)
    if gaps.size == 0:
        return nav.run(d_th, d_v, alt_ref=alt_ref, vu_ref=vu_ref, out_every=out_every)
    outs = []
    a = 0
    for g in [*gaps.tolist(), None]:
        b = d_th.shape[0] if g is None else g
        if b > a:
            outs.append(nav.run(d_th[a:b], d_v[a:b], alt_ref[a:b], vu_ref[a:b], out_every))
        if g is not None:
            nav.dt = float(dts[g])
            outs.append(nav.run(d_th[g : g + 1], d_v[g : g + 1], alt_ref[g : g + 1],
                                vu_ref[g : g + 1], out_every))  # fmt: skip
            nav.dt = dt
            a = g + 1
    return np.concatenate(outs) if outs else np.empty((0, 10))


__all__ = [
    "BLOCK_S",
    "MIN_WINDOW_S",
    "BlockStats",
    "Blocks",
    "CausalModelCompensator",
    "Noise",
    "PieceCompensator",
    "RecordedRun",
    "Reference",
    "TableUnwrap",
    "Window",
    "align_config",
    "check_at_rest",
    "check_encoder",
    "estimate_noise",
    "find_window",
    "navigate_recording",
    "quiet_blocks",
    "recording_frame",
    "seen_schedule",
]

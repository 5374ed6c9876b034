"""What moves in a recording: which seconds are quiet, judged on what quantisation cannot hide.

The inertial-frame coarse alignment and the zero-velocity filter need the IMU's *centre* at
rest; the table's own turn is allowed (the gyros follow it). A real recording starts with
people moving about the vehicle, and a navigation-grade unit's coarse counts (125 µg·s at
100 Hz: 12.5 mg a sample) hide their sway sample by sample; the sums do not (a sum of counts
with the remainder carried is exact to one count). So a second is judged on:

- the spread of ``|f|`` within it and the step of its mean (the sensor noise at its floor,
  where at least a tenth of the recording is at rest), where a second holds several samples;
- the largest deviation of its 0.1 s means of the force and of the rate beyond the table's
  turn from its own mean (a sway at a few hertz), from the first pass
  (:class:`~rinscal.nav.recorded.blocks.BlockStats`);
- the step of its mean force and rate from the second before (a spike of one sample is not
  a step), and the step of the horizontal force's mean over a few seconds (a tilt), all
  turned back with the table and only where it stands;

each against a limit from the recording's own quiet part (:func:`robust_limit`: median and
MAD, never a constant tuned to one unit), with the Earth rate's and gravity's size for
floors. At a low rate (a second of fewer than :data:`MIN_SPREAD_SAMPLES` samples) the steps
between samples judge it. Where it moved is reported (:class:`Disturbance`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rinscal import earth, units
from rinscal.nav.recorded.blocks import BLOCK_S, Blocks

__all__ = [
    "FLOOR_PERCENTILE",
    "MAX_LISTED",
    "MERGE_S",
    "MIN_SPREAD_SAMPLES",
    "MOTION_K",
    "QUIET_FACTOR",
    "TABLE_RATE_DPS",
    "TABLE_STILL_DPS",
    "TILT_SPAN",
    "Disturbance",
    "Motion",
    "motion",
    "quiet_blocks",
    "robust_limit",
    "table_frame",
]

#: A turn of the table about z: |ω_z − Ω sin L| above this [°/s] (a table turns at 1-20 °/s).
TABLE_RATE_DPS = 1.0
#: The table stands while it turns slower than this [°/s] (the Earth rate is 0.004 °/s).
TABLE_STILL_DPS = 0.1
#: A block is quiet when the spread of ``|f|`` within it is at most this many times the floor.
QUIET_FACTOR = 3.0
#: Percentile of the per-second spread of ``|f|`` taken as the noise floor.
FLOOR_PERCENTILE = 10.0
#: A statistic of motion beyond its quiet median by this many robust standard deviations
#: (1.4826 × MAD of the quieter part) is motion.
MOTION_K = 6.0
#: A block holding fewer samples than this has no spread judged (a low rate): the steps
#: between blocks are.
MIN_SPREAD_SAMPLES = 4
#: Seconds of motion closer than this are reported as one disturbed stretch [s].
MERGE_S = 30.0
#: Tilt steps listed per disturbed stretch (and disturbed stretches said).
MAX_LISTED = 5
#: Seconds before and after a step whose medians tell a tilt step from noise.
TILT_SPAN = 5


def _angle(blocks: Blocks) -> NDArray[np.float64]:
    """The table's angle at each block's middle [rad]: the encoder's, else the z gyro's turn."""
    if blocks.has_table:
        turn = blocks.table_turn
        return blocks.table_start + np.cumsum(turn) - 0.5 * turn
    turn = blocks.w_mean[:, 2] * np.maximum(blocks.t1 - blocks.t0, 0.0)
    return np.cumsum(turn) - 0.5 * turn


def table_frame(blocks: Blocks) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each block's mean force and rate turned back with the table into its fixed frame.

    Returns ``(f, w)`` [m/s², rad/s], shape (m, 3): x-y turned by the table's angle (the
    encoder's, else the z gyro's turn), so that what is fixed to the base (gravity, the Earth
    rate, a tilt) stays put while the table turns; ``w``'s z less the encoder's turn (without
    an encoder: z as it is).
    """
    phi = _angle(blocks)
    c, s = np.cos(phi), np.sin(phi)

    def turned(v: NDArray[np.float64]) -> NDArray[np.float64]:
        out = v.copy()
        out[:, 0] = c * v[:, 0] - s * v[:, 1]
        out[:, 1] = s * v[:, 0] + c * v[:, 1]
        return out

    return turned(blocks.f_mean), turned(blocks.rate_less_table())


def robust_limit(x: NDArray[np.float64], floor: float = 0.0) -> tuple[float, float, float]:
    """The level, robust scale and limit of a statistic of motion, from its quieter part.

    Starting from the lower half of the values, the median ``c`` and ``s = 1.4826 × MAD`` of
    those below ``c + K·s`` (:data:`MOTION_K`) are iterated to a fixed point: the values of
    the quiet part (at least half of them) set the limit, a disturbance of any size does not.
    The limit is at least ``3 c``, 4 × the 10th percentile of the values above round-off (a
    coarse count makes most steps 0 and the rest a count or two: their median and MAD 0)
    and ``floor`` (motion too small to matter).

    Returns
    -------
    (c, s, limit)
        NaN where no value is finite.
    """
    v = np.asarray(x, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan, math.nan, math.nan
    half = float(np.median(v))
    sel = v <= half
    c = s = 0.0
    for _ in range(30):
        q = v[sel]
        c = float(np.median(q))
        s = 1.4826 * float(np.median(np.abs(q - c)))
        new = (v <= c + MOTION_K * s) | (v <= half)
        if np.array_equal(new, sel):
            break
        sel = new
    pos = v[v > 1e-6 * float(np.max(v))]  # above round-off
    count = float(np.percentile(pos, 10)) if pos.size else 0.0  # a coarse count's step
    return c, s, max(c + MOTION_K * s, 3.0 * c, 4.0 * count, floor)


def _despiked(v: NDArray[np.float64], ok: NDArray[np.bool_]) -> NDArray[np.float64]:
    """``v`` with each lone outlier (a block far from both neighbours, which agree) replaced
    by its neighbours' mean: "far" beyond the robust limit of the steps between blocks."""
    near = _dist(v, ok, 0, -1)
    _, _, lim = robust_limit(near)
    if not math.isfinite(lim):
        return v
    after, across = _dist(v, ok, 0, 1), _dist(v, ok, 1, -1)
    with np.errstate(invalid="ignore"):
        spike = (near > lim) & (after > lim) & (across <= lim)
    out = v.copy()
    k = np.flatnonzero(spike)
    out[k] = 0.5 * (v[k - 1] + v[k + 1])
    return out


def _dist(v: NDArray[np.float64], ok: NDArray[np.bool_], i: int, j: int) -> NDArray[np.float64]:
    """|v_(k+i) − v_(k+j)| (norm) for every k; NaN where either is outside or not ``ok``."""
    m = v.shape[0]
    x = v.reshape(m, -1)
    out = np.full(m, np.nan)
    lo, hi = max(0, -i, -j), min(m, m - i, m - j)
    if hi > lo:
        a = x[lo + i : hi + i] - x[lo + j : hi + j]
        good = ok[lo + i : hi + i] & ok[lo + j : hi + j]
        out[lo:hi] = np.where(good, np.sqrt(np.sum(a * a, axis=1)), np.nan)
    return out


def _tilt_steps(
    fh: NDArray[np.float64], ok: NDArray[np.bool_]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Steps of the horizontal force's level (:func:`_level_steps`, lone outliers out), and
    where one is a tilt step: the largest within :data:`TILT_SPAN` seconds either side (the
    seconds about a step see part of it) and 4 × beyond what the scatter of the seconds on
    either side gives the difference of their means (noise, a sway, a vehicle starting off
    are not a step)."""
    level = _level_steps(_despiked(fh, ok), ok)
    m, span = fh.shape[0], TILT_SPAN
    clear = np.zeros(m, dtype=bool)
    if m < 2 * span:
        return level, clear
    c1 = np.concatenate([np.zeros((1, 2)), np.cumsum(fh, axis=0)])
    c2 = np.concatenate([np.zeros((1, 2)), np.cumsum(fh * fh, axis=0)])
    k = np.arange(span, m - span + 1)

    def var(a: NDArray[np.int64], b: NDArray[np.int64]) -> NDArray[np.float64]:
        s1, s2 = c1[b] - c1[a], c2[b] - c2[a]
        return np.maximum(s2 / span - (s1 / span) ** 2, 0.0).mean(axis=1)

    scatter = np.sqrt(0.5 * (var(k - span, k) + var(k, k + span)))
    lv = np.where(np.isfinite(level), level, -np.inf)
    pad = np.concatenate([np.full(span - 1, -np.inf), lv, np.full(span - 1, -np.inf)])
    top = np.lib.stride_tricks.sliding_window_view(pad, 2 * span - 1).max(axis=1)
    with np.errstate(invalid="ignore"):
        clear[k] = (lv[k] >= top[k]) & (level[k] > 4.0 * scatter * math.sqrt(2.0 / span))
    return level, clear


def _level_steps(v: NDArray[np.float64], ok: NDArray[np.bool_]) -> NDArray[np.float64]:
    """|mean(v_k … v_(k+S−1)) − mean(v_(k−S) … v_(k−1))| (S = :data:`TILT_SPAN`): a step of
    the level at block k, seen through S times less noise than one block's (and a count's
    quantisation S times finer). NaN unless all 2S blocks are ``ok`` and consecutive."""
    m, span = v.shape[0], TILT_SPAN
    out = np.full(m, np.nan)
    if m < 2 * span:
        return out
    x = v.reshape(m, -1)
    c = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0)])
    bad = np.concatenate([[0], np.cumsum(~ok)])
    k = np.arange(span, m - span + 1)
    d = (c[k + span] - 2 * c[k] + c[k - span]) / span
    good = (bad[k + span] - bad[k - span]) == 0
    out[k] = np.where(good, np.sqrt(np.sum(d * d, axis=1)), np.nan)
    return out


def _steps(v: NDArray[np.float64], ok: NDArray[np.bool_]) -> NDArray[np.float64]:
    """The step of ``v`` between consecutive blocks k−1 and k, a lone outlier left out.

    The smallest of ``|v_k − v_(k−1)|``, ``|v_(k+1) − v_(k−1)|`` and ``|v_k − v_(k−2)|``
    (norms): a step that lasts is in all three, a spike of one block (an outlier sample at a
    low rate) misses one of them on either side. NaN unless the four blocks are all ``ok``
    and consecutive.
    """
    # NaN where one is missing: a spike could not be told from a step
    return np.minimum(np.minimum(_dist(v, ok, 0, -1), _dist(v, ok, 0, -2)), _dist(v, ok, 1, -1))


@dataclass(frozen=True)
class Disturbance:
    """A stretch of the recording in which the IMU moved (merged seconds of motion).

    Attributes
    ----------
    start_s, end_s : float [s]
    seconds : int
        Seconds in it that moved.
    gyro_peak_dph : float [°/h]
        NaN unless the gyros moved in it; else the largest rate beyond rest and the
        table's turn (a 0.1 s mean's deviation from its second, or a step between seconds).
    accel_peak_mg : float [mg]
        NaN unless the short means moved; else the largest deviation of a short mean of the
        force from its second's.
    tilt_steps : tuple of (time [s], size [arcsec])
        Steps of the mean horizontal force between seconds beyond the noise that last (its
        medians over :data:`TILT_SPAN` seconds before and after differ by as much; the
        table's turn taken out), as tilts: the :data:`MAX_LISTED` largest, in time order.
    tilt_count : int
        All such steps.
    step_peak_ug : float [µg]
        NaN unless the force stepped in it; else the largest step of the force between
        seconds (or of its means over :data:`TILT_SPAN` seconds).
    """

    start_s: float
    end_s: float
    seconds: int
    gyro_peak_dph: float
    accel_peak_mg: float
    tilt_steps: tuple[tuple[float, float], ...] = ()
    tilt_count: int = 0
    step_peak_ug: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        return {
            "start_s": self.start_s,
            "end_s": self.end_s,
            "seconds_moving": self.seconds,
            "gyro_peak_dph": self.gyro_peak_dph if math.isfinite(self.gyro_peak_dph) else None,
            "accel_peak_mg": self.accel_peak_mg if math.isfinite(self.accel_peak_mg) else None,
            "tilt_steps": [{"time_s": t, "arcsec": a} for t, a in self.tilt_steps],
            "tilt_count": self.tilt_count,
            "step_peak_ug": self.step_peak_ug if math.isfinite(self.step_peak_ug) else None,
        }

    def text(self) -> str:
        """``"0-540 s disturbed: gyro peaks 730 °/h, tilt steps at 120, 540 s (35″, 80″)"``."""
        parts = []
        if math.isfinite(self.gyro_peak_dph):
            parts.append(f"gyro peaks {self.gyro_peak_dph:.0f} °/h")
        if math.isfinite(self.accel_peak_mg):
            parts.append(f"force {self.accel_peak_mg:.2g} mg in 0.1 s")
        if not parts and not self.tilt_steps and math.isfinite(self.step_peak_ug):
            parts.append(f"force steps up to {self.step_peak_ug:.0f} µg between seconds")
        if not parts and not self.tilt_steps:
            parts.append("|f| unsteady within its seconds")
        if self.tilt_steps:
            at = ", ".join(f"{t:.0f}" for t, _ in self.tilt_steps)
            size = ", ".join(f"{a:.0f}″" for _, a in self.tilt_steps)
            n = max(len(self.tilt_steps), self.tilt_count)
            more = (
                f", the clearest {len(self.tilt_steps)} of {n}" if n > len(self.tilt_steps) else ""
            )
            parts.append(f"tilt step{'s' if n > 1 else ''} at {at} s ({size}{more})")
        return f"{self.start_s:.0f}-{self.end_s:.0f} s disturbed: " + ", ".join(parts)


@dataclass(frozen=True)
class Motion:
    """Which seconds of a recording are quiet, and what moved where.

    Attributes
    ----------
    quiet : ndarray of bool
        Per block (one loud second between quiet ones forgiven, unless the force stepped).
    floor, threshold : float [m/s²]
        The spread of ``|f|`` within a second: its floor and the limit (NaN at a low rate).
    limits : dict
        The limit of each statistic judged, in °/h or µg (``gyro_dev_xy_dph`` ...).
    disturbed : tuple of Disturbance
    judged : str
        What was judged, in words (for a refusal).
    """

    quiet: NDArray[np.bool_]
    floor: float
    threshold: float
    limits: dict[str, float]
    disturbed: tuple[Disturbance, ...]
    judged: str


def motion(blocks: Blocks) -> Motion:
    """Which seconds are quiet, judged on what quantisation cannot hide.

    A second is loud when any of these lies beyond its limit (:func:`robust_limit`, from the
    recording's own quiet seconds):

    - the spread of ``|f|`` within it beyond :data:`QUIET_FACTOR` × its floor (the
      :data:`FLOOR_PERCENTILE`-th percentile), or its mean's step from the second before
      beyond that (only where a block holds :data:`MIN_SPREAD_SAMPLES` samples or more: at a
      low rate the steps below judge it);
    - the largest deviation of a 0.1 s mean of the force, or of the rate beyond the
      table's turn, from its second's mean (a sway at a few hertz);
    - the step of the mean force or of the mean rate beyond the Earth rate and the table's
      turn, from the second before (both turned back with the table; a spike of one sample
      is not a step), and the step of the horizontal force's mean over :data:`TILT_SPAN`
      seconds from its mean over as many before (a tilt), judged between seconds in which
      the table stands (:data:`TABLE_STILL_DPS`: a turn moves the biases against the tilt).

    One loud second between quiet ones (a turntable starting with a jerk) is forgiven, unless
    the force stepped (a tilt lasts). The z rate is not judged on a turntable the log has no encoder
    for (its turn is allowed, and its starts and stops would read as motion). Blocks with
    fewer than half the usual samples (the recording's ends) or a gap are never quiet.
    """
    full = blocks.n >= 0.5 * np.median(blocks.n)
    if blocks.gaps is not None:  # the aligner steps by the nominal interval: no gap in it
        full = full & ~blocks.gaps
    # steps only between consecutive blocks the table stands in: a turn moves the biases
    # (IMU-fixed) against the tilt and the Earth rate (base-fixed), a step in either frame
    ok = full & blocks.consecutive() & blocks.table_still(TABLE_STILL_DPS)
    g = 9.80665
    ug, dph = units.UG_TO_MPS2, units.DPH_TO_RPS
    f_floor, w_floor = 1e-5 * g, 0.1 * earth.RATE  # 10 µg (2″ of tilt), 1.5 °/h
    spread = BLOCK_S / blocks.dt >= MIN_SPREAD_SAMPLES - 1e-9  # the rate, not a short log's
    sd = blocks.fmag_sd
    floor = float(np.percentile(sd[full], FLOOR_PERCENTILE)) if full.any() else math.nan
    loud = np.zeros(blocks.size, dtype=bool)
    limits: dict[str, float] = {}
    thr = math.nan
    if spread:
        thr = QUIET_FACTOR * max(floor, 1e-9)
        jump = np.abs(np.diff(blocks.fmag_mean, prepend=blocks.fmag_mean[:1]))
        loud |= (sd > thr) | (jump > thr)
    turning = (
        not blocks.has_table
        and int(np.sum(np.abs(blocks.w_mean[:, 2]) > TABLE_RATE_DPS * units.DEG_TO_RAD)) >= 3
    )
    f_tab, w_tab = table_frame(blocks)
    level, clear = _tilt_steps(f_tab[:, :2], ok)
    stats: list[tuple[str, NDArray[np.float64] | None, float, float]] = [
        ("accel_dev_ug", blocks.f_dev, f_floor, ug),
        ("gyro_dev_xy_dph", blocks.w_dev_xy, w_floor, dph),
        ("gyro_dev_z_dph", None if turning else blocks.w_dev_z, w_floor, dph),
        ("accel_step_ug", _steps(f_tab, ok), f_floor, ug),
        ("tilt_step_ug", level, f_floor, ug),
        ("gyro_step_xy_dph", _steps(w_tab[:, :2], ok), w_floor, dph),
        ("gyro_step_z_dph", None if turning else _steps(w_tab[:, 2], ok), w_floor, dph),
    ]
    beyond: dict[str, NDArray[np.bool_]] = {}
    for name, x, fl, unit in stats:
        if x is None or not np.isfinite(x[full]).any():
            continue
        _, _, lim = robust_limit(x[full], fl)
        limits[name] = lim / unit
        beyond[name] = full & np.isfinite(x) & (x > lim)
        if name == "tilt_step_ug":
            beyond[name] &= clear
        loud |= beyond[name]
    quiet = full & ~loud
    lone = np.zeros_like(quiet)
    lone[1:-1] = ~quiet[1:-1] & quiet[:-2] & quiet[2:] & full[1:-1]
    for name in ("accel_step_ug", "tilt_step_ug"):
        if name in beyond:  # a step of the force that lasts (a tilt) is not a jerk to forgive
            lone &= ~beyond[name]
    quiet = quiet | lone
    moved = full & ~quiet
    # what moved where: loud seconds closer than MERGE_S are one stretch
    disturbed: list[Disturbance] = []
    gyro = np.zeros(blocks.size)
    gyro_moved = np.zeros(blocks.size, dtype=bool)
    for name, x, _, _ in stats:
        if x is not None and name.startswith("gyro") and name in beyond:
            gyro = np.fmax(gyro, np.where(np.isfinite(x), x, 0.0))
            gyro_moved |= beyond[name]
    tilt = beyond.get("tilt_step_ug", np.zeros(blocks.size, dtype=bool))
    lim_tilt = limits.get("tilt_step_ug", math.inf) * ug
    idx = np.flatnonzero(moved)
    if idx.size:
        cut = np.flatnonzero(blocks.t0[idx[1:]] - blocks.t1[idx[:-1]] >= MERGE_S) + 1
        for grp in np.split(idx, cut):
            a, b = int(grp[0]), int(grp[-1]) + 1
            fd = blocks.f_dev[a:b] if blocks.f_dev is not None else np.array([])
            lo = max(a - TILT_SPAN, 0)
            steps = [
                (level[k] / lim_tilt, float(blocks.t0[k]), level[k] / g)
                for k in np.flatnonzero(tilt[lo : b + TILT_SPAN]) + lo
            ]
            # the clearest (against the motion about them), in time order
            big = sorted(
                (tk, tilt_rad / units.ARCSEC_TO_RAD)
                for _, tk, tilt_rad in sorted(steps)[::-1][:MAX_LISTED]
            )
            disturbed.append(
                Disturbance(
                    start_s=float(blocks.t0[a]),
                    end_s=float(blocks.t1[b - 1]),
                    seconds=int(grp.size),
                    gyro_peak_dph=float(np.max(gyro[a:b])) / dph
                    if gyro_moved[a:b].any()
                    else math.nan,
                    accel_peak_mg=float(np.nanmax(fd)) / (1e3 * ug)
                    if "accel_dev_ug" in beyond and beyond["accel_dev_ug"][a:b].any()
                    else math.nan,
                    step_peak_ug=max(
                        (
                            float(np.nanmax(x[a:b], initial=0.0)) / ug
                            for n_, x, _, _ in stats
                            if n_ in beyond and n_.endswith("step_ug") and beyond[n_][a:b].any()
                        ),
                        default=math.nan,
                    ),
                    tilt_steps=tuple(big),
                    tilt_count=len(steps),
                )
            )
    said = [f"{k} ≤ {v:.3g}" for k, v in limits.items()]
    if spread:
        said.insert(
            0,
            f"the spread of |f| within a second at most {thr / ug:.0f} µg, {QUIET_FACTOR:g} × "
            f"the recording's floor of {floor / ug:.0f} µg",
        )
        judged = ", ".join(said)
    else:
        judged = (
            f"at {1 / blocks.dt:.3g} Hz (fewer than {MIN_SPREAD_SAMPLES} samples a second) the "
            f"steps between samples: {', '.join(said) or 'too few samples to judge'}"
        )
    return Motion(quiet, floor, thr, limits, tuple(disturbed), judged)


def quiet_blocks(blocks: Blocks) -> tuple[NDArray[np.bool_], float, float]:
    """Which seconds are quiet (:func:`motion`), the floor and the threshold of ``|f|``'s
    spread [m/s²] (NaN at a low rate)."""
    m = motion(blocks)
    return m.quiet, m.floor, m.threshold

"""The first pass over a recording: per-second sums (:class:`BlockStats` into :class:`Blocks`).

Every second of the recording is summed: the specific force magnitude ``|f|`` (its mean and
spread), the mean rate and force vectors, the spread of first differences (white noise) and
the encoder's turn (:class:`TableUnwrap`); and every tenth of a second (:data:`SUB_S`): the
mean force and rate, whose largest deviation from their second's mean is what a sway at a
few hertz leaves where a coarse count hides it sample by sample (a sum over k samples of
counts with the remainder carried is exact to one count). The window, noise and checks of
:mod:`rinscal.nav.recorded.window` are computed from these sums.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rinscal import _kernels, units
from rinscal.errors import LogError
from rinscal.schema import GAP_FACTOR, NavSamples

__all__ = [
    "BLOCK_S",
    "ENCODER_JUMP_DEG",
    "ENCODER_JUMP_DPS",
    "SUB_S",
    "BlockStats",
    "Blocks",
    "TableUnwrap",
]

#: Length of the blocks the first pass sums over [s].
BLOCK_S = 1.0
#: Length of the short blocks within a second whose means the first pass compares [s].
SUB_S = 0.1
#: Short blocks in a second.
SUBS = round(BLOCK_S / SUB_S)
#: An encoder step in one sample that differs from the gyro's turn about z by more than
#: this [deg] (or than this rate [deg/s] times the interval, if larger) is a jump.
ENCODER_JUMP_DEG = 5.0
ENCODER_JUMP_DPS = 200.0


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
    f_dev : ndarray, optional [m/s²]
        Largest deviation (norm) of the block's :data:`SUB_S` means of the force from its
        mean, both turned with the table into the frame of the block's mid (the encoder's
        angle, else the z gyro's); NaN for a block holding fewer than two short blocks (a
        rate below 20 Hz).
    w_dev_xy, w_dev_z : ndarray, optional [rad/s]
        The same of the rate: its x-y part (turned with the table), and z less the encoder's
        turn (without an encoder: z as it is).
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
    f_dev: NDArray[np.float64] | None = None
    w_dev_xy: NDArray[np.float64] | None = None
    w_dev_z: NDArray[np.float64] | None = None

    @property
    def size(self) -> int:
        return int(self.n.size)

    def select(self, start_s: float, end_s: float) -> NDArray[np.bool_]:
        """Blocks lying within ``[start_s, end_s]`` (to half a block)."""
        return (self.t0 >= start_s - 0.5 * BLOCK_S) & (self.t1 <= end_s + 0.5 * BLOCK_S)

    @property
    def span(self) -> NDArray[np.float64]:
        """Each block's length [s] (at least 1 ns: a block of one sample has none)."""
        return np.maximum(self.t1 - self.t0, 1e-9)

    def turn(self) -> NDArray[np.float64]:
        """The table's turn in each block [rad]: the encoder's, else the z gyro's."""
        return self.table_turn if self.has_table else self.w_mean[:, 2] * self.span

    def table_still(self, limit_dps: float) -> NDArray[np.bool_]:
        """Blocks in which the table turns slower than ``limit_dps`` [deg/s]."""
        return np.abs(self.turn()) < limit_dps * units.DEG_TO_RAD * self.span

    def consecutive(self) -> NDArray[np.bool_]:
        """Blocks that follow the one before without a gap (the first: True)."""
        ok = np.ones(self.size, dtype=bool)
        ok[1:] = (self.t0[1:] - self.t1[:-1]) <= 1.5 * self.dt
        return ok

    def rate_less_table(self) -> NDArray[np.float64]:
        """Each block's mean rate [rad/s], z less the encoder's turn (no encoder: as read)."""
        w = self.w_mean.copy()
        if self.has_table:
            w[:, 2] -= self.table_turn / self.span
        return w


class TableUnwrap:
    """Unwraps an encoder angle across pieces (±180° or 0-360° wrap-around): a step of more
    than half a turn between two samples is taken as the wrap."""

    def __init__(self) -> None:
        self._raw: float | None = None
        self._unwrapped = 0.0

    def __call__(self, angle: NDArray[np.float64]) -> NDArray[np.float64]:
        """Continuous angle [rad] from wrapped readings [rad] (one pass,
        :func:`rinscal._kernels.unwrap_angle`: the bits of ``numpy.unwrap`` across pieces)."""
        a = np.ascontiguousarray(angle, dtype=float)
        if a.size == 0:
            return a
        u = np.empty_like(a)
        first = self._raw is None
        raw = 0.0 if self._raw is None else self._raw
        _kernels.unwrap_angle(a, raw, self._unwrapped, first, u)
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
        self._psi = 0.0  # the z gyro's turn so far, without encoder [rad]
        self._subs: list[dict[str, NDArray]] = []

    def add(self, s: NavSamples) -> None:
        """Add one piece (in time order)."""
        if s.n == 0:
            return
        if self._origin is None:
            self._origin = float(s.t[0] - s.dt[0])
            self._has_table = s.table is not None
        dt = s.dt
        # the blocks the piece spans: those of its first and last samples (time increases),
        # the index rounded as the kernel rounds it
        lo = math.floor((float(s.t[0]) - 0.5 * float(dt[0]) - self._origin) / BLOCK_S)
        m = math.floor((float(s.t[-1]) - 0.5 * float(dt[-1]) - self._origin) / BLOCK_S) - lo + 1
        if self._prev_w is None:  # the first sample's difference: none
            self._prev_w, self._prev_f = s.dtheta[0] / dt[0], s.dv[0] / dt[0]
        first_table = s.table is not None and self._prev_table is None
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
            psi = u  # the angle the table stands at
        else:
            turn = np.zeros(s.n)
            psi = self._psi + np.cumsum(s.dtheta[:, 2])  # without encoder: the z gyro's
            self._psi = float(psi[-1])
        # the nominal step: the mean of the intervals that are not gaps (a clock in whole
        # ms gives 7 and 8 ms intervals for 128 Hz: the median would be 8 ms)
        med = float(np.median(dt))
        ok = dt <= GAP_FACTOR * med
        self._dt_sum += float(dt[ok].sum())
        self._dt_sq += float((dt[ok] ** 2).sum())
        self._dt_n += int(ok.sum())
        # every sum of the piece in one pass over its samples (a kernel that releases the
        # GIL): per second, and every SUB_S within each second
        sums = np.zeros((m, _kernels.SECOND_SUMS))
        sub = np.zeros((m * SUBS, _kernels.SUB_SUMS))
        first = np.full(m, np.inf)
        last = np.full(m, -np.inf)
        c = np.ascontiguousarray
        _kernels.piece_sums(
            c(s.t), c(dt), c(s.dtheta), c(s.dv), self._origin, BLOCK_S, lo, SUBS,
            self._prev_w, self._prev_f, c(turn), s.table is not None, first_table,
            c(psi, dtype=float), GAP_FACTOR * med, sums, sub, first, last,
        )  # fmt: skip
        self._prev_w, self._prev_f = s.dtheta[-1] / dt[-1], s.dv[-1] / dt[-1]
        full = np.flatnonzero(sub[:, 0])
        sub = sub[full]
        keys = ("n", "fx", "fy", "fz", "wx", "wy", "wz", "psi")  # the kernel's columns
        self._subs.append({"id": lo * SUBS + full} | {key: sub[:, j] for j, key in enumerate(keys)})
        self._parts.append(
            {
                "id": np.arange(lo, lo + m),
                "t0": first,
                "t1": last,
                "n": sums[:, 0],
                "fm": sums[:, 1],
                "fm2": sums[:, 2],
                "f": sums[:, 3:6],
                "w": sums[:, 6:9],
                "df2": sums[:, 9:12],
                "dw2": sums[:, 12:15],
                "turn": sums[:, 15],
                "gap": sums[:, 16],
            }
        )

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
        f_dev, w_dev_xy, w_dev_z = self._short_blocks(u[keep])
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
            f_dev=f_dev,
            w_dev_xy=w_dev_xy,
            w_dev_z=w_dev_z,
        )

    def _short_blocks(self, blocks: NDArray[np.int64]) -> tuple[NDArray, NDArray, NDArray]:
        """Per block (ids ``blocks``): the largest deviation of its short blocks' mean force,
        x-y rate and z rate from the block's own, turned into the frame of the block's mid."""
        ids = np.concatenate([p["id"] for p in self._subs])
        u, inv = np.unique(ids, return_inverse=True)
        mu = u.size

        def merged(key: str) -> NDArray:
            x = np.concatenate([p[key] for p in self._subs])
            return np.bincount(inv, weights=x, minlength=mu)

        n = merged("n")
        b = np.searchsorted(blocks, u // SUBS)  # every short block lies in a kept block
        nb = np.bincount(b, weights=n, minlength=blocks.size)
        count = np.bincount(b, minlength=blocks.size)
        psi = merged("psi") / n
        rel = psi - (np.bincount(b, weights=psi * n, minlength=blocks.size) / nb)[b]
        c, sn = np.cos(rel), np.sin(rel)

        def turned(kx: str, ky: str) -> tuple[NDArray, NDArray]:
            x, y = merged(kx) / n, merged(ky) / n  # a body-fixed vector, seen by the IMU
            return c * x - sn * y, sn * x + c * y  # turned by rel, is the same all second

        def dev(parts: list[NDArray]) -> NDArray:
            sq = np.zeros(mu)
            for p in parts:
                mean = np.bincount(b, weights=p * n, minlength=blocks.size) / nb
                sq += (p - mean[b]) ** 2
            start = np.flatnonzero(np.diff(b, prepend=-1))  # b is sorted: each block's first
            out = np.full(blocks.size, np.nan)
            out[b[start]] = np.sqrt(np.maximum.reduceat(sq, start))
            out[count < 2] = np.nan
            return out

        fx, fy = turned("fx", "fy")
        wx, wy = turned("wx", "wy")
        return dev([fx, fy, merged("fz") / n]), dev([wx, wy]), dev([merged("wz") / n])

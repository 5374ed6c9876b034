"""The second pass over a recording: the variants (uncompensated, one per model) navigated
side by side (:func:`navigate_recording`).

Every variant's compensator sees every sample from the first on (its temperature history is
causal), the aligner the window, the strapdown everything after it; the position errors are
taken against the :class:`Reference` (a known site or a track).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import earth
from rinscal.errors import ConfigError, LogError
from rinscal.nav.aiding import Measurement
from rinscal.nav.align import AlignConfig, Aligner
from rinscal.nav.engine import AidedFilter, NavResult, navigate_pieces
from rinscal.nav.recorded.blocks import TableUnwrap
from rinscal.nav.recorded.compensation import PieceCompensator, _ffill
from rinscal.nav.recorded.window import Window
from rinscal.nav.strapdown import VerticalMode
from rinscal.schema import NavSamples

__all__ = [
    "RecordedRun",
    "Reference",
    "navigate_recording",
]


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
    aiding: Sequence[Measurement] = (),
    aided_filter: AidedFilter | None = None,
    aligner: Callable[[int], Any] | None = None,
    progress: Callable[[float], None] | None = None,
    n_jobs: int | None = 1,
) -> NavResult:
    """Navigate a recording's variants side by side (the second pass; the pieces with their
    reference through :func:`rinscal.nav.engine.navigate_pieces`).

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
    aiding, aided_filter
        Aiding after the alignment (:func:`rinscal.nav.engine.navigate_pieces`); none:
        pure inertial.
    aligner : callable, optional
        ``aligner(k0)``: the alignment from sample ``k0`` on (e.g.
        :class:`rinscal.nav.inmotion.InMotionAligner`); default the zero-velocity
        :class:`~rinscal.nav.align.Aligner` at the reference's site.
    n_jobs : int or None
        Threads for the variants of each piece, the next piece read on one more (None or 0:
        every core; :func:`rinscal.nav.engine.navigate_pieces`). The result does not depend
        on it.

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
    comps = {"none": None} if compensators is None else dict(compensators)
    if not comps:
        raise ConfigError("navigate_recording: need at least one variant")
    out_every = round(out_dt_s / dt)
    if out_every < 1:
        raise ConfigError(f"output interval {out_dt_s} s is shorter than a sample ({dt} s)")

    def at_rest(k0: int) -> Aligner:
        return Aligner(reference.lat, reference.lon, reference.h, dt, align, vertical, k0=k0)

    run = navigate_pieces(
        pieces,
        _LogTruth(reference, use_heading_column),
        comps,
        dt=dt,
        start_s=window.start_s,
        out_every=out_every,
        aligner=at_rest if aligner is None else aligner,
        correct_warm_up=True,
        aiding=aiding,
        aided_filter=aided_filter,
        progress=progress,
        n_jobs=n_jobs,
        read_ahead=True,
    )
    t_last = run.t_last
    if run.n_start is None:
        raise LogError(f"the alignment window ({window.start_s:g} s) starts after the recording")
    if not run.aligned:
        raise LogError(
            f"the recording ends at {t_last:.1f} s, before the alignment "
            f"({window.start_s:g} s + {window.length_s:g} s) does"
        )
    truth = run.truth
    if truth.shape[0] == 0:
        raise LogError(
            f"the recording ends at {t_last:.1f} s, when the alignment "
            f"({window.start_s:g} s + {window.length_s:g} s) does: nothing is left to "
            "navigate (a shorter align_s=, or a longer recording)"
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
    truth_df = truth_df[keep].reset_index(drop=True)
    config = RecordedRun(
        name=name,
        duration_s=t_last - run.t_origin,
        rate_hz=1.0 / dt,
        align_start_s=run.t_align,
        nav_start_s=run.t_nav,
        align=align,
        schedule=_Named(schedule),
        trajectory=_Site(reference.lat, reference.lon),
        time_origin_s=run.t_origin,
        notes=tuple(notes),
    )
    return NavResult(config, truth_df, run.errors, run.alignment)


@dataclass(frozen=True)
class _PieceReference:
    """The reference at one piece's samples (:class:`rinscal.nav.engine.PieceTruth`)."""

    t: NDArray[np.float64]
    ref: NDArray[np.float64]  # (n, 6): lat, lon, h, v_e, v_n, v_u
    valid: NDArray[np.bool_]
    table: NDArray[np.float64]
    heading: NDArray[np.float64] | None  # the log's column (None: none)
    static: bool  # no track: the body stands
    owner: _LogTruth

    @property
    def alt(self) -> NDArray[np.float64]:
        return self.ref[:, 2]

    @property
    def vu(self) -> NDArray[np.float64]:
        return self.ref[:, 5]

    def rows(self, sel: NDArray[np.bool_]) -> NDArray[np.float64]:
        o = self.owner
        head = np.full(sel.size, np.nan) if self.heading is None else self.heading
        given = o.reference.heading
        if self.heading is None and given is not None:
            if self.static:  # the body stands: its heading is the one given, all along
                head = np.full(sel.size, given)
            elif not o.started:  # a track: the heading given holds at the start only
                head[np.flatnonzero(sel)[0]] = given
        o.started = True
        return np.column_stack(
            [self.t[sel], self.ref[sel], head[sel], np.full((sel.sum(), 2), np.nan),
             self.table[sel], self.valid[sel]]
        )  # fmt: skip


class _LogTruth:
    """Each piece's reference, in time order (the track's and the encoder's state carry)."""

    def __init__(self, reference: Reference, use_heading_column: bool) -> None:
        self.reference = reference
        self.use_heading_column = use_heading_column
        self.track = _LogTrack(reference)
        self.unwrap = TableUnwrap()
        self.started = False  # a row given out

    def __call__(self, s: NavSamples) -> _PieceReference:
        ref, valid = self.track(s)
        table = self.unwrap(s.table) if s.table is not None else np.zeros(s.n)
        static = self.reference.track is None and s.ref is None
        column = s.ref_heading if self.use_heading_column else None
        return _PieceReference(s.t, ref, valid, table, column, static, self)


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

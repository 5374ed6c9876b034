"""One navigation engine: the loop that scenarios and recordings both run.

A stream of pieces, each a :class:`rinscal.schema.NavSamples` (increments in the IMU frame
r, SI) with the truth or reference at its samples, goes through, per variant::

    sensor correction  correction(piece) -> (n, 6) rates [rad/s, m/s²], subtracted
      -> alignment     zero-velocity self-alignment (:class:`rinscal.nav.align.Aligner`)
                       from the sample whose interval starts at ``start_s`` on
      -> strapdown     free navigation (:class:`rinscal.nav.strapdown.Strapdown`), the
                       alignment's bias estimates kept subtracted
      -> errors        INS minus truth every ``out_every`` samples

:func:`navigate_pieces` is that loop; :func:`rinscal.nav.scenario.run_scenario` feeds it the
simulator's chunks, :func:`rinscal.nav.recorded.navigate.navigate_recording` a log's pieces.
Both return a :class:`NavResult`, wrapped with what the run was into a :class:`Navigation`,
whose :attr:`Navigation.summary` is what ``summary.json`` holds (built here, once) and whose
:meth:`Navigation.save` writes a navigation's folder.

Aiding: the alignment is today's zero-velocity measurement inside the aligner; ``aiding=``
of :func:`navigate_pieces` adds measurements (:class:`rinscal.nav.aiding.Measurement`: a
known site, a GNSS track) after it: each variant's strapdown is handed to the 15-state
filter of :mod:`rinscal.nav.gnss_ins` (loosely coupled), which takes them in their time.
Without them the navigation after the alignment is pure inertial, as before.
"""

from __future__ import annotations

import io
import json
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import _kernels
from rinscal.errors import ConfigError
from rinscal.nav.aiding import Measurement
from rinscal.nav.align import Aligner, AlignResult, feed_and_hand_over
from rinscal.nav.gnss_ins import AidedInertial, run_aided
from rinscal.nav.result import NavResult, error_frame
from rinscal.nav.strapdown import Strapdown
from rinscal.parallel import Lanes, map_jobs, resolve_jobs
from rinscal.parallel import read_ahead as _read_ahead
from rinscal.schema import GAP_FACTOR, NavSamples

__all__ = [
    "FIGURE_DPI",
    "TRUTH_COLUMNS",
    "AidedFilter",
    "EngineRun",
    "NavResult",
    "Navigation",
    "PieceCorrection",
    "PieceTruth",
    "error_frame",
    "figure_png",
    "navigate_pieces",
]

#: Resolution of a navigation's figures as PNG [dots per inch].
FIGURE_DPI = 110


def figure_png(fig: Any) -> bytes:
    """A matplotlib figure as the PNG a navigation's folder holds (:data:`FIGURE_DPI`)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=FIGURE_DPI)
    return buf.getvalue()


#: Columns of :meth:`PieceTruth.rows` and :attr:`EngineRun.truth`: time [s], lat, lon
#: [rad], height [m], ENU velocity [m/s ×3], heading, pitch, roll [rad] (NaN: unknown),
#: encoder angle [rad] and whether the truth exists there (1/0).
TRUTH_COLUMNS = (
    "time_s", "lat", "lon", "alt", "v_e", "v_n", "v_u",
    "heading", "pitch", "roll", "encoder", "valid",
)  # fmt: skip

#: A variant's sensor correction: ``correction(piece) -> (n, 6)`` rates [rad/s, m/s²] in r
#: to subtract from the piece's increments (each over its sample's own interval).
PieceCorrection = Callable[[NavSamples], NDArray[np.float64]]


class PieceTruth(Protocol):
    """The truth (or reference) at one piece's samples."""

    #: Reference height [m] and vertical velocity [m/s] per sample (the vertical channel's
    #: hold or damping).
    alt: NDArray[np.float64]
    vu: NDArray[np.float64]

    def rows(self, sel: NDArray[np.bool_]) -> NDArray[np.float64]:
        """The truth at the selected samples, shape (m, 12), columns :data:`TRUTH_COLUMNS`."""
        ...


@dataclass(frozen=True)
class EngineRun:
    """What :func:`navigate_pieces` found.

    Attributes
    ----------
    truth : ndarray, shape (m, 12)
        Truth at the output times, columns :data:`TRUTH_COLUMNS`.
    errors : dict of str to DataFrame
        Per variant, :func:`error_frame` at the output times where the truth exists (none
        before the alignment ends).
    alignment : dict of str to AlignResult or None
        Per variant (None: no alignment, or it did not end).
    aligned : bool
        Every variant's alignment ended (or there was none).
    n_start : int or None
        Samples before the alignment start (None: it never started).
    t_origin, t_last : float [s]
        Start of the first sample's interval, end of the last.
    t_align, t_nav : float [s]
        Start of the alignment, start of free navigation (NaN: not reached).
    """

    truth: NDArray[np.float64]
    errors: dict[str, pd.DataFrame]
    alignment: dict[str, AlignResult | None]
    aligned: bool
    n_start: int | None
    t_origin: float
    t_last: float
    t_align: float
    t_nav: float


@dataclass
class _Variant:
    correction: PieceCorrection | None
    aligner: Aligner | None
    nav: Strapdown | None
    gyro_bias: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    accel_bias: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    rows: list[NDArray[np.float64]] = field(default_factory=list)
    filt: AidedInertial | None = None


#: ``aided_filter(nav, alignment, gyro_bias, accel_bias) -> AidedInertial``: the filter that
#: takes a variant's navigation over once its alignment ended (``alignment`` None: none), its
#: bias estimates [rad/s, m/s²] the alignment's.
AidedFilter = Callable[
    [Strapdown, "AlignResult | None", NDArray[np.float64], NDArray[np.float64]], AidedInertial
]


def navigate_pieces(
    pieces: Iterable[NavSamples],
    truth_of: Callable[[NavSamples], PieceTruth],
    corrections: Mapping[str, PieceCorrection | None],
    *,
    dt: float,
    start_s: float,
    out_every: int,
    aligner: Callable[[int], Aligner] | None = None,
    initial: Callable[[], Strapdown] | None = None,
    correct_warm_up: bool = True,
    aiding: Sequence[Measurement] = (),
    aided_filter: AidedFilter | None = None,
    progress: Callable[[float], None] | None = None,
    n_jobs: int | None = 1,
    read_ahead: bool = False,
) -> EngineRun:
    """Navigate every variant side by side on the same pieces (the one navigation loop).

    Parameters
    ----------
    pieces : iterable of NavSamples
        The increments [rad, m/s] in time order.
    truth_of : callable
        ``truth_of(piece) -> PieceTruth``: the truth at a piece's samples, called once per
        piece in time order (a track's or an encoder's state may carry).
    corrections : mapping of str to PieceCorrection or None
        Variants: each one's sensor correction (None: none), called once per piece.
    dt : float [s]
        Nominal sample interval (the aligner's and the strapdown's step; a longer interval,
        a gap, is integrated with its own length).
    start_s : float [s]
        The alignment starts with the first sample whose interval starts at or after
        ``start_s`` (less a quarter sample); nobody navigates before.
    out_every : int
        Samples between error rows (sample counts from the first, whole multiples).
    aligner : callable, optional
        ``aligner(k0) -> Aligner`` starting ``k0`` samples in, one per variant; free
        navigation from the sample after its end.
    initial : callable, optional
        Without ``aligner``: ``initial() -> Strapdown``, a variant's navigation from the
        start on (e.g. the true initial state).
    correct_warm_up : bool
        Call the corrections on the pieces before the alignment too (a recording's
        compensators keep a temperature history from power-on); else from its start on.
    aiding : sequence of rinscal.nav.aiding.Measurement
        Aiding measurements after the alignment (a known site, a GNSS track); empty: pure
        inertial navigation. The aided stretch steps by ``dt`` (gaps are not stepped over).
    aided_filter : callable, optional
        With ``aiding``: :data:`AidedFilter`, the filter each variant's navigation is
        handed to when its alignment ends (or at the start, without an aligner).
    progress : callable, optional
        ``progress(t_s)`` after each piece, with the end of its last interval [s].
    n_jobs : int or None
        Threads the variants of a piece are spread over (:class:`rinscal.parallel.Lanes`: a
        variant's pieces in order, the variants side by side; None or 0: every core). Each
        variant's state is its own, so the result is the same, bit for bit, whatever the
        number; default 1 (a caller that runs beside others, e.g. on a Dask worker, keeps to
        its core).
    read_ahead : bool
        With ``n_jobs`` other than 1, read the next piece and take its truth on a thread
        while the variants navigate (:func:`rinscal.parallel.read_ahead`), and let a thread
        that has navigated its variant of a piece go on to another variant of the next one
        (two pieces in the variants' hands at most) rather than wait for the slowest. Only
        for a stream that shares no state with the corrections (a file's reader); not for
        the simulator's, whose oracle reads the chunk just drawn.

    Returns
    -------
    EngineRun
    """
    if not corrections:
        raise ConfigError("navigation: need at least one variant")
    if (aligner is None) == (initial is None):
        raise ConfigError("navigation: give an aligner or an initial state, one of them")
    if out_every < 1:
        raise ConfigError(f"navigation: out_every must be >= 1 sample, got {out_every}")
    if aiding and aided_filter is None:
        raise ConfigError("navigation: aiding measurements need an aided_filter")
    variants: dict[str, _Variant] = {}
    n_start = n_nav = None
    truth_rows: list[NDArray[np.float64]] = []
    consumed = 0
    t_origin: float | None = None
    t_last = t_align = t_nav = math.nan
    jobs = resolve_jobs(n_jobs)
    # each piece with its truth (taken on the reading thread when read ahead: truth_of keeps
    # its own state, in the pieces' order); a piece and its truth are freed once every
    # variant has navigated it (peak memory)
    with_truth = ((s, truth_of(s)) for s in pieces if s.n)
    stream = _read_ahead(with_truth, jobs) if read_ahead else with_truth
    # pieces in the variants' hands at once: two of a file's on threads (a thread done with
    # its variant of one takes another variant's of the next); one of a simulator's, whose
    # oracle reads the chunk just drawn, or on one thread
    depth = 2 if read_ahead and jobs > 1 else 1
    ends: list[tuple[int, float]] = []  # (piece, end of its last interval) not yet reported

    def settle(lanes: Lanes, k: float) -> None:
        """Wait for the pieces up to ``k``; report them to ``progress``."""
        lanes.wait(k)
        while ends and ends[0][0] <= k:
            t_end = ends.pop(0)[1]
            if progress is not None:
                progress(t_end)

    with Lanes(jobs) as lanes:
        for k, (s, truth) in enumerate(stream):
            if t_origin is None:
                t_origin = float(s.t[0] - s.dt[0])
            if n_start is None:
                # the alignment starts at the first sample whose interval starts at start_s
                n_before = int(np.searchsorted(s.t - s.dt, start_s - 0.25 * dt))
                if n_before < s.n:
                    n_start = consumed + n_before
                    for name, corr in corrections.items():
                        if aligner is not None:
                            variants[name] = _Variant(corr, aligner(n_start), None)
                        else:
                            assert initial is not None
                            variants[name] = _Variant(corr, None, initial())
                    first = next(iter(variants.values())).aligner
                    n_nav = n_start + (0 if first is None else first.n_total)
            gidx = consumed + np.arange(1, s.n + 1)
            consumed += s.n
            t_last = float(s.t[-1])
            ends.append((k, t_last))
            if n_start is not None and gidx[0] <= n_start + 1 <= gidx[-1]:
                i = n_start - (gidx[0] - 1)
                t_align = float(s.t[i] - s.dt[i])
            if n_nav is not None and gidx[0] <= n_nav <= gidx[-1]:
                t_nav = float(s.t[n_nav - gidx[0]])
            if n_start is None or gidx[-1] <= n_start:  # warming up: nobody navigates
                if correct_warm_up:  # a compensator's history runs from power-on
                    for name, c in corrections.items():
                        if c is not None:
                            lanes.put(name, k, lambda c=c, s=s: c(s))  # type: ignore[misc]
                settle(lanes, k - depth + 1)
                continue
            assert n_nav is not None
            sel = (gidx % out_every == 0) & (gidx > n_nav)
            if sel.any():
                truth_rows.append(truth.rows(sel))
            piece = _Piece(s, truth, gidx, max(0, n_start - (gidx[0] - 1)))
            for name, v in variants.items():
                lanes.put(
                    name,
                    k,
                    lambda v=v, p=piece: _advance(v, p, dt, out_every, aiding, aided_filter),  # type: ignore[misc]
                )
            settle(lanes, k - depth + 1)
        settle(lanes, math.inf)
    aligned = all(v.aligner is None or v.aligner.done for v in variants.values())
    truth_all = np.concatenate(truth_rows) if truth_rows else np.empty((0, len(TRUTH_COLUMNS)))
    keep = truth_all[:, 11] > 0
    errors: dict[str, pd.DataFrame] = {}
    alignment: dict[str, AlignResult | None] = {}
    for name in corrections:  # a variant that never started has no rows and no alignment
        v = variants.get(name)
        rows = np.concatenate(v.rows) if v is not None and v.rows else np.empty((0, 10))
        errors[name] = error_frame(truth_all[keep, :11], rows[keep])
        done = v is not None and v.aligner is not None and v.aligner.done
        alignment[name] = v.aligner.result() if done else None  # type: ignore[union-attr]
    return EngineRun(
        truth=truth_all,
        errors=errors,
        alignment=alignment,
        aligned=aligned,
        n_start=n_start,
        t_origin=math.nan if t_origin is None else t_origin,
        t_last=t_last,
        t_align=t_align,
        t_nav=t_nav,
    )


@dataclass(frozen=True)
class _Piece:
    """One piece as every variant takes it: the samples, their truth, their sample counts
    from the first (1-based) and the first sample of the alignment in it."""

    s: NavSamples
    truth: PieceTruth
    gidx: NDArray[np.int64]
    i_first: int


def _advance(
    v: _Variant,
    p: _Piece,
    dt: float,
    out_every: int,
    aiding: Sequence[Measurement],
    aided_filter: AidedFilter | None,
) -> None:
    """One variant over one piece: its correction, its alignment, then its navigation (its
    rows appended to ``v.rows``). Touches nothing but ``v``: the variants of a piece may run
    on threads side by side."""
    s, truth, i_first = p.s, p.truth, p.i_first
    d_th, d_v = s.dtheta, s.dv
    if v.correction is not None:
        c = np.asarray(v.correction(s), dtype=float)
        if c.shape != (s.n, 6):
            raise ConfigError(f"a correction returned shape {c.shape}, not ({s.n}, 6)")
        d_th, d_v = _less_rates(d_th, d_v, c, s.dt)
    i0 = i_first
    if v.aligner is not None and not v.aligner.done:
        i0 += feed_and_hand_over(v, d_th[i_first:], d_v[i_first:])
    if i0 < s.n and aiding:
        assert v.nav is not None and aided_filter is not None
        if v.filt is None:
            res = v.aligner.result() if v.aligner is not None else None
            v.filt = aided_filter(v.nav, res, v.gyro_bias, v.accel_bias)
        out = _run_aided(
            v.filt, d_th[i0:], d_v[i0:], s.t[i0:] - s.dt[i0:],
            int(p.gidx[i0]) - 1, out_every, aiding,
        )  # fmt: skip
        if out.shape[0]:
            v.rows.append(out)
    elif i0 < s.n:
        assert v.nav is not None
        # the estimates are rates: over each sample's own interval
        bias = np.concatenate([v.gyro_bias, v.accel_bias])[None, :]
        th, dv = _less_rates(d_th[i0:], d_v[i0:], bias, s.dt[i0:])
        out = _run_nav(v.nav, th, dv, s.dt[i0:], dt, truth.alt[i0:], truth.vu[i0:], out_every)
        if out.shape[0]:
            v.rows.append(out)


def _less_rates(
    dtheta: NDArray, dv: NDArray, rates: NDArray, dt: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``dtheta − rates[:, :3] · dt``, ``dv − rates[:, 3:] · dt`` per sample (``rates`` (n, 6)
    or (1, 6) for all) [rad, m/s]: new arrays, numpy's rounding, one pass of a kernel
    (numpy's broadcast over three columns walks them three values at a time)."""
    out_th = np.empty((dtheta.shape[0], 3))
    out_v = np.empty((dtheta.shape[0], 3))
    _kernels.less_rates(
        np.ascontiguousarray(dtheta, dtype=float),
        np.ascontiguousarray(dv, dtype=float),
        np.ascontiguousarray(rates, dtype=float),
        np.ascontiguousarray(dt, dtype=float),
        out_th,
        out_v,
    )
    return out_th, out_v


def _run_aided(
    filt: AidedInertial,
    d_th: NDArray,
    d_v: NDArray,
    t_start: NDArray,
    k0: int,
    out_every: int,
    aiding: Sequence[Measurement],
) -> NDArray[np.float64]:
    """The aided filter over a stretch whose sample ``i`` starts at ``t_start[i]`` [s] and is
    sample ``k0 + i + 1`` from the first: the state rows (as :meth:`Strapdown.run`'s) after
    every sample count that is a whole multiple of ``out_every``."""
    n = d_th.shape[0]
    first = (k0 // out_every + 1) * out_every - k0
    ends = [*range(first, n + 1, out_every)]
    if not ends or ends[-1] != n:
        ends.append(n)
    rows = []
    a = 0
    for e in ends:
        run_aided(filt, d_th[a:e], d_v[a:e], float(t_start[a]), aiding)
        if (k0 + e) % out_every == 0:
            rows.append(filt.nav.state[:10].copy())
        a = e
    return np.array(rows) if rows else np.empty((0, 10))


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


# --------------------------------------------------------------------------- results
#: ``figures(nav) -> {file name: figure}``: the figures :meth:`Navigation.save` writes (each
#: with a matplotlib-like ``savefig(buffer, format=, dpi=)``).
FigureMaker = Callable[["Navigation"], Mapping[str, Any]]


@dataclass(frozen=True)
class Navigation:
    """A navigated run, simulated or recorded: the one result of both.

    Attributes
    ----------
    result : NavResult
        ``errors[variant]``: position and attitude error over time from the navigation
        start; ``truth``: the truth (a scenario) or the reference (a recording).
    temperatures : DataFrame
        Thermometer readings over the run [°C] (``time_s, chamber, outer, sensor_<ch>``).
    config : ScenarioConfig or RecordedRun, optional
        What was run (default the result's).
    imu : ImuConfig, optional
        A scenario's plant.
    info : dict
        A scenario's summary entries after the result's (seed, IMU, models, chamber ...).
    report : dict, optional
        A recording's report (window, noise, reference, warnings ...; see
        :func:`rinscal.nav.recording.navigate_log`); None for a scenario.
    warnings : list of str
        A recording's warnings (also in the report).
    """

    result: NavResult
    temperatures: pd.DataFrame
    config: Any = None
    imu: Any = None
    info: Mapping[str, Any] = field(default_factory=dict)
    report: dict[str, Any] | None = None
    warnings: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.config is None:
            object.__setattr__(self, "config", self.result.config)

    @cached_property
    def summary(self) -> dict[str, Any]:
        """What ``summary.json`` holds (JSON-able), built here only.

        :meth:`NavResult.summary` (per variant the maximum, final and RMS position error
        [m, nmi], the attitude error handed over [″], improvement over no compensation [%]),
        then a scenario's :attr:`info`; a recording's starts with ``log`` (its path), has no
        ``scenario`` and ends with ``recording`` (the report).
        """
        core = self.result.summary()
        if self.report is None:
            return {**core, **self.info}
        core.pop("scenario", None)
        return {"log": self.report["log"], **core, "recording": self.report}

    @property
    def errors(self) -> dict[str, pd.DataFrame]:
        """Per variant: :attr:`NavResult.errors`."""
        return self.result.errors

    @property
    def truth(self) -> pd.DataFrame:
        """:attr:`NavResult.truth`."""
        return self.result.truth

    @property
    def alignment(self) -> dict[str, AlignResult | None]:
        """:attr:`NavResult.alignment`."""
        return self.result.alignment

    def max_error_m(self, variant: str) -> float:
        """Maximum horizontal position error of a variant [m]."""
        return self.result.max_error_m(variant)

    def save(
        self,
        folder: str | os.PathLike[str],
        figures: FigureMaker | None = None,
        n_jobs: int | None = 1,
    ) -> Path:
        """Write the navigation's folder: ``errors.csv`` (every variant's error rows, a
        ``variant`` column first), ``truth.csv``, ``summary.json`` and the figures.

        Everything is made before anything is written, and each file is written atomically:
        a failure leaves the folder as it was.

        Parameters
        ----------
        folder : path-like
            Created if needed.
        figures : callable, optional
            ``figures(nav) -> {file name: figure}`` (PNG at :data:`FIGURE_DPI` each, by
            :func:`figure_png`; a figure already drawn may be given as its PNG's bytes);
            :func:`rinscal.report.nav_plots.navigation_figures` draws the command's three
            (:func:`rinscal.report.nav_plots.save_navigation` saves with them). None: no
            figures (navigation sits below the report layer and draws none itself).
        n_jobs : int or None
            Threads: with more than one, the figures are drawn while the CSV files are
            formatted (None or 0: every core). The files are the same.

        Returns
        -------
        Path
            The folder.
        """
        # deferred: the CSV writer (pyarrow) and the atomic writes only when saving
        import pyarrow as pa
        import pyarrow.csv as pacsv

        from rinscal.io.atomic import atomic_path

        out = Path(folder)
        out.mkdir(parents=True, exist_ok=True)
        frames = []
        for name, df in self.result.errors.items():
            d = df.copy()
            d.insert(0, "variant", name)
            frames.append(d)
        errors = pd.concat(frames, ignore_index=True)
        text = json.dumps(self.summary, indent=2, allow_nan=False, default=float) + "\n"

        def draw() -> dict[str, bytes]:
            made = figures(self) if figures is not None else {}
            return {k: v if isinstance(v, bytes) else figure_png(v) for k, v in made.items()}

        def csv() -> dict[str, Any]:
            # Arrow's CSV writer: every float to round-trip precision, 10× faster than
            # pandas' formatting (which was a third of an 8 h run's whole command)
            out_csv = {}
            for name, frame in (("errors.csv", errors), ("truth.csv", self.result.truth)):
                buf = pa.BufferOutputStream()
                pacsv.write_csv(pa.Table.from_pandas(frame, preserve_index=False), buf)
                out_csv[name] = buf.getvalue()
            return out_csv

        png, tables = map_jobs(lambda make: make(), [draw, csv], n_jobs)
        for name, data in tables.items():
            with atomic_path(out / name) as tmp:
                tmp.write_bytes(data)
        with atomic_path(out / "summary.json") as tmp:
            tmp.write_text(text)
        for fname, data in png.items():
            with atomic_path(out / fname) as tmp:
                tmp.write_bytes(data)
        return out

"""A recorded-navigation log opened: :class:`NavLog`, read in pieces of SI increments.

:class:`NavLog` (made by :func:`rinscal.io.navopen.open_nav_log`) reads the log's needed
columns piece by piece (:data:`rinscal.io.streaming.PIECE_ROWS` rows) and turns each piece
into a :class:`rinscal.schema.NavSamples` of angle and velocity increments [rad, m/s] in the
IMU frame r, time in seconds; an interval longer than the nominal one by
:data:`rinscal.schema.GAP_FACTOR` is a :class:`Gap`. The file format and its mapping are in
:mod:`rinscal.io.navopen`.

Row numbers in messages are data rows of the file: 1-based, the header not counted.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from rinscal.errors import LogError
from rinscal.io.mapping import IDENTITY_AXES, TIME_UNITS, ColumnMapping, parse_axes
from rinscal.io.streaming import PIECE_ROWS
from rinscal.io.tables import _CSV_READ_KW, _NA_STRINGS, _text_frames
from rinscal.io.track import _check_latitude
from rinscal.parallel import read_ahead
from rinscal.schema import (
    _ROWS,
    CHANNELS,
    GAP_FACTOR,
    REF_HEADING,
    REF_TRACK,
    RUN,
    TABLE,
    TEMP_OUT,
    TIME,
    NavSamples,
    as_float,
    check_finite,
    col_label,
)
from rinscal.units import DEG_TO_RAD

__all__ = [
    "NOMINAL_SAMPLES",
    "Gap",
    "NavLog",
]

#: Samples whose median interval is the nominal one when the metadata has no ``rate_hz``.
NOMINAL_SAMPLES = 1001

#: What a recording's six sensor columns hold.
Kind = Literal["rates", "increments", "counts"]


@dataclass(frozen=True)
class Gap:
    """An interval longer than :data:`GAP_FACTOR` nominal intervals.

    Attributes
    ----------
    time_s : float [s]
        ``time_s`` of the sample that ends the gap (the first one after it).
    row : int
        Its data row (1-based, header not counted).
    length_s : float [s]
        The interval ``t[k] − t[k−1]``.
    missing_samples : int
        About how many samples are missing: ``round(length_s / nominal) − 1``.
    """

    time_s: float
    row: int
    length_s: float
    missing_samples: int


@dataclass
class NavLog:
    """A recorded-navigation log opened by :func:`rinscal.io.navopen.open_nav_log`: what its
    header and its metadata say, without reading the data; :meth:`pieces` reads the data.

    Attributes
    ----------
    path : Path
        The log file.
    mapping : ColumnMapping or None
        How it is read (None: canonical column names).
    meta : dict or None
        Its sidecar metadata ``<log>.meta.json``.
    kind : {"rates", "increments", "counts"}
        How the file gives the IMU's output.
    units : dict of str to str
        Per channel of :data:`rinscal.schema.CHANNELS` (the file's channel, before ``axes``):
        rates: the unit name (mapping, else ``meta["units"]``, else deg/h and µg);
        increments: ``"rad"``/``"m/s"``; counts: the weight, e.g. ``"0.1 arcsec/count"``.
    to_si : dict of str to float
        Per channel: rates: SI rate per unit [(rad/s)/unit, (m/s²)/unit]; increments: 1;
        counts: SI per count [rad, m/s].
    names : dict of str to str
        Canonical name -> the file's column, for every column read.
    run : str or None
        The run read (``run`` argument, else the mapping's); None: the file's only run.
    n_rows : int or None
        Data rows in the file (Parquet metadata; all runs); None for a text file.
    has_table, has_temps, has_temp_out, has_ref, has_ref_heading : bool
        Whether the pieces carry the encoder angle, the six inner temperatures, the outer
        temperature, the reference track columns, the reference heading.
    rate_hz : float or None [Hz]
        ``meta["rate_hz"]``: the nominal rate (else the median interval is used).
    site : tuple of float or None
        ``meta["site"]`` as ``(lat [rad], lon [rad], h [m])`` (``h_m`` 0 when not given).
    heading_deg : float or None [deg]
        ``meta["heading_deg"]``: the body's heading, clockwise from north.
    noise : dict of str to float or None
        ``meta["noise"]``: ``gyro_noise_density`` [rad/√s], ``accel_noise_density``
        [m/s²/√Hz].
    utc_start : datetime or None
        ``meta["utc_start"]``: the UTC of ``time_s`` = 0 (timezone-aware).
    gaps : list of Gap
        Filled while :meth:`pieces` runs (emptied when it starts again).
    """

    path: Path
    mapping: ColumnMapping | None
    meta: dict[str, Any] | None
    kind: Kind
    units: dict[str, str]
    to_si: dict[str, float]
    names: dict[str, str]
    run: str | None
    n_rows: int | None
    has_table: bool
    has_temps: bool
    has_temp_out: bool
    has_ref: bool
    has_ref_heading: bool
    rate_hz: float | None
    site: tuple[float, float, float] | None
    heading_deg: float | None
    noise: dict[str, float] | None
    utc_start: datetime | None
    gaps: list[Gap] = field(default_factory=list)
    _fmt: str = field(default="csv", repr=False)
    _sep: str | None = field(default=None, repr=False)
    _sensors: tuple[str, ...] = field(default=(), repr=False)
    _temp_cols: tuple[str, ...] = field(default=(), repr=False)

    # ------------------------------------------------------------------ public

    def pieces(
        self,
        piece_rows: int = PIECE_ROWS,
        *,
        max_gap_samples: int = 5,
        allow_gaps: bool = False,
        threads: bool = True,
    ) -> Iterator[NavSamples]:
        """The recording (its chosen run) as :class:`NavSamples` pieces, in time order.

        Each piece has at most ``piece_rows`` samples (fewer where a run begins or ends
        inside a batch); memory holds one or two pieces, whatever the file's length.

        Parameters
        ----------
        piece_rows : int
            Rows read at a time.
        max_gap_samples : int
            A gap of more missing samples than this is refused unless ``allow_gaps``.
        allow_gaps : bool
            Integrate across every gap (rates: the rate is held over the gap; increments
            and counts: taken as the device reports them). Gaps are recorded in
            :attr:`gaps` either way.
        threads : bool
            Let Arrow decode a Parquet file's columns on its threads (False: on the caller's
            thread alone, for a command told to keep to one core). The same values.

        Yields
        ------
        NavSamples

        Raises
        ------
        LogError
            Naming the file, the column as the file names it and the data row: a value that
            is not a number, NaN or inf in time, a sensor or the encoder column (navigation
            cannot skip a sample), time not strictly increasing (across pieces too), a gap
            longer than ``max_gap_samples`` samples, a count column holding fractions, a
            latitude beyond ±90°, several runs and none chosen (they are listed), the chosen
            run absent or not contiguous, fewer than two samples.
        """
        piece_rows = int(piece_rows)
        if piece_rows < 1:
            raise ValueError(f"piece_rows must be at least 1, got {piece_rows}")
        self.gaps = []
        return self._pieces(piece_rows, int(max_gap_samples), bool(allow_gaps), bool(threads))

    # ------------------------------------------------------------------ reading

    def _src(self) -> str:
        return str(self.path)

    def _foreign(self, canon: str) -> str:
        return self.names.get(canon, canon)

    def _needed(self) -> list[str]:
        canon = [TIME, *self._sensors, *self._temp_cols]
        for flag, cols in (
            (self.has_temp_out, (TEMP_OUT,)),
            (self.has_table, (TABLE,)),
            (self.has_ref, REF_TRACK),
            (self.has_ref_heading, (REF_HEADING,)),
            (RUN in self.names, (RUN,)),
        ):
            if flag:
                canon.extend(cols)
        return list(dict.fromkeys(self._foreign(c) for c in canon))

    def _raw(self, piece_rows: int, threads: bool = True) -> Iterator[tuple[int, dict[str, Any]]]:
        """(rows of the file before it, canonical column -> values) for each piece read."""
        cols = self._needed()
        inverse = {self._foreign(c): c for c in self.names}
        if self._fmt == "parquet":
            # deferred on purpose: pyarrow is heavy and only Parquet needs it
            import pyarrow.parquet as pq

            try:
                pf = pq.ParquetFile(self.path, buffer_size=1 << 20, pre_buffer=False)
                batches = pf.iter_batches(batch_size=piece_rows, columns=cols, use_threads=threads)
                row = 0
                while True:
                    try:
                        batch = next(batches)
                    except StopIteration:
                        break
                    piece: dict[str, Any] = {}
                    for name in cols:
                        arr = batch.column(name)
                        canon = inverse[name]
                        if canon == RUN:
                            piece[canon] = arr.to_pandas()
                        else:
                            piece[canon] = arr.to_numpy(zero_copy_only=False)
                    n = batch.num_rows
                    del batch
                    yield row, piece
                    row += n
            except (LogError, GeneratorExit):
                raise
            except Exception as exc:  # pyarrow raises many types for a damaged file
                raise LogError(f"{self.path}: unreadable Parquet file: {exc}") from None
            return
        run_col = self.names.get(RUN)
        options = {
            "sep": self._sep,
            "usecols": cols,
            "encoding": "utf-8-sig",
            "keep_default_na": False,
            "na_values": {c: ([""] if c == run_col else list(_NA_STRINGS)) for c in cols},
            "dtype": {run_col: str} if run_col else None,
            **_CSV_READ_KW,
        }
        row = 0
        for df in _text_frames(self.path, options, piece_rows):
            yield row, {inverse[c]: df[c] for c in cols}
            row += len(df)

    def _run_pieces(
        self, piece_rows: int, threads: bool = True
    ) -> Iterator[tuple[int, dict[str, Any]]]:
        """The rows of the chosen (or only) run: (rows of the file before, columns)."""
        has_run = RUN in self.names
        target = self.run
        if target is not None and not has_run:
            raise LogError(
                f"{self.path}: run {target!r} chosen, but the file has no {RUN!r} column "
                "(it is one recording: leave run= and the mapping's select_run out)"
            )
        seen = ended = False
        current: object = None
        total = 0
        for row, piece in self._raw(piece_rows, threads):
            if not has_run:
                n = len(piece[TIME])
                if n:
                    total += n
                    yield row, piece
                continue
            run = piece.pop(RUN)
            n = len(run)
            if n == 0:
                continue
            if isinstance(run.dtype, pd.CategoricalDtype):  # Parquet dictionary: by codes
                codes = run.cat.codes.to_numpy()
                uniques = [str(u) for u in run.cat.categories]
            else:
                codes, found = pd.factorize(run, sort=False, use_na_sentinel=True)
                uniques = [str(u) for u in found]
            empty = codes < 0
            if empty.any():
                pos = int(np.argmax(empty))
                raise LogError(
                    f"{self.path}: {col_label(RUN, self.names)}, data row {row + pos + 1}: empty "
                    f"run name ({_ROWS})"
                )
            if target is None:
                present = np.unique(codes) if len(uniques) > 1 else [0]
                if current is None:
                    current = uniques[present[0]]
                if len(present) > 1 or uniques[present[0]] != current:
                    raise self._several_runs()
                total += n
                yield row, piece
                continue
            mask = codes == (uniques.index(target) if target in uniques else -2)
            if not mask.any():
                ended = ended or seen
                continue
            idx = np.flatnonzero(mask)
            a, b = int(idx[0]), int(idx[-1]) + 1
            resumes = None
            if ended or (seen and a != 0):
                resumes = a
            elif b - a != idx.size:
                hole = a + int(np.argmin(mask[a:b]))
                resumes = hole + int(np.argmax(mask[hole:b]))
            if resumes is not None:
                raise LogError(
                    f"{self.path}: {col_label(RUN, self.names)}, data row {row + resumes + 1}: run "
                    f"{target!r} resumes after rows of other runs; a run's rows must be "
                    f"contiguous to be navigated ({_ROWS})"
                )
            seen = True
            ended = b < n
            if a == 0 and b == n:
                total += n
                yield row, piece
            else:
                total += b - a
                yield row + a, {k: _rows(v, a, b) for k, v in piece.items()}
        if has_run and target is not None and not seen:
            runs, count = self._scan_runs()
            raise LogError(
                f"{self.path}: no run {target!r} in column {self._foreign(RUN)!r}; the file "
                f"holds {self._runs_text(runs, count)}"
            )
        if total < 2:
            raise LogError(
                f"{self.path}: {total} sample(s); navigating needs at least two"
                + (f" (run {target!r})" if target is not None else "")
            )

    def _scan_runs(self, most: int = 10) -> tuple[list[str], int]:
        """The first ``most`` run names in file order, and how many runs there are."""
        col = self._foreign(RUN)
        seen: dict[str, None] = {}
        if self._fmt == "parquet":
            # deferred on purpose: pyarrow is heavy and only Parquet needs it
            import pyarrow.parquet as pq

            pf = pq.ParquetFile(self.path)
            for batch in pf.iter_batches(batch_size=PIECE_ROWS, columns=[col]):
                for v in pd.unique(batch.column(0).to_pandas().astype(object)):
                    seen.setdefault(str(v), None)
        else:
            options = {
                "sep": self._sep,
                "usecols": [col],
                "dtype": {col: str},
                "keep_default_na": False,
                "na_values": {col: [""]},
                "encoding": "utf-8-sig",
            }
            for df in _text_frames(self.path, options, PIECE_ROWS):
                for v in pd.unique(df[col]):
                    seen.setdefault(str(v), None)
        names = list(seen)
        return names[:most], len(names)

    @staticmethod
    def _runs_text(runs: list[str], count: int) -> str:
        more = f", ... ({count} in all)" if count > len(runs) else ""
        return f"{count} run(s): {', '.join(map(repr, runs))}{more}"

    def _several_runs(self) -> LogError:
        runs, count = self._scan_runs()
        return LogError(
            f"{self.path}: column {self._foreign(RUN)!r} holds {self._runs_text(runs, count)}; "
            'choose one with run= (or select_run = "..." in the mapping)'
        )

    # ------------------------------------------------------------------ converting

    def _float(self, values: Any, canon: str, row: int) -> np.ndarray:
        """One column of a piece as float64 (no copy for a float64 column)."""
        if isinstance(values, np.ndarray):
            if values.dtype == np.float64:
                return values
            if values.dtype.kind in "iuf":
                return values.astype(np.float64)
            if values.dtype.kind in "mM":
                raise LogError(
                    f"{self.path}: {col_label(canon, self.names)} holds dates/times, not numbers"
                    + ("; write time as a number (s, ms or us)" if canon == TIME else "")
                )
            values = pd.Series(values)
        elif values.dtype.kind in "mM":
            raise LogError(f"{self.path}: {col_label(canon, self.names)} holds dates, not numbers")
        return as_float(values, self._src(), canon, self.names, copy=False, first_row=row)

    def _times(self, values: Any, row: int) -> tuple[np.ndarray, np.ndarray | None]:
        """Seconds, and the integer ticks when the time column is integer (exact intervals)."""
        per_second = TIME_UNITS[self.mapping.time_unit] if self.mapping is not None else 1.0
        arr = values.to_numpy() if isinstance(values, pd.Series) else values
        if arr.dtype.kind in "iu":
            ticks = arr.astype(np.int64)
            t = ticks.astype(np.float64)
            return (t / per_second if per_second != 1.0 else t), ticks
        t = self._float(values, TIME, row)
        check_finite(t, self._src(), TIME, self.names, False, "time must be finite", row)
        return (t / per_second if per_second != 1.0 else t), None

    def _sensor_block(
        self, piece: dict[str, Any], row: int, dt: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Increments [rad], [m/s], each (n, 3), C order, in r (``axes`` applied)."""
        n = dt.shape[0]
        out = (np.empty((n, 3), dtype=np.float64), np.empty((n, 3), dtype=np.float64))
        axes = parse_axes(self.mapping.axes) if self.mapping is not None else IDENTITY_AXES
        dest = {fa: (i, sign) for i, (fa, sign) in enumerate(axes)}  # file axis -> ours
        for j, canon in enumerate(self._sensors):
            x = self._float(piece[canon], canon, row)
            check_finite(
                x, self._src(), canon, self.names, False,
                "navigation cannot skip a sample", row,
            )  # fmt: skip
            if self.kind == "counts":
                frac = x != np.rint(x)
                if frac.any():
                    pos = int(np.argmax(frac))
                    raise LogError(
                        f"{self.path}: {col_label(canon, self.names)}, data row {row + pos + 1}: "
                        f"value {float(x[pos])!r} is not a whole number of counts; the mapping "
                        "gives [weights] (integer counts per interval): is this column a rate? "
                        f"({_ROWS})"
                    )
            i, sign = dest[j % 3]
            col = out[j // 3][:, i]
            k = self.to_si[CHANNELS[j]] * sign  # exact: the sign only flips
            if self.kind == "rates":
                np.multiply(x * dt, k, out=col)  # the mean rate over the interval, times it
            elif k == 1.0:
                col[:] = x
            else:
                np.multiply(x, k, out=col)
        return out

    def _pieces(
        self, piece_rows: int, max_gap_samples: int, allow_gaps: bool, threads: bool = True
    ) -> Iterator[NavSamples]:
        raw = self._run_pieces(piece_rows, threads)
        if threads:  # the next batch decoded while this one is converted
            raw = read_ahead(raw, 2)
        try:
            yield from self._timed(raw, max_gap_samples, allow_gaps)
        finally:  # the batch being decoded ahead waited for, the file closed
            raw.close()  # type: ignore[attr-defined]

    def _timed(
        self, raw: Iterator[tuple[int, dict[str, Any]]], max_gap_samples: int, allow_gaps: bool
    ) -> Iterator[NavSamples]:
        """The pieces of ``raw`` timed (intervals, gaps checked) and converted."""
        nominal = 1.0 / self.rate_hz if self.rate_hz else None
        held: list[tuple[int, dict[str, Any], np.ndarray, np.ndarray | None]] = []
        if nominal is None:  # the median interval of the first NOMINAL_SAMPLES samples
            count = 0
            for row, piece in raw:
                t, ticks = self._times(piece[TIME], row)
                held.append((row, piece, t, ticks))
                count += t.shape[0]
                if count >= NOMINAL_SAMPLES:
                    break
            t0 = np.concatenate([h[2] for h in held])[:NOMINAL_SAMPLES]
            d0 = np.diff(t0)
            nominal = float(np.median(d0)) if d0.size else 0.0
            if not nominal > 0.0:
                bad = int(np.argmax(d0 <= 0)) if d0.size else 0
                self._not_increasing(t0, bad + 1, held[0][0])
        prev_t: float | None = None
        prev_ticks: int | None = None
        per_second = TIME_UNITS[self.mapping.time_unit] if self.mapping is not None else 1.0

        def timed() -> Iterator[tuple[int, dict[str, Any], np.ndarray, np.ndarray | None]]:
            yield from held
            held.clear()
            for row, piece in raw:
                yield (row, piece, *self._times(piece[TIME], row))

        for row, piece, t, ticks in timed():
            n = t.shape[0]
            dt = np.empty(n, dtype=np.float64)
            if ticks is not None:
                dt[1:] = np.diff(ticks) / per_second
                if prev_ticks is not None:
                    dt[0] = (ticks[0] - prev_ticks) / per_second
                elif prev_t is not None:
                    dt[0] = t[0] - prev_t
                else:
                    dt[0] = nominal
            else:
                dt[1:] = np.diff(t)
                dt[0] = nominal if prev_t is None else t[0] - prev_t
            first = prev_t is None
            bad = dt <= 0.0
            if first:
                bad[0] = False
            if bad.any():
                k = int(np.argmax(bad))
                before = t[k - 1] if k > 0 else prev_t
                self._not_increasing(t, k, row, before)
            long = dt > GAP_FACTOR * nominal
            if first:
                long[0] = False
            if long.any():
                for k in np.flatnonzero(long):
                    gap = Gap(
                        float(t[k]),
                        row + int(k) + 1,
                        float(dt[k]),
                        max(round(float(dt[k]) / nominal) - 1, 1),
                    )
                    self.gaps.append(gap)
                    if gap.missing_samples > max_gap_samples and not allow_gaps:
                        raise LogError(
                            f"{self.path}: {col_label(TIME, self.names)}, data row {gap.row}: a "
                            f"gap of {gap.length_s:.6g} s before {gap.time_s:.10g} s (about "
                            f"{gap.missing_samples} samples missing at the nominal interval "
                            f"{nominal:.6g} s, more than {max_gap_samples}); pass allow_gaps=True "
                            "to integrate across it (rates are held over the gap, increments "
                            f"taken as the device reports them) ({_ROWS})"
                        )
            prev_t = float(t[-1])
            prev_ticks = int(ticks[-1]) if ticks is not None else None
            yield self._samples(piece, row, t, dt)

    def _not_increasing(self, t: np.ndarray, k: int, row: int, before: float | None = None) -> None:
        prev = float(t[k - 1]) if before is None else float(before)
        raise LogError(
            f"{self.path}: {col_label(TIME, self.names)}, data row {row + k + 1}: time not "
            f"strictly increasing ({float(t[k]):.10g} s after {prev:.10g} s at data row "
            f"{row + k}) ({_ROWS})"
        )

    def _samples(
        self, piece: dict[str, Any], row: int, t: np.ndarray, dt: np.ndarray
    ) -> NavSamples:
        dtheta, dv = self._sensor_block(piece, row, dt)
        axes = parse_axes(self.mapping.axes) if self.mapping is not None else IDENTITY_AXES
        perm = [fa for fa, _ in axes]
        table = None
        if self.has_table:
            x = self._float(piece[TABLE], TABLE, row)
            check_finite(
                x, self._src(), TABLE, self.names, False, "the encoder angle must be finite", row
            )
            m = self.mapping
            unit = DEG_TO_RAD if m is None or m.table_unit == "deg" else 1.0
            sign = m.table_sign if m is not None else 1.0
            zero = m.table_zero_deg * DEG_TO_RAD if m is not None else 0.0
            table = x * (sign * unit)
            if zero:
                table -= zero
        temps = None
        if self.has_temps:
            cols = {}
            for canon in dict.fromkeys(self._temp_cols):
                x = self._float(piece[canon], canon, row)
                check_finite(
                    x, self._src(), canon, self.names, True,
                    "temperatures must be finite (or empty)", row,
                )  # fmt: skip
                cols[canon] = x
            temps = np.empty((t.shape[0], 6), dtype=np.float64)
            for j, canon in enumerate(self._temp_cols):
                temps[:, j] = cols[canon]
            if perm != [0, 1, 2]:  # a temperature follows its sensor (no sign)
                temps = temps[:, [*perm, *(p + 3 for p in perm)]]
        temp_out = None
        if self.has_temp_out:
            temp_out = self._float(piece[TEMP_OUT], TEMP_OUT, row)
            check_finite(
                temp_out, self._src(), TEMP_OUT, self.names, True,
                "temperatures must be finite (or empty)", row,
            )  # fmt: skip
        ref = None
        if self.has_ref:
            ref = np.empty((t.shape[0], 3), dtype=np.float64)
            for j, canon in enumerate(REF_TRACK):
                x = self._float(piece[canon], canon, row)
                check_finite(
                    x, self._src(), canon, self.names, True,
                    "a reference must be finite (or empty: no reference at that sample)", row,
                )  # fmt: skip
                if j == 0:
                    _check_latitude(x, self._src(), col_label(canon, self.names), row)
                ref[:, j] = x * DEG_TO_RAD if j < 2 else x
        ref_heading = None
        if self.has_ref_heading:
            x = self._float(piece[REF_HEADING], REF_HEADING, row)
            check_finite(
                x, self._src(), REF_HEADING, self.names, True,
                "a reference must be finite (or empty)", row,
            )  # fmt: skip
            ref_heading = x * DEG_TO_RAD
        return NavSamples(
            t=t,
            dt=dt,
            dtheta=dtheta,
            dv=dv,
            first_row=row + 1,
            table=table,
            temps=temps,
            temp_out=temp_out,
            ref=ref,
            ref_heading=ref_heading,
        )


def _rows(values: Any, a: int, b: int) -> Any:
    """Rows ``a:b`` (positions) of a column: an ndarray or a Series."""
    return values.iloc[a:b] if isinstance(values, pd.Series) else values[a:b]

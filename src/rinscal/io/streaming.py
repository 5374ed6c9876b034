"""Read and write a log run by run: memory bounded by the longest run, not by the log.

:func:`iter_log_source` reads a log in pieces of :data:`PIECE_ROWS` rows (Parquet record
batches, CSV chunks) and yields its runs one at a time; a Parquet file whose runs lie along
its row groups well enough is read a run at a time instead, each run's columns decoded into
one block that the run's frame shares (no joining of pieces, no copy). :func:`by_runs` falls
back to the whole log when runs are interleaved. :class:`LogStreamWriter` writes runs as they
come, atomically.
"""

from __future__ import annotations

import ctypes
import itertools
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
import pandas as pd

from rinscal.errors import LogError
from rinscal.io.atomic import atomic_path
from rinscal.io.mapping import ColumnMapping
from rinscal.io.tables import (
    Format,
    SourceLog,
    _check_parquet,
    _check_table,
    _flight_sources,
    _log_path,
    _source,
    _text_columns,
    _text_frames,
    _text_options,
    format_of,
    is_flight_log,
    read_log_source,
)
from rinscal.schema import (
    RUN,
    validate_log,
)

if TYPE_CHECKING:
    from rinscal.io.flightinfo import FlightLogOptions

__all__ = [
    "PIECE_ROWS",
    "InterleavedRunsError",
    "LogStreamWriter",
    "by_runs",
    "iter_log_source",
    "write_log_runs",
]

T = TypeVar("T")


class InterleavedRunsError(LogError):
    """A run continues after another run began: the log cannot be read run by run."""


#: Rows per piece read by :func:`iter_log_source` (Parquet batch or CSV chunk).
PIECE_ROWS = 1 << 18


def _table_pieces(
    p: Path, fmt: Format, mapping: ColumnMapping | None, piece_rows: int
) -> tuple[Iterator[Any], str | None]:
    """The file's table in pieces of at most ``piece_rows`` rows, and its separator.

    Parquet pieces are Arrow record batches (joined in Arrow, converted once per run); text
    pieces are DataFrames.
    """
    if fmt == "parquet":
        pf, names = _open_parquet(p)

        def parquet() -> Iterator[Any]:
            # deferred on purpose: pyarrow is heavy and only Parquet needs it
            import pyarrow as pa

            rows = 0
            try:
                for batch in pf.iter_batches(batch_size=piece_rows, columns=names):
                    rows += batch.num_rows
                    yield batch
            except Exception as exc:
                raise LogError(f"{p}: unreadable Parquet file: {exc}") from None
            if rows == 0:  # no rows: one empty piece, so that the columns are known
                schema = pa.schema([pf.schema_arrow.field(n) for n in names])
                yield pa.RecordBatch.from_pylist([], schema=schema)

        return parquet(), None
    options = _text_options(p, fmt, mapping)

    def text() -> Iterator[pd.DataFrame]:
        for k, df in enumerate(_text_frames(p, options, piece_rows)):
            if k == 0:
                _check_table(p, df, options["sep"])
            yield df

    return text(), options["sep"]


def _open_parquet(p: Path) -> tuple[Any, list[str]]:
    """The Parquet file, opened for buffered reads, and its columns (a stored pandas index
    left out)."""
    # deferred on purpose: pyarrow is heavy and only Parquet needs it
    import pyarrow.parquet as pq

    _check_parquet(p)
    try:  # buffered reads, no pre-buffering of whole row groups (memory: a piece)
        pf = pq.ParquetFile(p, buffer_size=1 << 20, pre_buffer=False)
    except Exception as exc:  # pyarrow raises many types for a damaged file
        raise LogError(f"{p}: unreadable Parquet file: {exc}") from None
    return pf, [n for n in pf.schema_arrow.names if not n.startswith("__index_level_")]


#: A Parquet file is read run-aligned (:func:`_aligned_parquet`) when that decodes at most
#: this share of its rows twice.
ALIGNED_EXTRA = 0.25


def _aligned_parquet(
    p: Path, run_col: str, piece_rows: int
) -> tuple[Any, list[str], list[tuple[int, int, object]]] | None:
    """The file, its columns and its runs' row ranges ``[a, b)`` with their names, when the
    file can be read one run at a time, each run's columns decoded into one block.

    A run's block is decoded from the first row group it touches: the rows of that group
    before the run (the previous run's end) are decoded twice. None where that would be
    more than :data:`ALIGNED_EXTRA` of the file (many short runs in long row groups): the
    file is then read piece by piece. The run column alone is read first (a dictionary
    column: a few bytes a row); a run that resumes after another run began raises
    :class:`InterleavedRunsError` before anything else is read.
    """
    pf, names = _open_parquet(p)
    meta = pf.metadata
    stretches: list[tuple[int, int, object]] = []
    try:
        if run_col not in names:  # one run (named by the mapping or the file)
            stretches = [(0, meta.num_rows, run_col)] if meta.num_rows else []
        else:
            row = 0
            for piece in pf.iter_batches(batch_size=piece_rows, columns=[run_col]):
                for a, b, v in zip(*_piece_runs(piece, run_col), strict=True):
                    if stretches and stretches[-1][2] == v:  # the run goes on
                        stretches[-1] = (stretches[-1][0], row + int(b), v)
                    else:
                        stretches.append((row + int(a), row + int(b), v))
                row += len(piece)
    except Exception as exc:  # pyarrow raises many types for a damaged file
        raise LogError(f"{p}: unreadable Parquet file: {exc}") from None
    if not stretches or stretches[-1][1] != meta.num_rows:  # no rows, or a damaged file
        return None
    finished: set[object] = set()
    for a, _, v in stretches:
        if v in finished:
            raise InterleavedRunsError(
                f"{p}: data row {a + 1}: run {v!r} resumes after other runs began; "
                "the log is read whole instead"
            )
        finished.add(v)
    starts = _group_starts(meta)
    extra = sum(
        a - int(starts[np.searchsorted(starts, a, side="right") - 1]) for a, _, _ in stretches
    )
    if extra > ALIGNED_EXTRA * meta.num_rows:
        return None
    return pf, names, stretches


def _group_starts(meta: Any) -> np.ndarray:
    """First row of each row group of a Parquet file, then its row count."""
    rows = [meta.row_group(i).num_rows for i in range(meta.num_row_groups)]
    return np.concatenate([[0], np.cumsum(rows, dtype=np.int64)])


def _aligned_sources(
    p: Path,
    pf: Any,
    names: list[str],
    stretches: list[tuple[int, int, object]],
    mapping: ColumnMapping | None,
) -> Iterator[SourceLog]:
    """Each run of a Parquet file (:func:`_aligned_parquet`), read, mapped and validated.

    Every column but the dictionary-encoded ones (run names) is decoded into one block for
    the run, which the frame then shares (no copy); the table is what reading the run's rows
    in pieces and joining them gives.
    """
    # deferred on purpose: pyarrow is heavy and only Parquet needs it
    import pyarrow as pa

    schema = pf.schema_arrow
    fields = [schema.field(n) for n in names]
    dicts = [f.name for f in fields if pa.types.is_dictionary(f.type)]
    block = [f.name for f in fields if not pa.types.is_dictionary(f.type)]
    starts = _group_starts(pf.metadata)
    for a, b, _ in stretches:
        g0 = int(np.searchsorted(starts, a, side="right")) - 1
        groups = list(range(g0, int(np.searchsorted(starts, b, side="left"))))
        lead, n = a - int(starts[g0]), b - a
        cols: dict[str, Any] = {}
        try:
            if block:  # one batch from the run's first row group to its last row
                cols.update(_block(p, pf, groups, block, lead, n))
            if dicts:  # a chunk per row group, each its own dictionary (as read in pieces)
                t = pf.read_row_groups(groups, columns=dicts).slice(lead, n)
                cols.update(zip(dicts, t.columns, strict=True))
                del t
        except LogError:
            raise
        except Exception as exc:  # pyarrow raises many types for a damaged file
            raise LogError(f"{p}: unreadable Parquet file: {exc}") from None
        table = pa.Table.from_arrays(
            [cols.pop(c) for c in names], schema=pa.schema(fields, metadata=schema.metadata)
        )
        # the table holds the only reference: converted, the columns it could not share go
        yield _source(p, _to_frame(table), mapping, None, a)


def _block(
    p: Path, pf: Any, groups: list[int], columns: list[str], lead: int, n: int
) -> dict[str, Any]:
    """Rows ``lead .. lead + n`` of the row groups ``groups`` of ``p``, each column one chunk.

    Decoded as one batch of ``lead + n`` rows (a batch of columns without a dictionary runs
    across row groups); a reader that gives several batches is joined in Arrow instead.
    """
    # deferred on purpose: pyarrow is heavy and only Parquet needs it
    import pyarrow as pa

    got, rows = [], 0
    batches = pf.iter_batches(batch_size=lead + n, row_groups=groups, columns=columns)
    try:
        for batch in batches:
            got.append(batch)
            rows += len(batch)
            if rows >= lead + n:
                break
    finally:
        batches.close()
    if rows < lead + n:
        raise LogError(
            f"{p}: unreadable Parquet file: row groups {groups[0]}-{groups[-1]} hold {rows} "
            f"rows, not the {lead + n} their metadata gives"
        )
    return dict(zip(columns, pa.Table.from_batches(got).slice(lead, n).columns, strict=True))


def _to_frame(table: Any) -> pd.DataFrame:
    """A table as a DataFrame, one block per column: a column of one chunk without nulls is
    shared (no copy), the others converted; Arrow memory freed column by column."""
    return table.to_pandas(split_blocks=True, self_destruct=True)


def by_runs(
    path: str | os.PathLike[str],
    mapping: ColumnMapping | FlightLogOptions | None,
    consume: Callable[[Iterator[SourceLog]], T],
) -> T:
    """``consume`` the log's runs as :func:`iter_log_source` reads them, one at a time.

    A log whose runs are interleaved cannot be read run by run: ``consume`` is then called
    again, from the start, with the whole log as its one item
    (:func:`~rinscal.io.tables.read_log_source`); ``consume`` must not have written anything
    final before it returns.
    """
    try:
        return consume(iter_log_source(path, mapping))
    except InterleavedRunsError:
        return consume(iter([read_log_source(path, mapping)]))


def _piece_runs(piece: Any, run_col: str) -> tuple[np.ndarray, np.ndarray, list[object]]:
    """Start, end and run name of each stretch of equal run names in a piece (none if empty)."""
    n = len(piece)
    if n == 0:  # a header and no rows
        return np.zeros(0, np.int64), np.zeros(0, np.int64), []
    names = piece.schema.names if not isinstance(piece, pd.DataFrame) else list(piece.columns)
    if run_col not in names:  # one run (named by the mapping or the file)
        return np.array([0]), np.array([n]), [run_col]
    col = piece[run_col] if isinstance(piece, pd.DataFrame) else piece.column(run_col).to_pandas()
    codes, uniques = pd.factorize(col, sort=False, use_na_sentinel=True)
    cut = np.flatnonzero(codes[1:] != codes[:-1]) + 1
    starts = np.concatenate([[0], cut]).astype(np.int64)
    ends = np.concatenate([cut, [n]]).astype(np.int64)
    return starts, ends, [None if codes[a] < 0 else uniques[codes[a]] for a in starts]


def _piece_table(pieces: list[Any]) -> pd.DataFrame:
    """One table from consecutive pieces (Arrow batches or DataFrames), RangeIndex."""
    if not isinstance(pieces[0], pd.DataFrame):
        # deferred on purpose: pyarrow is heavy and only Parquet needs it
        import pyarrow as pa

        table = pa.Table.from_batches(pieces)
        pieces.clear()  # the table holds the only reference: converted, its buffers go
        # one block per column (no 2-D consolidation copy), Arrow memory freed column by column
        return _to_frame(table)
    if len(pieces) == 1:
        return pieces[0].reset_index(drop=True)
    return pd.concat(pieces, ignore_index=True)


def iter_log_source(
    path: str | os.PathLike[str],
    mapping: ColumnMapping | FlightLogOptions | None = None,
    *,
    fmt: str | None = None,
    piece_rows: int | None = None,
) -> Iterator[SourceLog]:
    """Read and validate a log run by run: memory bounded by the longest run, not the log.

    The file is read in pieces of ``piece_rows`` rows (Parquet record batches, CSV chunks);
    the pieces of a run are joined, and each whole run is mapped, validated and yielded as a
    :class:`~rinscal.io.tables.SourceLog` (``first_row`` says where it starts in the file).
    A Parquet file is read run by run where that decodes few rows twice (its run column
    first, then each run in one block from the first row group it touches: the frame shares
    the block); its interleaved runs are then found before any run is read.
    Every run's table is exactly what :func:`~rinscal.io.tables.read_log_source` gives for its rows.

    Parameters
    ----------
    path, mapping, fmt
        As for :func:`~rinscal.io.tables.read_log_source`.
    piece_rows : int, optional
        Rows read at a time (default :data:`PIECE_ROWS`).

    Yields
    ------
    SourceLog
        One run, in file order.

    Raises
    ------
    InterleavedRunsError
        When a run's rows resume after another run's (read such a log whole, with
        :func:`~rinscal.io.tables.read_log_source`), also when the part of a run before
        another run began is not a valid run on its own (one sample, say): it is never refused
        for that.
    LogError
        As :func:`~rinscal.io.tables.read_log_source`, with the row numbers of the whole file.
    """
    piece_rows = PIECE_ROWS if piece_rows is None else int(piece_rows)
    if piece_rows < 1:
        raise ValueError(f"piece_rows must be at least 1, got {piece_rows}")
    if fmt is None and is_flight_log(path):
        yield from _flight_sources(path, mapping)
        return
    p, f = _log_path(path, fmt, mapping)
    run_col = RUN
    if mapping is not None:
        run_col = next((k for k, c in mapping.columns.items() if c == RUN), RUN)
    if f == "parquet":
        aligned = _aligned_parquet(p, run_col, int(piece_rows))
        if aligned is not None:  # each run decoded into one block that its frame shares
            yield from _aligned_sources(p, *aligned, mapping)
            return
    pieces, sep = _table_pieces(p, f, mapping, int(piece_rows))
    heads: list[Any] = []
    stretches = _stretches(pieces, run_col, heads)
    held: list[Any] = []
    current: object = None
    finished: set[object] = set()
    first = 0
    for seg, v in stretches:
        if held and v == current:
            held.append(seg)
            continue
        if held:
            rows = sum(len(h) for h in held)
            try:
                src = _source(p, _piece_table(held), mapping, sep, first)
            except LogError:
                # a run cut short by another run may be a run that resumes later: then the
                # log is read whole and validated as such, never refused for a piece of a run
                finished.add(current)
                row = _resumed_at(itertools.chain([(seg, v)], stretches), first + rows, finished)
                if row is not None:
                    raise InterleavedRunsError(
                        f"{p}: data row {row + 1}: a run resumes after other runs began; "
                        "the log is read whole instead"
                    ) from None
                raise
            yield src
            del src  # the run is the caller's now: hold no reference while reading the next
            first += rows
            finished.add(current)
        if v in finished:
            raise InterleavedRunsError(
                f"{p}: data row {first + 1}: run {v!r} resumes after other runs began; "
                "the log is read whole instead"
            )
        held, current = [seg], v
    if held:
        yield _source(p, _piece_table(held), mapping, sep, first)
    else:  # a header and no rows: validation says so
        empty = pd.DataFrame() if not heads else _piece_table(heads)
        yield _source(p, empty, mapping, sep)


def _stretches(
    pieces: Iterator[Any], run_col: str, heads: list[Any]
) -> Iterator[tuple[Any, object]]:
    """Each stretch of equal run names, piece by piece, with its run name.

    The first piece's columns (no rows) go to ``heads``: a file with a header and no rows
    has no stretch.
    """
    for piece in pieces:
        frame = isinstance(piece, pd.DataFrame)
        if not heads:
            heads.append(piece.iloc[:0] if frame else piece.slice(0, 0))
        for a, b, v in zip(*_piece_runs(piece, run_col), strict=True):
            if b > a:
                yield (piece.iloc[a:b] if frame else piece.slice(a, b - a)), v


def _resumed_at(
    stretches: Iterator[tuple[Any, object]], row: int, finished: set[object]
) -> int | None:
    """First data row (0-based) where one of the ``finished`` runs resumes, or None.

    ``row`` is the data row where ``stretches`` begin; only their run names and lengths are
    used. ``finished`` gains the runs that end on the way.
    """
    current: object = _NO_RUN
    for seg, v in stretches:
        if v != current:
            if v in finished:
                return row
            if current is not _NO_RUN:
                finished.add(current)
            current = v
        row += len(seg)
    return None


_NO_RUN = object()


class LogStreamWriter:
    """Write a log run by run (bounded memory), atomically: nothing appears under ``path``
    until :meth:`close` succeeds; on an error the partial file is removed.

    Each frame is one or more whole runs with the same columns, stacked in the order
    written. Parquet gets row groups of at most :data:`PIECE_ROWS` rows (the writer holds one
    encoded row group at a time: memory bounded by that, not by a run); CSV/TSV are appended.
    Use as a context manager::

        with LogStreamWriter("soak.parquet") as w:
            for run in runs:
                w.write(run)

    Parameters
    ----------
    path : path-like
        Destination; ``.csv``, ``.tsv`` or ``.parquet``.
    fmt : {"csv", "tsv", "parquet"}, optional
        Format, overriding the suffix.
    validate : bool
        Validate each frame as a calibration log before writing it (off for truth files).
    sep : str, optional
        Field separator of a text file (default: tab for ``.tsv``, comma for ``.csv``).
    writeback : bool
        After each frame, have the system start writing the file's pages to disk
        (:func:`start_writeback`; they stay cached): moved onto an existing file at the end,
        the file then has little left to flush (ext4 flushes a file renamed over another at
        once: 0.26 s for a 450 MB file, 0.03-0.1 s after this). For a writer that runs
        beside other work (``compensate`` writes a run while the next is computed).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        fmt: str | None = None,
        validate: bool = True,
        sep: str | None = None,
        writeback: bool = False,
    ) -> None:
        self.path = Path(path)
        self.fmt = format_of(self.path, fmt)
        self.validate = validate
        self.sep = sep or ("\t" if self.fmt == "tsv" else ",")
        if not self.path.parent.is_dir():
            raise LogError(f"{self.path}: folder {self.path.parent} does not exist")
        self.rows = 0
        self._columns: list[str] | None = None
        self._writer: Any = None
        self._ctx = atomic_path(self.path)
        self._tmp: Path | None = None
        self._writeback = writeback

    def __enter__(self) -> LogStreamWriter:
        self._tmp = self._ctx.__enter__()
        return self

    def write(self, frame: pd.DataFrame) -> None:
        """Append whole runs [rows keep their order]."""
        # deferred on purpose: pyarrow is heavy and only Parquet needs it
        import pyarrow as pa
        import pyarrow.parquet as pq

        assert self._tmp is not None, "use LogStreamWriter as a context manager"
        df = validate_log(frame, source=f"log to write to {self.path}") if self.validate else frame
        if self._columns is None:
            self._columns = list(df.columns)
        elif list(df.columns) != self._columns:
            raise LogError(
                f"{self.path}: a run has columns {list(df.columns)}, not {self._columns}"
            )
        if self.fmt == "parquet":
            if RUN in df.columns and not isinstance(df[RUN].dtype, pd.CategoricalDtype):
                df = df.assign(**{RUN: df[RUN].astype("category")})
            if self._writer is None:
                table = pa.Table.from_pandas(df, preserve_index=False)
                self._writer = pq.ParquetWriter(
                    self._tmp, table.schema, use_dictionary=_text_columns(df)
                )
            else:  # every run in the first one's types
                table = _arrow_table(df, self._writer.schema)
            self._writer.write_table(table, row_group_size=PIECE_ROWS)
        else:
            df.to_csv(
                self._tmp,
                mode="w" if self.rows == 0 else "a",
                header=self.rows == 0,
                sep=self.sep,
                index=False,
                float_format=None,
                lineterminator="\n",
            )
        self.rows += len(df)
        if self._writeback:
            start_writeback(self._tmp)

    def __exit__(self, exc_type: object, exc: BaseException | None, tb: object) -> None:
        if self._writer is not None:
            self._writer.close()
        if exc is None and self.rows == 0:
            exc = LogError(f"{self.path}: nothing to write (no runs)")
            self._ctx.__exit__(type(exc), exc, None)
            raise exc
        self._ctx.__exit__(exc_type, exc, tb)


def start_writeback(path: Path) -> None:
    """Have Linux start writing the dirty pages of the file ``path`` to disk, waiting for
    none (``sync_file_range`` with ``SYNC_FILE_RANGE_WRITE``: the pages stay cached, nothing
    is made durable); nothing where the system has no such call."""
    fn = _sync_file_range()
    if fn is None:
        return
    fd = os.open(path, os.O_RDONLY)
    try:
        fn(fd, 0, 0, _SYNC_FILE_RANGE_WRITE)  # a failure only leaves the flush for later
    finally:
        os.close(fd)


#: ``SYNC_FILE_RANGE_WRITE`` (linux/fs.h): start writing the range's dirty pages.
_SYNC_FILE_RANGE_WRITE = 2
_SYNC: list[Any] = []


def _sync_file_range() -> Any:
    """The C library's ``sync_file_range`` (Linux), or None; looked up once."""
    if not _SYNC:
        fn = None
        if sys.platform.startswith("linux"):
            try:
                fn = ctypes.CDLL(None, use_errno=True).sync_file_range
                fn.argtypes = [ctypes.c_int, ctypes.c_int64, ctypes.c_int64, ctypes.c_uint]
                fn.restype = ctypes.c_int
            except (OSError, AttributeError):  # no C library, or none with the call
                fn = None
        _SYNC.append(fn)
    return _SYNC[0]


def _arrow_table(df: pd.DataFrame, schema: Any) -> Any:
    """``pa.Table.from_pandas(df, schema=schema, preserve_index=False)``, the same table,
    with each float64 column that holds no NaN wrapped as it is.

    ``from_pandas`` takes NaN for a missing value, so it looks at every element of a float
    column one by one for it (about 0.06 s a 1 M-row run of 16 columns); numpy's vectorised
    ``isnan`` says the same for a column that has none, and such a column is then shared
    (no copy). A column with a NaN, and every other column, is converted as before.
    """
    # deferred on purpose: pyarrow is heavy and only Parquet needs it
    import pyarrow as pa

    names = list(schema.names)
    if list(df.columns) != names or len(set(names)) != len(names):  # from_pandas decides
        return pa.Table.from_pandas(df, schema=schema, preserve_index=False)
    arrays: dict[str, Any] = {}
    for name, f in zip(names, schema, strict=True):
        x = df[name]
        if f.type == pa.float64() and x.dtype == np.float64:
            v = x.to_numpy()
            if v.ndim == 1 and v.flags.c_contiguous and not np.isnan(v).any():
                arrays[name] = pa.array(v, type=f.type)
    if not arrays:
        return pa.Table.from_pandas(df, schema=schema, preserve_index=False)
    rest = [f for f in schema if f.name not in arrays]
    if rest:
        others = pa.Table.from_pandas(
            df[[f.name for f in rest]], schema=pa.schema(rest), preserve_index=False
        )
        arrays.update(zip(others.column_names, others.columns, strict=True))
    return pa.Table.from_arrays([arrays[n] for n in names], schema=schema)


def write_log_runs(
    frames: Iterator[pd.DataFrame],
    path: str | os.PathLike[str],
    *,
    fmt: str | None = None,
    validate: bool = True,
) -> int:
    """Write an iterator of runs with :class:`LogStreamWriter`; return the rows written."""
    with LogStreamWriter(path, fmt=fmt, validate=validate) as w:
        for frame in frames:
            w.write(frame)
    return w.rows

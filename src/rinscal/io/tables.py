"""Read and write whole calibration logs (CSV, TSV, Parquet), canonical or through a mapping.

Verbs: ``read_*`` load and validate a file, ``write_*`` write one atomically (a temporary
file in the same folder, then :func:`os.replace`, see :mod:`rinscal.io.atomic`), so a crash
never leaves a half-written file under the final name.

A foreign table is read through a :class:`rinscal.io.mapping.ColumnMapping`; a PX4 ``.ulg``
or ArduPilot ``.bin`` log through :mod:`rinscal.io.flightlog`. Reading a log one run at a
time, and writing one run by run, is :mod:`rinscal.io.streaming`.
"""

from __future__ import annotations

import csv
import os
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd

from rinscal import _check
from rinscal.errors import LogError, LogNoteWarning
from rinscal.io.atomic import write_atomic
from rinscal.io.mapping import SEPARATORS, TIME_UNITS, ColumnMapping, check_applies
from rinscal.schema import (
    CANONICAL,
    RUN,
    TIME,
    as_float,
    quoted_columns,
    validate_log,
)

if TYPE_CHECKING:
    from rinscal.io.flightinfo import FlightLogOptions

__all__ = [
    "FORMATS",
    "SourceLog",
    "check_mapping",
    "format_of",
    "is_flight_log",
    "read_log",
    "read_log_source",
    "write_log",
]

Format = Literal["csv", "tsv", "parquet"]
#: File formats of a log, by suffix.
FORMATS: dict[str, Format] = {".csv": "csv", ".tsv": "tsv", ".parquet": "parquet", ".pq": "parquet"}
#: Flight-controller log suffixes (read by :mod:`rinscal.io.flightlog`).
_FLIGHT_SUFFIXES = (".ulg", ".bin")
# pandas < 3 needs the round-trip float parser for a lossless CSV round trip; pandas 3
# parses exactly by default and deprecates the option.
_CSV_READ_KW: dict[str, Any] = (
    {"float_precision": "round_trip"} if int(pd.__version__.split(".")[0]) < 3 else {}
)
# pandas' default missing-value strings (documented for read_csv). They apply to every column
# but the run name: a run called "NA", "None" or "nan" is a name, only an empty cell is missing.
_NA_STRINGS = (
    "", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN",
    "<NA>", "N/A", "NA", "NULL", "NaN", "None", "n/a", "nan", "null",
)  # fmt: skip


def format_of(path: str | os.PathLike[str], fmt: str | None = None) -> Format:
    """File format of a log: ``fmt`` if given, else from the suffix.

    Raises
    ------
    LogError
        For an unknown suffix or format name.
    """
    if fmt is not None:
        f = fmt.lower().lstrip(".")
        if f in ("csv", "tsv", "parquet"):
            return f  # type: ignore[return-value]
        raise LogError(f"{path}: unknown log format {fmt!r}; use csv, tsv or parquet")
    suffix = Path(path).suffix.lower()
    if suffix in _FLIGHT_SUFFIXES:
        raise LogError(
            f"{path}: ULog and DataFlash logs are read, never written; write a .csv, .tsv or "
            ".parquet log"
        )
    if suffix not in FORMATS:
        raise LogError(
            f"{path}: unknown log file suffix {suffix or '(none)'!r}; "
            f"use {', '.join(FORMATS)} (or read a PX4 .ulg / ArduPilot .bin log)"
            + (
                "; compressed logs are not read: decompress it first (e.g. gunzip -k)"
                if suffix in (".gz", ".bz2", ".xz", ".zip", ".zst")
                else ""
            )
        )
    return FORMATS[suffix]


def _sniff_text(p: Path) -> str:
    """First line of a text table; refuse binary junk and JSON with a clear message."""
    with p.open("rb") as fh:
        head = fh.read(65536)
    if not head.strip():
        raise LogError(f"{p}: empty file, no header and no data")
    if b"\x00" in head or head.startswith(b"PAR1"):
        raise LogError(f"{p}: binary data, not a text table (CSV/TSV)")
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not just a character cut at the end of the block
            raise LogError(
                f"{p}: not a UTF-8 text table (undecodable byte at offset {exc.start})"
            ) from None
        text = head[: exc.start].decode("utf-8")
    text = text.lstrip("\ufeff")
    stripped = text.lstrip()
    if stripped[:1] in ("{", "["):
        raise LogError(f"{p}: looks like JSON, not a table (CSV/TSV with a header line)")
    return stripped.splitlines()[0] if stripped else ""


def _read_parquet_columns(p: Path) -> pd.DataFrame:
    """Read a Parquet file one column at a time.

    Peak memory stays near the size of the frame itself (``pandas.read_parquet`` holds the
    whole Arrow table and the frame at once: twice as much for a 7.5 M-row log).
    """
    # deferred on purpose: pyarrow is heavy and only Parquet needs it
    import pyarrow.parquet as pq

    pf = pq.ParquetFile(p)
    cols: dict[str, pd.Series] = {}
    for name in pf.schema_arrow.names:
        if name.startswith("__index_level_"):  # a pandas index stored as a column
            continue
        table = pf.read(columns=[name])
        cols[name] = table.column(0).to_pandas()
        del table
    return pd.DataFrame(cols, copy=False)


def _separator(p: Path, fmt: Format, mapping: ColumnMapping | None, header: str) -> str:
    name = mapping.separator if mapping is not None else None
    if name is None:
        return "\t" if fmt == "tsv" else ","
    sep = SEPARATORS[name]
    if sep is None:  # auto: the most frequent candidate in the header line
        counts = {s: header.count(s) for s in ("\t", ",", ";")}
        sep = max(counts, key=counts.get)  # type: ignore[arg-type]
        if counts[sep] == 0:
            raise LogError(f"{p}: cannot guess the separator: header has no tab, comma or ';'")
    return sep


def _check_parquet(p: Path) -> None:
    with p.open("rb") as fh:
        magic = fh.read(4)
    if magic != b"PAR1":
        raise LogError(f"{p}: not a Parquet file (no PAR1 magic number)")


def _text_options(p: Path, fmt: Format, mapping: ColumnMapping | None) -> dict[str, Any]:
    """``pandas.read_csv`` options of a text log (``sep`` among them), the header checked.

    Columns the reader owns are numbers (pandas' missing-value strings are NaN); the run name
    and every other column are text kept exactly as written (``NA`` stays ``NA``).
    """
    header = _sniff_text(p)
    sep = _separator(p, fmt, mapping, header)
    raw_cols = next(csv.reader([header.lstrip("\ufeff")], delimiter=sep), [])
    dup = sorted({c for c in raw_cols if raw_cols.count(c) > 1})
    if dup:
        raise LogError(
            f"{p}: column(s) {', '.join(map(repr, dup))} appear more than once in the header "
            "(a reader would rename the second to '<name>.1' and one of them would be used "
            "silently); rename or drop the duplicates"
        )
    run_name = RUN
    if mapping is not None:
        run_name = next((f for f, c in mapping.columns.items() if c == RUN), RUN)
    owned = _owned_columns(mapping)
    header_cols = next(_text_frames(p, {"sep": sep, "nrows": 0, "encoding": "utf-8-sig"})).columns
    text = [c for c in header_cols if c == run_name or c not in owned]
    na = {c: list(_NA_STRINGS) for c in header_cols if c not in text}
    na[run_name] = [""]
    return {
        "sep": sep,
        "dtype": dict.fromkeys(text, str),
        "encoding": "utf-8-sig",
        "keep_default_na": False,
        "na_values": na,
        **_CSV_READ_KW,
    }


def _text_frames(
    p: Path, options: Mapping[str, Any], chunksize: int | None = None
) -> Iterator[pd.DataFrame]:
    """A text log's table (in pieces of ``chunksize`` rows), read errors as :class:`LogError`."""
    try:
        if chunksize is None:
            yield pd.read_csv(p, **options)
            return
        with pd.read_csv(p, chunksize=chunksize, **options) as reader:
            yield from reader
    except pd.errors.EmptyDataError:
        raise LogError(f"{p}: empty file, no header and no data") from None
    except pd.errors.ParserError as exc:
        raise LogError(f"{p}: not a well-formed table: {exc}") from None
    except UnicodeDecodeError as exc:
        raise LogError(f"{p}: not a UTF-8 text table: {exc}") from None


def _check_table(p: Path, df: pd.DataFrame, sep: str) -> None:
    """Refuse a text table of fewer than two columns (most likely the wrong separator)."""
    if df.shape[1] >= 2:
        return
    header = _sniff_text(p)
    seps = {"\t": "tab", ",": "comma", ";": "semicolon"}
    found = [name for s, name in seps.items() if s != sep and s in header]
    hint = f" (the header contains a {found[0]}: set the separator)" if found else ""
    raise LogError(
        f"{p}: not a table: only one column {str(df.columns[0])[:60]!r} with "
        f"{seps.get(sep, repr(sep))} separation{hint}"
    )


def _read_table(
    p: Path, fmt: Format, mapping: ColumnMapping | None
) -> tuple[pd.DataFrame, str | None]:
    """The file's table and its separator (None for Parquet)."""
    if fmt == "parquet":
        _check_parquet(p)
        try:
            return _read_parquet_columns(p), None
        except Exception as exc:  # pyarrow raises many types for a damaged file
            raise LogError(f"{p}: unreadable Parquet file: {exc}") from None
    options = _text_options(p, fmt, mapping)
    df = next(_text_frames(p, options))
    _check_table(p, df, options["sep"])
    return df, options["sep"]


def _owned_columns(mapping: ColumnMapping | None) -> set[str]:
    """Columns of a file that the reader parses as numbers: canonical or mapped onto one."""
    owned = set(CANONICAL)
    if mapping is not None:
        owned |= set(mapping.foreign_columns())
    return owned


def _apply_mapping(
    df: pd.DataFrame, mapping: ColumnMapping, p: Path
) -> tuple[pd.DataFrame, dict[str, str]]:
    cols = [str(c) for c in df.columns]
    wanted = mapping.foreign_columns() + list(mapping.drop)
    missing = [c for c in wanted if c not in cols]
    if missing:
        raise LogError(
            f"{p}: column(s) {', '.join(map(repr, missing))} named in the mapping are not in "
            f"the file (columns found: {quoted_columns(cols)})"
        )
    rename = mapping.rename()
    df = df.drop(columns=list(mapping.drop))
    clash = [c for c in df.columns if c in rename.values() and c not in rename]
    if clash:
        raise LogError(
            f"{p}: the mapping renames other columns to {', '.join(map(repr, clash))}, "
            "which the file already has; drop or map them"
        )
    df = df.rename(columns=rename)
    names = {canon: foreign for foreign, canon in rename.items()}
    if RUN not in df.columns:
        df[RUN] = mapping.run_name or p.stem
    if TIME in df.columns:
        t = df[TIME]
        per_second = TIME_UNITS[mapping.time_unit]
        if pd.api.types.is_integer_dtype(t.dtype) and not pd.api.types.is_bool_dtype(t.dtype):
            ti = t.to_numpy(dtype=np.int64)
            if mapping.relative_time:
                ti = ti - ti[_first_of_run(df[RUN])]  # exact in integers, then to seconds
            x = ti.astype(np.float64)
        else:
            x = as_float(t, str(p), TIME, names)
            if mapping.relative_time:
                x = x - x[_first_of_run(df[RUN])]
        df[TIME] = x / per_second if per_second != 1.0 else x
    for ch, k in mapping.scale.items():
        if ch in df.columns:
            df[ch] = as_float(df[ch], str(p), ch, names) * k
    return df, names


def _first_of_run(run: pd.Series) -> np.ndarray:
    """Index of the first row of each sample's run, per sample."""
    codes, _ = pd.factorize(run, sort=False)
    _, first = np.unique(codes, return_index=True)
    return first[codes]


@dataclass(frozen=True)
class SourceLog:
    """A log as read: the canonical frame and the file's own table, for writing back.

    Attributes
    ----------
    log : DataFrame
        The validated canonical log (see :func:`rinscal.schema.validate_log`).
    raw : DataFrame
        The file's table as read, every column under its own name and in its own order
        (columns the reader does not own as text, exactly as written).
    names : dict of str to str
        Canonical name -> the file's name, for renamed columns.
    scale : dict of str to float
        Channel -> factor the mapping multiplied it by.
    sep : str or None
        Field separator of a text file (None for Parquet): a text file is written back with it.
    first_row : int
        Data rows of the file before this table (a log read run by run,
        :func:`rinscal.io.streaming.iter_log_source`).
    """

    log: pd.DataFrame
    raw: pd.DataFrame
    names: dict[str, str]
    scale: dict[str, float]
    sep: str | None = None
    first_row: int = 0

    def write_back(
        self, values: Mapping[str, np.ndarray], extra: Mapping[str, Any]
    ) -> pd.DataFrame:
        """The file's table with some canonical channels replaced and columns appended.

        Parameters
        ----------
        values : mapping of str to ndarray
            Canonical channel -> new values in canonical units (divided back by the
            mapping's scale), written under the file's name for the channel.
        extra : mapping of str to array-like
            Columns to add (or replace, if the file has them) at the end.

        Returns
        -------
        DataFrame
            Same rows, same columns in the same order (then ``extra``); every column not
            named is the file's own, untouched.
        """
        out = self.raw.copy(deep=False)  # new columns replace, the file's table is untouched
        for c, v in values.items():
            x = np.asarray(v, dtype=np.float64)
            out[self.names.get(c, c)] = x / self.scale[c] if c in self.scale else x
        for name, v in extra.items():
            out[name] = v
        return out


def read_log(
    path: str | os.PathLike[str],
    mapping: ColumnMapping | FlightLogOptions | None = None,
    *,
    fmt: str | None = None,
) -> pd.DataFrame:
    """Read and validate a calibration log.

    Parameters
    ----------
    path : path-like
        ``.csv``, ``.tsv`` or ``.parquet`` file.
    mapping : ColumnMapping, optional
        How to read a foreign log; ``None`` for a canonical one.
    fmt : {"csv", "tsv", "parquet"}, optional
        Format, overriding the suffix.

    Returns
    -------
    DataFrame
        The validated canonical log (see :func:`rinscal.schema.validate_log`), rows in file
        order, RangeIndex; columns the reader does not own are text, as written.

    Raises
    ------
    LogError
        Naming the file, the column and the first offending data row.
    """
    _check.path_like("path", path)
    _check.text("fmt", fmt, optional=True)
    check_mapping(mapping)
    return read_log_source(path, mapping, fmt=fmt).log


def check_mapping(mapping: object) -> None:
    """Refuse a ``mapping=`` that is neither a :class:`ColumnMapping`, a
    :class:`~rinscal.io.flightinfo.FlightLogOptions` nor None (a TOML file's path given as
    is), naming the argument.

    Raises
    ------
    ArgumentTypeError
    """
    if mapping is None or isinstance(mapping, ColumnMapping):
        return
    from rinscal.io.flightinfo import FlightLogOptions  # deferred: it loads numba

    accepted = (
        "a ColumnMapping (rinscal.io.mapping.read_mapping reads a TOML file), "
        "a FlightLogOptions or None"
    )
    _check.instance("mapping", mapping, (ColumnMapping, FlightLogOptions), accepted)


def _log_path(
    path: str | os.PathLike[str], fmt: str | None, mapping: object = None
) -> tuple[Path, Format]:
    p = Path(path)
    f = format_of(p, fmt)
    check_mapping(mapping)
    if mapping is not None and not isinstance(mapping, ColumnMapping):
        raise LogError(f"{p}: instance= applies to PX4 .ulg and ArduPilot .bin logs only")
    if mapping is not None:
        check_applies(mapping, "calibration")
    if not p.exists():
        raise LogError(f"{p}: no such file")
    if p.is_dir():
        raise LogError(f"{p}: is a folder, not a log file")
    return p, f


def _source(
    p: Path, raw: pd.DataFrame, mapping: ColumnMapping | None, sep: str | None, first_row: int = 0
) -> SourceLog:
    """Map and validate the file's table (or one run of it) into a :class:`SourceLog`."""
    df, names = raw, {}
    if mapping is not None:
        df, names = _apply_mapping(raw, mapping, p)
    log = validate_log(df, source=str(p), names=names, first_row=first_row)
    scale = dict(mapping.scale) if mapping is not None else {}
    return SourceLog(log, raw, names, scale, sep, first_row)


def read_log_source(
    path: str | os.PathLike[str],
    mapping: ColumnMapping | FlightLogOptions | None = None,
    *,
    fmt: str | None = None,
) -> SourceLog:
    """Read and validate a calibration log, keeping the file's own table (see :func:`read_log`).

    Returns
    -------
    SourceLog
    """
    if fmt is None and is_flight_log(path):
        sources = list(_flight_sources(path, mapping))
        if len(sources) == 1:
            return sources[0]
        # each run is validated as it is made: joined, they need no second pass
        log = pd.concat([s.log for s in sources], ignore_index=True)
        raw = pd.concat([s.raw for s in sources], ignore_index=True)
        return SourceLog(log, raw, {}, {})
    p, f = _log_path(path, fmt, mapping)
    raw, sep = _read_table(p, f, mapping)
    return _source(p, raw, mapping, sep)


def is_flight_log(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` names a PX4 ULog (``.ulg``) or ArduPilot DataFlash (``.bin``) log."""
    return Path(path).suffix.lower() in _FLIGHT_SUFFIXES


def _flight_sources(path: str | os.PathLike[str], options: Any) -> Iterator[SourceLog]:
    """The runs of a flight log (one per IMU instance read), validated, one at a time.

    What the reader did (a truncated end, samples left out) is told as a
    :class:`rinscal.errors.LogNoteWarning`.
    """
    # deferred on purpose: the flight-log readers compile numba kernels (and load pyulog or
    # pymavlink), which reading a table never needs
    from rinscal.io.flightinfo import FlightLogOptions
    from rinscal.io.flightlog import iter_flight_runs

    if isinstance(options, ColumnMapping):
        raise LogError(
            f"{path}: a ULog or DataFlash log is read without a column mapping "
            "(map_file=, col=, time_col=, sep=, temp_col= ...); choose the IMU with instance="
        )
    p = Path(path)
    _, runs, notes = iter_flight_runs(p, options or FlightLogOptions())
    first, told = 0, 0
    for frame in runs:
        for note in notes[told:]:
            warnings.warn(_with_path(p, note), LogNoteWarning, stacklevel=2)
        told = len(notes)
        src = _source(p, frame, None, None, first)
        first += len(frame)
        yield src
    for note in notes[told:]:
        warnings.warn(_with_path(p, note), LogNoteWarning, stacklevel=2)


def _with_path(p: Path, note: str) -> str:
    return note if note.startswith(str(p)) else f"{p}: {note}"


def write_log(
    df: pd.DataFrame,
    path: str | os.PathLike[str],
    *,
    fmt: str | None = None,
    validate: bool = True,
    sep: str | None = None,
) -> None:
    """Write a calibration log atomically, losslessly.

    Floats are written with full (shortest round-trip) precision, so CSV/TSV and Parquet
    read back bit for bit; NaN becomes an empty cell in text files.

    Parameters
    ----------
    df : DataFrame
        The canonical log. The index is not written.
    path : path-like
        Destination; ``.csv``, ``.tsv`` or ``.parquet``.
    fmt : {"csv", "tsv", "parquet"}, optional
        Format, overriding the suffix.
    validate : bool
        Validate the log first (default) so that no invalid log is ever written.
    sep : str, optional
        Field separator of a text file (default: tab for ``.tsv``, comma for ``.csv``).

    Raises
    ------
    LogError
        For an unknown format or an invalid log.
    """
    _check.instance("df", df, pd.DataFrame, "a calibration log as a pandas DataFrame")
    p = _check.path_like("path", path)
    _check.text("fmt", fmt, optional=True)
    _check.flag("validate", validate)
    _check.instance("sep", sep, str, "a field separator (str)", optional=True)
    f = format_of(p, fmt)
    if validate:
        df = validate_log(df, source=f"log to write to {p}")
    if not p.parent.is_dir():
        raise LogError(f"{p}: folder {p.parent} does not exist")

    def writer(tmp: Path) -> None:
        if f == "parquet":
            df.to_parquet(tmp, index=False, use_dictionary=_text_columns(df))
        else:
            df.to_csv(
                tmp,
                sep=sep or ("\t" if f == "tsv" else ","),
                index=False,
                float_format=None,
                lineterminator="\n",
            )

    write_atomic(p, writer)


def _text_columns(df: pd.DataFrame) -> list[str]:
    """Columns to dictionary-encode in Parquet: text (run names) only; on float columns the
    dictionary is never kept and trying costs half the write time."""
    return [str(c) for c in df.columns if not pd.api.types.is_numeric_dtype(df[c])]

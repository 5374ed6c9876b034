"""Read and write calibration logs (CSV, TSV, Parquet); read foreign logs through a mapping.

Verbs: ``read_*`` load and validate a file, ``write_*`` write one atomically (a temporary
file in the same folder, then :func:`os.replace`), so a crash never leaves a half-written
file under the final name.

A foreign log (other column names, a µs or ms timestamp, tab separation, one shared
temperature) is read through a :class:`ColumnMapping`, from a small TOML file
(:func:`read_mapping`) or built from command-line options, never by editing the file::

    # tofupilot_mapping.toml
    separator = "tab"            # "tab", "comma", "semicolon" or "auto"
    time = "timestamp"           # foreign time column ...
    time_unit = "us"             # ... in s, ms or us
    relative_time = true         # shift each run to start at 0 (default false: time as given)
    temperature = "imu.temperature"   # one shared inner temperature -> temp_in
    drop = ["imu.status"]        # columns to leave out
    run = "thermal_cycle"        # run name when the log has no run column (default: file stem)

    [columns]                    # foreign name -> canonical name
    "imu.gyro.x" = "gyro_x"

    [scale]                      # optional: multiply a channel by a factor after reading
    gyro_x = 1.0

    [units]                      # optional: units of the channels (rinscal.units names)
    gyro = "rad/s"
    accel = "m/s^2"

A log may carry sidecar metadata ``<log>.meta.json`` (units, latitude, rate, seed, ...),
read with :func:`read_meta` and written with :func:`write_meta`.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import itertools
import json
import math
import os
import tempfile
import tomllib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import numpy as np
import pandas as pd

from rinscal.errors import ConfigError, LogError, LogNoteWarning, OutputError, describe_os_error
from rinscal.schema import (
    CANONICAL,
    CHANNELS,
    RUN,
    TEMP_IN,
    TIME,
    as_float,
    quoted_columns,
    temperature_column,
    validate_log,
)
from rinscal.units import MS_TO_S, US_TO_S, check_sensor_unit

if TYPE_CHECKING:
    from rinscal.flightlog import FlightLogOptions

__all__ = [
    "FORMATS",
    "ColumnMapping",
    "atomic_path",
    "channel_unit",
    "format_of",
    "is_flight_log",
    "mapping_from_options",
    "meta_path",
    "read_log",
    "read_mapping",
    "read_meta",
    "temperature_column",
    "validate_log",
    "write_atomic",
    "write_log",
    "write_meta",
]

Format = Literal["csv", "tsv", "parquet"]
#: File formats of a log, by suffix.
FORMATS: dict[str, Format] = {".csv": "csv", ".tsv": "tsv", ".parquet": "parquet", ".pq": "parquet"}
#: Time units a mapping accepts, and how many of them make a second (dividing by an exact
#: integer rounds correctly: 1011327 µs -> 1.011327 s, where * 1e-6 would be off by an ulp).
TIME_UNITS: dict[str, float] = {
    "s": 1.0,
    "ms": 1.0 / MS_TO_S,
    "us": 1.0 / US_TO_S,
    "µs": 1.0 / US_TO_S,
}
#: Separator names a mapping accepts.
SEPARATORS: dict[str, str | None] = {
    "auto": None,
    "tab": "\t",
    "comma": ",",
    "semicolon": ";",
    "\t": "\t",
    ",": ",",
    ";": ";",
}
_CHANNEL_GROUPS = {"gyro": CHANNELS[:3], "accel": CHANNELS[3:]}
#: Flight-controller log suffixes (read by :mod:`rinscal.flightlog`).
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


T = TypeVar("T")

# --------------------------------------------------------------------------- mapping


@dataclass(frozen=True)
class ColumnMapping:
    """How to read a foreign log into the canonical schema.

    Parameters
    ----------
    columns : mapping of str to str
        Foreign column name -> canonical name (see :data:`rinscal.schema.CANONICAL`).
    time : str, optional
        Foreign time column, renamed to ``time_s``.
    time_unit : {"s", "ms", "us"}
        Unit of the time column; it is converted to seconds.
    relative_time : bool
        Shift each run's time so that its first sample is at 0 s, e.g. for an absolute µs
        timestamp. Off by default: time is read as given (only its unit converted).
    separator : {"auto", "tab", "comma", "semicolon"}, optional
        Field separator of a text file; ``None`` (default) follows the suffix
        (``.tsv`` tab, ``.csv`` comma); ``"auto"`` guesses from the header line.
    temperature : str, optional
        A single foreign temperature column shared by all sensors, renamed to ``temp_in``.
    run : str, optional
        Run name for a log without a run column (default: the file's stem).
    scale : mapping of str to float
        Canonical channel -> factor multiplying its values after reading.
    drop : tuple of str
        Foreign columns to leave out.
    units : mapping of str to str
        Canonical channel (or ``"gyro"``/``"accel"`` for all three) -> unit name of the
        values after scaling, e.g. ``"rad/s"``; used for plot labels.
    """

    columns: Mapping[str, str] = field(default_factory=dict)
    time: str | None = None
    time_unit: str = "s"
    relative_time: bool = False
    separator: str | None = None
    temperature: str | None = None
    run: str | None = None
    scale: Mapping[str, float] = field(default_factory=dict)
    drop: tuple[str, ...] = ()
    units: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "columns", dict(self.columns))
        object.__setattr__(self, "scale", dict(self.scale))
        object.__setattr__(self, "drop", tuple(self.drop))
        object.__setattr__(self, "units", dict(self.units))
        for foreign, canon in self.columns.items():
            if canon not in CANONICAL:
                raise ConfigError(
                    f"columns: {foreign!r} -> {canon!r}: {canon!r} is not a canonical column "
                    f"(canonical: {', '.join(CANONICAL)})"
                )
        check_mapping_basics(self)
        for ch, k in self.scale.items():
            if ch not in CHANNELS:
                raise ConfigError(f"scale: {ch!r} is not a channel ({', '.join(CHANNELS)})")
            if isinstance(k, bool) or not isinstance(k, int | float) or not math.isfinite(k):
                raise ConfigError(f"scale.{ch}: {k!r} is not a finite number")
        for key, unit in self.units.items():
            if key not in CHANNELS and key not in _CHANNEL_GROUPS:
                raise ConfigError(
                    f"units: {key!r} is not a channel, 'gyro' or 'accel' ({', '.join(CHANNELS)})"
                )
            if not isinstance(unit, str):
                raise ConfigError(f"units.{key}: {unit!r} is not a unit name")
            try:
                check_sensor_unit(key.partition("_")[0], unit)  # gyro_x and gyro -> gyro
            except ValueError as exc:
                raise ConfigError(f"units.{key}: {exc}") from None
        if self.run is not None and (not isinstance(self.run, str) or not self.run):
            raise ConfigError(f"run: {self.run!r} is not a run name")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<mapping>") -> ColumnMapping:
        """Build a mapping from parsed TOML (or any dict of the same keys).

        Parameters
        ----------
        data : mapping
            Keys as in the module docstring.
        source : str
            Named in error messages.

        Raises
        ------
        ConfigError
            Naming ``source`` and the offending key.
        """
        kw = mapping_keys(cls, data, source, tables=("columns", "scale", "units"))
        if "drop" in kw:
            drop = kw["drop"]
            if isinstance(drop, str):
                drop = [drop]
            if not isinstance(drop, list | tuple) or not all(isinstance(d, str) for d in drop):
                raise ConfigError(f"{source}: drop must be a list of column names")
            kw["drop"] = tuple(drop)
        for key in ("time", "time_unit", "separator", "temperature", "run"):
            if key in kw and not isinstance(kw[key], str):
                raise ConfigError(f"{source}: {key} must be a string, got {kw[key]!r}")
        if "relative_time" in kw and not isinstance(kw["relative_time"], bool):
            raise ConfigError(f"{source}: relative_time must be true or false")
        try:
            return cls(**kw)
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None

    def unit_of(self, channel: str) -> str | None:
        """Unit of ``channel`` declared in :attr:`units`, or ``None``."""
        return channel_unit(self.units, channel)

    def foreign_columns(self) -> list[str]:
        """Every foreign column the mapping names (and so the file must have)."""
        cols = list(self.columns)
        cols += [c for c in (self.time, self.temperature) if c is not None]
        return cols


def mapping_keys(
    cls: type, data: Mapping[str, Any], source: str, tables: Sequence[str]
) -> dict[str, Any]:
    """A mapping's keys as a dict for ``cls``, unknown keys and non-table tables refused.

    Parameters
    ----------
    cls : dataclass type
        The mapping class (its fields are the known keys).
    data : mapping
        Parsed TOML.
    source : str
        Named in error messages.
    tables : sequence of str
        Keys whose values must be tables.
    """
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ConfigError(
            f"{source}: unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(known))})"
        )
    kw = dict(data)
    for key in tables:
        if key in kw and not isinstance(kw[key], Mapping):
            raise ConfigError(f"{source}: {key} must be a table")
    return kw


def check_mapping_basics(mapping: Any) -> None:
    """The checks every mapping shares: no two foreign columns onto one canonical name, a
    known time unit and separator.

    Parameters
    ----------
    mapping : ColumnMapping or rinscal.navlog.NavMapping
        Anything with ``columns``, ``time``, ``temperature``, ``time_unit``, ``separator``.

    Raises
    ------
    ConfigError
        Naming the key.
    """
    targets = list(mapping.columns.values())
    if mapping.time is not None:
        targets.append(TIME)
    if mapping.temperature is not None:
        targets.append(TEMP_IN)
    dup = sorted({t for t in targets if targets.count(t) > 1})
    if dup:
        raise ConfigError(f"columns: several foreign columns map to {', '.join(dup)}")
    if mapping.time_unit not in TIME_UNITS:
        raise ConfigError(f"time_unit: {mapping.time_unit!r} is not one of {', '.join(TIME_UNITS)}")
    if mapping.separator is not None and mapping.separator not in SEPARATORS:
        raise ConfigError(
            f"separator: {mapping.separator!r} is not one of auto, tab, comma, semicolon"
        )


def channel_unit(units: Mapping[str, Any], channel: str) -> str | None:
    """Unit of ``channel`` in a units table keyed by channel or by sensor, or ``None``.

    Parameters
    ----------
    units : mapping
        ``{"gyro_x": "deg/h", ...}`` and/or ``{"gyro": "rad/s", "accel": "m/s^2"}`` (a
        mapping's ``[units]``, a log's ``meta["units"]``); a channel's own entry wins.
    channel : str
        A sensor channel, e.g. ``"accel_z"``.
    """
    if channel in units:
        return str(units[channel])
    for group, chans in _CHANNEL_GROUPS.items():
        if channel in chans and group in units:
            return str(units[group])
    return None


def read_mapping(path: str | os.PathLike[str]) -> ColumnMapping:
    """Read a :class:`ColumnMapping` from a TOML file.

    Parameters
    ----------
    path : path-like
        The TOML file (keys as in the module docstring).

    Raises
    ------
    ConfigError
        If the file is missing, not TOML, or has an unknown or invalid key (named).
    """
    p = Path(path)
    return ColumnMapping.from_dict(mapping_toml(p), source=str(p))


def mapping_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The parsed TOML of a mapping file (either reader's).

    Raises
    ------
    ConfigError
        If the file is missing, a folder or not TOML (named).
    """
    p = Path(path)
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{p}: mapping file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{p}: is a folder, not a mapping file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: not a valid TOML mapping file: {exc}") from None


def mapping_from_options(
    base: ColumnMapping | None = None,
    *,
    columns: Sequence[str] = (),
    time: str | None = None,
    time_unit: str | None = None,
    separator: str | None = None,
    temperature: str | None = None,
    run: str | None = None,
    drop: Sequence[str] = (),
    scale: Sequence[str] = (),
    relative_time: bool | None = None,
) -> ColumnMapping | None:
    """Build (or override) a mapping from command-line style options.

    Parameters
    ----------
    base : ColumnMapping, optional
        A mapping read from a file; the options override or extend it.
    columns : sequence of str
        ``"FOREIGN=canonical"`` pairs.
    time, time_unit, separator, temperature, run : str, optional
        As in :class:`ColumnMapping`.
    drop : sequence of str
        Foreign columns to leave out.
    scale : sequence of str
        ``"channel=factor"`` pairs.
    relative_time : bool, optional
        Override the mapping's ``relative_time`` (None: keep it; off without a mapping).

    Returns
    -------
    ColumnMapping or None
        ``None`` when there is neither a base nor any option (read the log as canonical).

    Raises
    ------
    ConfigError
        For a malformed pair or value, naming the option.
    """

    def pairs(items: Sequence[str], option: str) -> dict[str, str]:
        out = {}
        for item in items:
            key, sep, value = item.rpartition("=")
            if not sep or not key or not value:
                raise ConfigError(f"{option}: {item!r} is not of the form NAME=VALUE")
            out[key] = value
        return out

    scale_values: dict[str, float] = {}
    for ch, text in pairs(scale, "--scale").items():
        try:
            scale_values[ch] = float(text)
        except ValueError:
            raise ConfigError(f"--scale: {ch}={text!r} is not a number") from None
    given = {
        "time": time,
        "time_unit": time_unit,
        "separator": separator,
        "temperature": temperature,
        "run": run,
        "relative_time": relative_time,
    }
    given = {k: v for k, v in given.items() if v is not None}
    if base is None and not (given or columns or drop or scale):
        return None
    base = base or ColumnMapping()
    extra = pairs(columns, "--col")
    # an option mapping a column onto a canonical name replaces the file's entry for it
    kept = {f: c for f, c in base.columns.items() if c not in extra.values() and f not in extra}
    return dataclasses.replace(
        base,
        columns={**kept, **extra},
        drop=(*base.drop, *drop),
        scale={**base.scale, **scale_values},
        **given,
    )


# --------------------------------------------------------------------------- reading


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


def _table_pieces(
    p: Path, fmt: Format, mapping: ColumnMapping | None, piece_rows: int
) -> tuple[Iterator[Any], str | None]:
    """The file's table in pieces of at most ``piece_rows`` rows, and its separator.

    Parquet pieces are Arrow record batches (joined in Arrow, converted once per run); text
    pieces are DataFrames.
    """
    if fmt == "parquet":
        import pyarrow.parquet as pq

        _check_parquet(p)
        try:  # buffered reads, no pre-buffering of whole row groups (memory: a piece)
            pf = pq.ParquetFile(p, buffer_size=1 << 20, pre_buffer=False)
        except Exception as exc:  # pyarrow raises many types for a damaged file
            raise LogError(f"{p}: unreadable Parquet file: {exc}") from None
        names = [n for n in pf.schema_arrow.names if not n.startswith("__index_level_")]

        def parquet() -> Iterator[Any]:
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


def by_runs(
    path: str | os.PathLike[str],
    mapping: ColumnMapping | FlightLogOptions | None,
    consume: Callable[[Iterator[SourceLog]], T],
) -> T:
    """``consume`` the log's runs as :func:`iter_log_source` reads them, one at a time.

    A log whose runs are interleaved cannot be read run by run: ``consume`` is then called
    again, from the start, with the whole log as its one item (:func:`read_log_source`);
    ``consume`` must not have written anything final before it returns.
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
        import pyarrow as pa

        table = pa.Table.from_batches(pieces)
        pieces.clear()  # the table holds the only reference: converted, its buffers go
        # one block per column (no 2-D consolidation copy), Arrow memory freed column by column
        return table.to_pandas(split_blocks=True, self_destruct=True)
    if len(pieces) == 1:
        return pieces[0].reset_index(drop=True)
    return pd.concat(pieces, ignore_index=True)


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
    rename = dict(mapping.columns)
    if mapping.time is not None:
        rename[mapping.time] = TIME
    if mapping.temperature is not None:
        rename[mapping.temperature] = TEMP_IN
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
        df[RUN] = mapping.run or p.stem
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
        Data rows of the file before this table (a log read run by run, :func:`iter_log_source`).
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
            out[self.names.get(c, c)] = np.asarray(v, dtype=np.float64) / self.scale.get(c, 1.0)
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
    return read_log_source(path, mapping, fmt=fmt).log


def _log_path(
    path: str | os.PathLike[str], fmt: str | None, mapping: object = None
) -> tuple[Path, Format]:
    p = Path(path)
    f = format_of(p, fmt)
    if mapping is not None and not isinstance(mapping, ColumnMapping):
        raise LogError(f"{p}: --instance applies to PX4 .ulg and ArduPilot .bin logs only")
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
    import warnings

    from rinscal.flightlog import FlightLogOptions, iter_flight_runs

    if isinstance(options, ColumnMapping):
        raise LogError(
            f"{path}: a ULog or DataFlash log is read without a column mapping "
            "(--map, --col, --time-col, --sep, --temp-col ...); choose the IMU with --instance"
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


class InterleavedRunsError(LogError):
    """A run continues after another run began: the log cannot be read run by run."""


#: Rows per piece read by :func:`iter_log_source` (Parquet batch or CSV chunk).
PIECE_ROWS = 1 << 18


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
    :class:`SourceLog` (``first_row`` says where it starts in the file). Every run's table is
    exactly what :func:`read_log_source` gives for its rows.

    Parameters
    ----------
    path, mapping, fmt
        As for :func:`read_log_source`.
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
        :func:`read_log_source`), also when the part of a run before another run began is
        not a valid run on its own (one sample, say): it is never refused for that.
    LogError
        As :func:`read_log_source`, with the row numbers of the whole file.
    """
    piece_rows = PIECE_ROWS if piece_rows is None else int(piece_rows)
    if piece_rows < 1:
        raise ValueError(f"piece_rows must be at least 1, got {piece_rows}")
    if fmt is None and is_flight_log(path):
        yield from _flight_sources(path, mapping)
        return
    p, f = _log_path(path, fmt, mapping)
    pieces, sep = _table_pieces(p, f, mapping, int(piece_rows))
    run_col = RUN
    if mapping is not None:
        run_col = next((k for k, c in mapping.columns.items() if c == RUN), RUN)
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


# --------------------------------------------------------------------------- writing


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` if the block succeeds.

    The temporary file keeps the suffix of ``path`` (writers that pick the format from it
    work) and is removed if the block raises. An operating-system error (permission, missing
    folder, full disk) becomes :class:`rinscal.errors.OutputError` naming ``path``.
    """
    p = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=f".tmp{p.suffix}", dir=p.parent)
    except OSError as exc:
        raise OutputError(describe_os_error(exc, p)) from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes the file private (0600); give it the permissions of a normal file
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp_path, 0o666 & ~umask)
        os.replace(tmp_path, p)
    except OutputError:
        raise
    except OSError as exc:  # disk full while writing, a folder in the way of the name...
        raise OutputError(describe_os_error(exc, p)) from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()


def write_atomic(path: str | os.PathLike[str], writer: Callable[[Path], None]) -> None:
    """Call ``writer(tmp_path)`` and move the result onto ``path`` atomically."""
    with atomic_path(path) as tmp:
        writer(tmp)


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
    p = Path(path)
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


# --------------------------------------------------------------------------- metadata


def meta_path(logpath: str | os.PathLike[str]) -> Path:
    """Sidecar metadata path of a log: ``<logpath>.meta.json``."""
    p = Path(logpath)
    return p.with_name(p.name + ".meta.json")


def _json_default(obj: object) -> object:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def read_meta(logpath: str | os.PathLike[str]) -> dict[str, Any] | None:
    """Read the sidecar metadata of a log, if it has one.

    Parameters
    ----------
    logpath : path-like
        The log (not the metadata file).

    Returns
    -------
    dict or None
        The metadata, e.g. ``{"units": {"gyro_x": "deg/h", ...}, "rate_hz": 100.0, ...}``;
        ``None`` when there is no ``<logpath>.meta.json``.

    Raises
    ------
    LogError
        If the file is not a JSON object.
    """
    mp = meta_path(logpath)
    if not mp.is_file():
        return None
    try:
        meta = json.loads(mp.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise LogError(f"{mp}: not valid JSON metadata: {exc}") from None
    if not isinstance(meta, dict):
        raise LogError(f"{mp}: metadata must be a JSON object, got {type(meta).__name__}")
    return meta


def write_meta(meta: Mapping[str, Any], logpath: str | os.PathLike[str]) -> Path:
    """Write sidecar metadata beside a log, atomically.

    Parameters
    ----------
    meta : mapping
        JSON-serialisable (numpy scalars and arrays are converted).
    logpath : path-like
        The log the metadata describes.

    Returns
    -------
    Path
        The metadata file written, ``<logpath>.meta.json``.
    """
    mp = meta_path(logpath)
    text = json.dumps(dict(meta), indent=2, default=_json_default, allow_nan=False) + "\n"
    write_atomic(mp, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return mp


# --------------------------------------------------------------------------- streaming


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
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        fmt: str | None = None,
        validate: bool = True,
        sep: str | None = None,
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

    def __enter__(self) -> LogStreamWriter:
        self._tmp = self._ctx.__enter__()
        return self

    def write(self, frame: pd.DataFrame) -> None:
        """Append whole runs [rows keep their order]."""
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
                table = pa.Table.from_pandas(df, schema=self._writer.schema, preserve_index=False)
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

    def __exit__(self, exc_type: object, exc: BaseException | None, tb: object) -> None:
        if self._writer is not None:
            self._writer.close()
        if exc is None and self.rows == 0:
            exc = LogError(f"{self.path}: nothing to write (no runs)")
            self._ctx.__exit__(type(exc), exc, None)
            raise exc
        self._ctx.__exit__(exc_type, exc, tb)


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

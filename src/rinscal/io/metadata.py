"""Sidecar metadata of a log: ``<log>.meta.json`` (units, latitude, rate, seed, ...).

Read with :func:`read_meta`, written atomically with :func:`write_meta`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from rinscal import _check
from rinscal.errors import LogError
from rinscal.io.atomic import write_atomic

__all__ = [
    "meta_path",
    "read_meta",
    "side_files",
    "truth_path",
    "write_meta",
]


def meta_path(logpath: str | os.PathLike[str]) -> Path:
    """Sidecar metadata path of a log: ``<logpath>.meta.json``."""
    p = Path(logpath)
    return p.with_name(p.name + ".meta.json")


def truth_path(logpath: str | os.PathLike[str]) -> Path:
    """The simulator's truth beside a simulated log: ``cal.parquet`` → ``cal.truth.parquet``
    (the true thermal bias of every sample, in the log's format)."""
    p = Path(logpath)
    return p.with_name(f"{p.stem}.truth{p.suffix}")


def side_files(logpath: str | os.PathLike[str]) -> list[Path]:
    """The files written beside a log that are not logs: its truth (:func:`truth_path`), the
    multiposition truth table (``.params.truth.csv``) and its sidecar metadata
    (:func:`meta_path`)."""
    # deferred: the parameter table's module loads pandas
    from rinscal.io.params import TRUTH_SUFFIX, params_path

    return [truth_path(logpath), params_path(logpath, TRUTH_SUFFIX), meta_path(logpath)]


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
    _check_meta(meta, mp)
    return meta


#: Metadata keys that hold an object of per-channel (or per-sensor) entries, and the type of
#: an entry; keys that hold a number.
_META_TABLES = {"units": str, "unit_to_si": float}
_META_NUMBERS = ("latitude_deg", "heading_deg", "altitude_m", "rate_hz")


def _check_meta(meta: Mapping[str, Any], mp: Path) -> None:
    """The types of the keys a reader uses, so that an edited sidecar is refused naming the
    file and the key (not a crash inside, not a value ignored)."""

    def is_number(v: Any) -> bool:
        return isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v)

    for key, kind in _META_TABLES.items():
        table = meta.get(key)
        if table is None:
            continue
        if not isinstance(table, dict):
            raise LogError(
                f"{mp}: {key} must be an object of channel: value, got {type(table).__name__}"
            )
        for name, v in table.items():
            if v is None:  # not given
                continue
            ok = isinstance(v, str) if kind is str else (is_number(v) and v > 0)
            if not ok:
                want = "a unit name" if kind is str else "a positive number"
                raise LogError(f"{mp}: {key}.{name} must be {want}, got {v!r}")
    for key in _META_NUMBERS:
        v = meta.get(key)
        if v is not None and not is_number(v):
            raise LogError(f"{mp}: {key} must be a finite number, got {v!r}")


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
    _check.mapping("meta", meta)
    _check.path_like("logpath", logpath)
    mp = meta_path(logpath)
    text = json.dumps(dict(meta), indent=2, default=_json_default, allow_nan=False) + "\n"
    write_atomic(mp, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return mp

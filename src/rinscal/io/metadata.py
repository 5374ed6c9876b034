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
    _check.mapping("meta", meta)
    _check.path_like("logpath", logpath)
    mp = meta_path(logpath)
    text = json.dumps(dict(meta), indent=2, default=_json_default, allow_nan=False) + "\n"
    write_atomic(mp, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return mp

"""Checks of a public function's arguments at its boundary, with messages naming the argument.

Every function of the Python API (``rinscal.__all__``) calls these first, so that a wrong
type or value is refused with the project's errors (:mod:`rinscal.errors`) naming the
argument, what was given (its type and value, shortened) and what is accepted, instead of
an error from deep inside pandas, numpy or pathlib.

* A wrong type raises :class:`~rinscal.errors.ArgumentTypeError` (a ``TypeError`` and a
  ``ConfigError``). Numbers given as strings (``hours="0.05"``) are a wrong type: they are
  refused, not converted, with a hint to drop the quotes.
* A wrong value (out of range, not one of the choices, not finite) raises
  :class:`~rinscal.errors.ConfigError` (a ``ValueError``).
* A table with no rows or not a calibration log raises :class:`~rinscal.errors.LogError`
  (a ``ValueError``), through :func:`rinscal.schema.validate_log` where it is a log.

Each helper returns the value as the function will use it (a number as ``float`` or
``int``, a path as :class:`~pathlib.Path`, a log as its validated table).
"""

from __future__ import annotations

import math
import numbers
import os
import sys
import warnings
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rinscal.errors import ArgumentTypeError, ConfigError, LogError

if TYPE_CHECKING:  # pandas is imported by the caller that has a table, never here:
    import pandas as pd  # model files load with numpy alone (test_inference_needs_numpy_only)

__all__ = [
    "array",
    "callback",
    "deprecated",
    "flag",
    "instance",
    "log_like",
    "log_table",
    "mapping",
    "number",
    "numbers_of",
    "one_of",
    "path_like",
    "renamed",
    "shown",
    "strings",
    "text",
    "wrong_type",
]

#: The longest value repr a message shows.
SHOWN_CHARS = 60


def _is_frame(value: Any) -> bool:
    """Whether ``value`` is a :class:`pandas.DataFrame` (False, without importing pandas,
    where nothing has imported it: then no value can be one)."""
    pd = sys.modules.get("pandas")
    return pd is not None and isinstance(value, pd.DataFrame)


def shown(value: Any, limit: int = SHOWN_CHARS) -> str:
    """A value as a message shows it: its type and its repr, shortened (``str '0.05'``)."""
    if _is_frame(value):
        return f"a DataFrame of {len(value)} rows × {value.shape[1]} columns"
    r = repr(value)
    if len(r) > limit:
        r = r[: limit - 3] + "..."
    return f"{type(value).__name__} {r}"


def _is_numeric_text(value: Any) -> bool:
    if not isinstance(value, str):
        return False
    try:
        float(value)
    except ValueError:
        return False
    return True


def wrong_type(name: str, value: Any, accepted: str, *, listed: bool = False) -> ArgumentTypeError:
    """The error for ``name`` given ``value`` of a type it does not take (``listed``: the
    argument is a sequence, so a number as text is shown as a list)."""
    hint = ""
    if _is_numeric_text(value):
        given = f"[{value.strip()}]" if listed else value.strip()
        hint = f"; numbers are not read from text: give {given} without quotes"
    return ArgumentTypeError(f"{name}: expected {accepted}, got {shown(value)}{hint}")


def number(
    name: str,
    value: Any,
    *,
    min: float | None = None,
    above: float | None = None,
    max: float | None = None,
    integer: bool = False,
    optional: bool = False,
    unit: str = "",
) -> Any:
    """A finite real number (int, float or a numpy scalar; not a bool, not a string).

    Parameters
    ----------
    name : str
        The argument's name, as the message gives it.
    value : object
        What was given.
    min, above, max : float, optional
        ``value >= min``, ``value > above``, ``value <= max``.
    integer : bool
        A whole number (an int, or a float with no fractional part), returned as ``int``.
    optional : bool
        ``None`` is accepted (and returned).
    unit : str
        The unit the message appends to a bound (``"s"``, ``"Hz"``).

    Returns
    -------
    float, int or None
    """
    if value is None and optional:
        return None
    kind = "a whole number (int)" if integer else "a number (int or float)"
    if optional:
        kind += " or None"
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise wrong_type(name, value, kind)
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(f"{name} must be a finite number, got {value!r}")
    if integer:
        if not v.is_integer():
            raise wrong_type(name, value, kind)
        v = int(value)
    sfx = f" {unit}" if unit else ""
    if min is not None and v < min:
        raise ConfigError(f"{name} must be >= {min:g}{sfx}, got {value!r}")
    if above is not None and not v > above:
        raise ConfigError(f"{name} must be > {above:g}{sfx}, got {value!r}")
    if max is not None and v > max:
        raise ConfigError(f"{name} must be <= {max:g}{sfx}, got {value!r}")
    return v


def numbers_of(
    name: str,
    value: Any,
    *,
    length: int | None = None,
    nonempty: bool = True,
    optional: bool = False,
    **bounds: Any,
) -> tuple[Any, ...] | None:
    """A sequence of numbers (list, tuple or array), each checked as :func:`number`."""
    if value is None and optional:
        return None
    what = "a sequence of numbers" if length is None else f"{length} numbers"
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence | np.ndarray):
        raise wrong_type(name, value, what + (" or None" if optional else ""), listed=True)
    items = list(np.asarray(value).ravel()) if isinstance(value, np.ndarray) else list(value)
    if length is not None and len(items) != length:
        raise ConfigError(f"{name} must hold {length} numbers, got {len(items)}: {value!r}")
    if nonempty and not items:
        raise ConfigError(f"{name} is empty: give at least one number")
    return tuple(number(f"{name}[{k}]", v, **bounds) for k, v in enumerate(items))


def strings(name: str, value: Any, *, optional: bool = False) -> tuple[str, ...] | None:
    """A sequence of strings (a list or tuple; a single string is not one)."""
    if value is None and optional:
        return None
    accepted = "a list of strings" + (" or None" if optional else "")
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise wrong_type(name, value, accepted)
    for k, v in enumerate(value):
        if not isinstance(v, str):
            raise wrong_type(f"{name}[{k}]", v, "a string")
    return tuple(value)


def array(name: str, value: Any, *, last: int | None = None, optional: bool = False) -> Any:
    """An array of numbers (any array-like, returned as a float ndarray); ``last``: the size
    its last axis must have (e.g. 6 channels)."""
    if value is None and optional:
        return None
    accepted = "an array of numbers" + (f" with {last} columns" if last else "")
    if isinstance(value, str | bytes | Mapping):
        raise wrong_type(name, value, accepted)
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise wrong_type(name, value, accepted) from None
    if last is not None and (a.ndim == 0 or a.shape[-1] != last):
        raise ConfigError(
            f"{name} must have {last} columns (shape (n, {last})), got shape {a.shape}"
        )
    return a


def callback(name: str, value: Any) -> Any:
    """A callable or None (a progress hook): a string or a number is refused at once, not
    where the function first calls it."""
    if value is not None and not callable(value):
        raise wrong_type(name, value, "a callable (a function) or None")
    return value


def deprecated(name: str, value: Any, instead: str, depth: int = 1) -> Any:
    """``value`` of a keyword kept for one release: a :class:`DeprecationWarning` naming what
    replaces it (``instead``) when it is given (not ``None``), pointed at the caller of the
    public function ``depth`` frames up (1: the function that calls this)."""
    if value is not None:
        warnings.warn(
            f"{name}= is deprecated and goes in the next release: use {instead}",
            DeprecationWarning,
            stacklevel=2 + depth,
        )
    return value


def renamed(new: str, value: Any, old: str, old_value: Any, default: Any = None) -> Any:
    """A keyword and its old name (kept for one release, with a :class:`DeprecationWarning`):
    the one given, else ``default``; both given is a :class:`ConfigError`."""
    if old_value is None:
        return default if value is None else value
    if value is not None:
        raise ConfigError(f"give {new}= once ({old}= is its old name), not both")
    warnings.warn(
        f"{old}= is now {new}=; the old name goes in the next release",
        DeprecationWarning,
        stacklevel=3,
    )
    return old_value


def alias(new: str, value: Any, old: str, old_value: Any) -> Any:
    """A keyword and its other name, kept without a warning (``n_jobs=`` and ``workers=``):
    the one given (None if neither); both given with different values is a
    :class:`ConfigError` naming both."""
    if old_value is None:
        return value
    if value is not None and value != old_value:
        raise ConfigError(
            f"{new}={value!r} and {old}={old_value!r}: {old}= is another name of {new}=; "
            "give one of them"
        )
    return old_value


def flag(name: str, value: Any, *, optional: bool = False) -> bool | None:
    """A bool (``True`` or ``False``; numpy's too): ``"no"`` or ``0`` are not."""
    if value is None and optional:
        return None
    if not isinstance(value, bool | np.bool_):
        raise wrong_type(name, value, "True or False" + (" or None" if optional else ""))
    return bool(value)


def text(name: str, value: Any, *, optional: bool = False) -> str | None:
    """A non-empty string."""
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise wrong_type(name, value, "a string" + (" or None" if optional else ""))
    if not value.strip():
        raise ConfigError(f"{name} is empty")
    return value


def one_of(name: str, value: Any, choices: Collection[str], *, optional: bool = False) -> Any:
    """One of ``choices`` (strings)."""
    if value is None and optional:
        return None
    listed = ", ".join(map(str, choices))
    if not isinstance(value, str):
        raise wrong_type(name, value, f"one of {listed}")
    if value not in choices:
        raise ConfigError(f"{name} must be one of {listed}; got {value!r}")
    return value


def path_like(name: str, value: Any, *, optional: bool = False) -> Path | None:
    """A file or folder path: a ``str`` or an :class:`os.PathLike` (not bytes, not empty)."""
    if value is None and optional:
        return None
    if not isinstance(value, str | os.PathLike):
        raise wrong_type(
            name, value, "a path (str or os.PathLike)" + (" or None" if optional else "")
        )
    p = os.fspath(value)
    if not isinstance(p, str):
        raise wrong_type(name, value, "a path (str or os.PathLike)")
    if not p.strip():
        raise ConfigError(f"{name} is an empty path")
    return Path(p)


def mapping(name: str, value: Any, *, optional: bool = False) -> Mapping[str, Any] | None:
    """A mapping (a dict)."""
    if value is None and optional:
        return None
    if not isinstance(value, Mapping):
        raise wrong_type(name, value, "a mapping (dict)" + (" or None" if optional else ""))
    return value


def instance(
    name: str, value: Any, types: type | tuple[type, ...], accepted: str, *, optional: bool = False
) -> Any:
    """``value`` of one of ``types``; ``accepted`` says what in words."""
    if value is None and optional:
        return None
    if not isinstance(value, types):
        raise wrong_type(name, value, accepted + (" or None" if optional else ""))
    return value


def log_table(name: str, value: Any, *, validate: bool = True) -> pd.DataFrame:
    """A calibration log as a table: a non-empty :class:`pandas.DataFrame` that passes
    :func:`rinscal.schema.validate_log` (returned validated; messages name ``name``);
    ``validate=False``: the type and the rows only (the function checks its columns)."""
    if not _is_frame(value):
        raise wrong_type(name, value, "a calibration log as a pandas DataFrame")
    if len(value) == 0:
        cols = (
            f"columns {', '.join(map(str, value.columns[:8]))}" if value.shape[1] else "no columns"
        )
        raise LogError(
            f"{name} has no rows (an empty DataFrame, {cols}); give a calibration log "
            "(rinscal.read_log or rinscal.simulate)"
        )
    if not validate:
        return value
    from rinscal.schema import validate_log  # deferred: schema imports pandas

    return validate_log(value, source=name)


def log_like(name: str, value: Any, *, table: bool = True) -> Path | pd.DataFrame:
    """A calibration log: a file's path, or (``table``) a table as :func:`log_table`."""
    if table and _is_frame(value):
        return log_table(name, value)
    if not isinstance(value, str | os.PathLike):
        accepted = "a log file's path (str or os.PathLike)"
        raise wrong_type(name, value, accepted + (" or a pandas DataFrame" if table else ""))
    return path_like(name, value)  # type: ignore[return-value]

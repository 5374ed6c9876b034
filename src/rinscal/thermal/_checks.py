"""Checks of configuration numbers shared by the thermal laws and the IMU configuration."""

from __future__ import annotations

import math
import numbers

from rinscal._check import wrong_type
from rinscal.errors import ConfigError

__all__: list[str] = []


def _finite(name: str, value: float) -> float:
    # a string or a bool is not read as a number (float("30") would pass and keep the str)
    if isinstance(value, str | bytes | bool) or not isinstance(value, numbers.Real):
        raise wrong_type(name, value, "a number (int or float)")
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(f"{name} must be a finite number, got {value!r}")
    return v


def _nonneg(name: str, value: float) -> float:
    v = _finite(name, value)
    if v < 0:
        raise ConfigError(f"{name} must be >= 0, got {value!r}")
    return v

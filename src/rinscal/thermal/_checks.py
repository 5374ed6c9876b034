"""Checks of configuration numbers shared by the thermal laws and the IMU configuration."""

from __future__ import annotations

import math

from rinscal.errors import ConfigError

__all__: list[str] = []


def _finite(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(f"{name} must be a finite number, got {value!r}")
    return v


def _nonneg(name: str, value: float) -> float:
    v = _finite(name, value)
    if v < 0:
        raise ConfigError(f"{name} must be >= 0, got {value!r}")
    return v

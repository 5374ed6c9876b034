"""Checks of configuration numbers shared by the thermal laws and the IMU configuration."""

from __future__ import annotations

from rinscal import _check

__all__: list[str] = []


def _finite(name: str, value: float) -> float:
    """A finite number, not a string or a bool (``float("30")`` would pass and keep the str)."""
    return float(_check.number(name, value))


def _nonneg(name: str, value: float) -> float:
    """A finite number ``>= 0``."""
    return float(_check.number(name, value, min=0))

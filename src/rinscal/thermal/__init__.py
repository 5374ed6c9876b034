"""Deprecated: the simulator moved to :mod:`rinscal.sim` (IMU preset names to
:mod:`rinscal.presets`). Kept for one release so that ``import rinscal.thermal.config`` and
the like still work; importing it warns (:class:`DeprecationWarning`) and loads every module
of the old package from its new home. Nothing in rinscal imports it.
"""

from __future__ import annotations

import sys
import warnings

from rinscal import presets
from rinscal.sim import (
    config,
    field,
    mechanistic,
    multiposition,
    plant,
    polynomial,
    protocols,
    sensor,
)

warnings.warn(
    "rinscal.thermal is deprecated: import rinscal.sim (the IMU preset names: rinscal.presets)",
    DeprecationWarning,
    stacklevel=2,
)

#: Old module name -> the module that now holds it.
MOVED = {
    "presets": presets,
    "config": config,
    "field": field,
    "mechanistic": mechanistic,
    "multiposition": multiposition,
    "plant": plant,
    "polynomial": polynomial,
    "protocols": protocols,
    "sensor": sensor,
}
for _name, _module in MOVED.items():
    sys.modules[f"{__name__}.{_name}"] = _module

__all__ = list(MOVED)

"""Names of the built-in IMU presets (a light module: the CLI reads it at start-up).

The presets themselves are TOML files in ``rinscal/data``; :func:`rinscal.sim.config.load_imu`
reads them.
"""

from __future__ import annotations

#: Built-in IMU presets, chosen by name wherever an IMU is accepted.
PRESETS = (
    "paper",
    "navigation_grade",
    "paper_mechanistic",
    "navigation_grade_mechanistic",
    "ring_laser",
)
#: The preset the tool runs by default: the paper's own IMU.
DEFAULT_PRESET = "paper"

__all__ = ["DEFAULT_PRESET", "PRESETS"]

"""Old names of the navigation recording's mapping, kept for one release.

The one mapping of every foreign log is :class:`rinscal.io.mapping.ColumnMapping`, read by
:func:`rinscal.io.mapping.read_mapping` with ``log_kind="navigation"`` for a recording; the
recording's format is described in :mod:`rinscal.io.navopen`.
"""

from __future__ import annotations

import os

from rinscal.io.mapping import (
    ANGLE_WEIGHT_UNITS,
    VELOCITY_WEIGHT_UNITS,
    ColumnMapping,
    parse_weight,
    read_mapping,
)

__all__ = [
    "ANGLE_WEIGHT_UNITS",
    "VELOCITY_WEIGHT_UNITS",
    "NavMapping",
    "parse_weight",
    "read_nav_mapping",
]

#: Old name of :class:`rinscal.io.mapping.ColumnMapping` (a recording's ``run`` is now
#: ``select_run``).
NavMapping = ColumnMapping


def read_nav_mapping(path: str | os.PathLike[str]) -> ColumnMapping:
    """Old name of ``read_mapping(path, log_kind="navigation")``.

    Raises
    ------
    ConfigError
        As :func:`rinscal.io.mapping.read_mapping`.
    """
    return read_mapping(path, log_kind="navigation")

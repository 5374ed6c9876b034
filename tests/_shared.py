"""Where the tests find the project's shared data (not in git): the real thermal-cycle log.

``$RINSCAL_SHARED`` (the shared folder, or directly its ``data/real``) if set, else
``shared/`` beside the repository. Tests that need the file skip, naming the path, when it is
absent (a fresh clone).
"""

from __future__ import annotations

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
REAL_NAME = "tofupilot_imu_thermal_cycle.tsv"


def real_log_dir() -> Path:
    """``data/real`` of the shared folder: under $RINSCAL_SHARED, or beside the repository."""
    env = os.environ.get("RINSCAL_SHARED")
    if env:
        base = Path(env)
        return base / "data" / "real" if (base / "data").is_dir() else base
    return REPO.parent / "shared" / "data" / "real"


def real_log_path() -> Path:
    """Path of the real MEMS thermal-cycle log (it may not exist)."""
    return real_log_dir() / REAL_NAME

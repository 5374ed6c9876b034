"""Where the tests find the real logs: ``tests/data/real`` of this repository.

Both are kept in git with their licences (see ``tests/data/real/README.md``), so a fresh clone
runs every test on real data.
"""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
REAL_NAME = "tofupilot_imu_thermal_cycle.tsv"


def real_log_dir() -> Path:
    """``tests/data/real`` of the repository: the real logs and their licences."""
    return REPO / "tests" / "data" / "real"


def real_log_path() -> Path:
    """Path of the real MEMS thermal-cycle log (tab-separated, 8,400 rows)."""
    return real_log_dir() / REAL_NAME

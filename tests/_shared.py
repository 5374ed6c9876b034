"""Where the tests find the real logs: ``tests/data/real`` of this repository.

Both are kept in git with their licences (see ``tests/data/real/README.md``), so a fresh clone
runs every test on real data.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pandas as pd

from rinscal.schema import CHANNELS

REPO = Path(__file__).resolve().parents[1]
REAL_NAME = "tofupilot_imu_thermal_cycle.tsv"


def real_log_dir() -> Path:
    """``tests/data/real`` of the repository: the real logs and their licences."""
    return REPO / "tests" / "data" / "real"


def real_log_path() -> Path:
    """Path of the real MEMS thermal-cycle log (tab-separated, 8,400 rows)."""
    return real_log_dir() / REAL_NAME


def linear_log(n: int = 400, runs: int = 2, t0: float = 1.0) -> pd.DataFrame:
    """A small canonical log: outputs linear in T (slope 0.1·k per °C on the k-th channel,
    white noise 0.01), ``runs`` runs warming up from 10 °C + 15 °C per run, 0.1 Hz from ``t0``."""
    rng = np.random.default_rng(0)
    parts = []
    for k in range(runs):
        t = t0 + np.arange(n) * 10.0
        temp = 10.0 + 15.0 * k + 20.0 * (1 - np.exp(-t / 1500.0))
        frame = {"time_s": t, "run": f"r{k}", "temp_in": temp}
        for j, c in enumerate(CHANNELS):
            frame[c] = (j + 1) * 0.1 * (temp - 25.0) + rng.normal(0, 0.01, n)
        parts.append(pd.DataFrame(frame))
    return pd.concat(parts, ignore_index=True)


def docs_script(name: str) -> ModuleType:
    """``docs/scripts/<name>.py`` imported as the module ``name`` (once per session)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, REPO / "docs" / "scripts" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module

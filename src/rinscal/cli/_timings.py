"""The measured timings the README, ``--help`` and the console quote: one file, one reader.

``rinscal/data/timings.json`` is written by ``docs/scripts/timings.py`` (the only place a
timing is measured) and holds under ``commands``, per measured command, its wall time [s],
the peak memory of its largest process [MiB], the 1-minute load average before and after,
the date and the machine (CPU model, cores). Everything that states how long a command
takes reads it here, so the README's generated block, ``rinscal reproduce --help``,
``rinscal study --help`` and the console line at the start of ``rinscal reproduce --quick``
cannot disagree.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

__all__ = [
    "Timing",
    "format_duration",
    "load_timings",
    "timing",
    "timing_phrase",
]

#: The file inside the package.
FILE = "timings.json"


@dataclass(frozen=True)
class Timing:
    """One measured command.

    Parameters
    ----------
    command : str
        The command as run.
    wall_s : float [s]
        Wall time (the median when several runs were made).
    peak_mib : float [MiB]
        Peak resident memory of its largest process (NaN where not measured).
    cores : int
        CPU cores of the machine.
    cpu : str
        CPU model.
    load : tuple of float
        1-minute load average before and after the command.
    measured : str
        UTC date of the measurement (ISO 8601).
    size : str
        What was run, in words (e.g. "2 units, 28 tasks").
    """

    command: str
    wall_s: float
    peak_mib: float
    cores: int
    cpu: str
    load: tuple[float, ...]
    measured: str
    size: str = ""


def format_duration(seconds: float) -> str:
    """A wall time in words: ``"47 s"``, ``"1 min 52 s"``, ``"12 min"`` (from 10 min on)."""
    if not math.isfinite(seconds) or seconds < 0:
        return "n/a"
    s = round(seconds)
    if s < 60:
        return f"{s} s"
    m, r = divmod(s, 60)
    return f"{m} min" if m >= 10 else f"{m} min {r} s"


@cache
def load_timings() -> dict[str, Any]:
    """The package's ``timings.json`` as a dict ({} where the file is missing)."""
    try:
        text = resources.files("rinscal.data").joinpath(FILE).read_text(encoding="utf-8")
    except (FileNotFoundError, OSError):
        return {}
    return dict(json.loads(text))


def timing(name: str, data: Mapping[str, Any] | None = None) -> Timing | None:
    """The measured command ``name`` (``quick_reproduction``, ``quick_study``, ``suite``,
    ``full_reproduction``) of ``data`` (default :func:`load_timings`); None if unmeasured."""
    data = load_timings() if data is None else data
    entry = data.get("commands", {}).get(name)
    if not entry:
        return None
    machine = entry.get("machine", {})
    peak = entry.get("peak_mib")
    return Timing(
        command=str(entry["command"]),
        wall_s=float(entry["wall_s"]),
        peak_mib=float(peak) if peak is not None else math.nan,
        cores=int(machine.get("cores", 0)),
        cpu=str(machine.get("cpu", "unknown CPU")),
        load=tuple(float(x) for x in entry.get("load", ())),
        measured=str(entry.get("measured", "")),
        size=str(entry.get("size", "")),
    )


def timing_phrase(name: str, data: Mapping[str, Any] | None = None, sized: bool = False) -> str:
    """``"1 min 52 s wall on 2 cores"`` (``sized``: after what was run, ``"the quick paper
    study at 2 units: 1 min 30 s wall on 2 cores"``): how the CLI quotes a measured command; ``"wall
    time not measured"`` when the file has no such entry."""
    t = timing(name, data)
    if t is None:
        return "wall time not measured"
    phrase = f"{format_duration(t.wall_s)} wall on {t.cores} cores"
    return f"{t.size}: {phrase}" if sized and t.size else phrase

"""Memory the machine has, and a refusal before an allocation that would not fit.

Used by the commands (the I/O edge) before they start work whose memory grows with an
option (``simulate --rate/--hours``): the user reads the estimate and the option to change,
not a ``MemoryError`` minutes later.
"""

from __future__ import annotations

import os

from rinscal.errors import ConfigError

__all__ = ["available_bytes", "format_bytes", "require_memory"]

#: Share of the available memory a command may plan to use.
HEADROOM = 0.8


def available_bytes() -> int | None:
    """Memory available to a new allocation [bytes]: ``MemAvailable`` (Linux), else None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def format_bytes(n: float) -> str:
    """``n`` bytes as GiB or MiB, e.g. ``"3.2 GiB"``."""
    if n >= 2**30:
        return f"{n / 2**30:.1f} GiB"
    return f"{n / 2**20:.0f} MiB"


def require_memory(need: float, what: str, advice: str, available: int | None = None) -> None:
    """Refuse, with the estimate, work that would need more than :data:`HEADROOM` of memory.

    Parameters
    ----------
    need : float [bytes]
        Estimated peak memory of the work.
    what : str
        The work, e.g. ``"simulate soak at 2000 Hz"``.
    advice : str
        The option(s) to change, e.g. ``"lower --rate or --hours"``.
    available : int, optional [bytes]
        Memory available (default: :func:`available_bytes`; unknown: never refuse).

    Raises
    ------
    ConfigError
        Naming the estimate, the memory available and the advice.
    """
    avail = available_bytes() if available is None else available
    if avail is not None and need > HEADROOM * avail:
        raise ConfigError(
            f"{what} needs about {format_bytes(need)} of memory, more than the "
            f"{format_bytes(avail)} available; {advice}"
        )

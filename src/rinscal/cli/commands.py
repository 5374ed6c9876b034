"""The ``rinscal`` command: every command module registered on one Typer app, in workflow order."""

from __future__ import annotations

import atexit
import ctypes
import gc
import os
import sys
import threading

# Arrow's allocator (mimalloc) keeps freed pages for a while by default; a command that reads
# a log run by run frees a run's buffers before the next, and should give them back at once
# (peak memory of a 400 Hz soak run read: 0.92 GB instead of 1.32 GB). Read when pyarrow
# loads, which no command does before this point.
os.environ.setdefault("MIMALLOC_PURGE_DELAY", "0")

from rinscal.cli import (  # noqa: F401  (registers)
    calibrate,
    compensate,
    fieldcal,
    fleet,
    imucal,
    navigate,
    reproduce,
    simulate,
    study,
)
from rinscal.cli._app import PlainUsageCommand, app, guard_os_errors
from rinscal.cluster import WORKER_HEAP

#: ``rinscal --help``: every command in workflow order, with a summary that reads whole at 80
#: columns (click would cut a docstring's first sentence at "Eq." or after 45 characters):
#: 59 characters at most, beside the longest command name (calibrate-field).
SUMMARIES: dict[str, str] = {
    "simulate": "Simulate a chamber protocol or parked starts; log and truth.",
    "calibrate-imu": "Scale factor, misalignment, bias over temperature (table).",
    "fit": "Fit a thermal model per channel; write a JSON model file.",
    "calibrate-field": "A thermal model from parked cold starts: no chamber needed.",
    "select": "Held-out RMS of every candidate per channel (Tables 5, 7).",
    "evaluate": "RMS before/after a model (Eq. 16), steps, Allan deviation.",
    "compensate": "Subtract the modelled thermal bias from every row (Eq. 10).",
    "export": "Write a model for PX4, ArduPilot or as a C header.",
    "plot": "Draw outputs and temperatures per run over time (Figure 3).",
    "navigate": "Navigate a RINS from a cold start; position error in nmi.",
    "reproduce": "Re-run the paper's Section 5 on a simulated IMU: a report.",
    "study": "Monte Carlo study over many units and cold starts, on Dask.",
    "fleet": "Calibrate a fleet of IMUs, one log per unit, on Dask.",
    "fleet fit": "Fit each unit's log as a Dask task; check limits; resumable.",
}

for _info in [  # one place turns OS errors into a message
    *app.registered_commands,
    *(c for g in app.registered_groups for c in g.typer_instance.registered_commands),
]:
    _info.callback = guard_os_errors(_info.callback)
    _info.cls = PlainUsageCommand
for _info in [*app.registered_commands, *app.registered_groups]:
    _info.short_help = SUMMARIES[_info.name]
for _group in app.registered_groups:
    for _info in _group.typer_instance.registered_commands:
        _info.short_help = SUMMARIES[f"{_group.name} {_info.name}"]
_ORDER = list(SUMMARIES)
app.registered_commands.sort(key=lambda c: _ORDER.index(c.name))
app.registered_groups.sort(key=lambda g: _ORDER.index(g.name))


def main() -> None:
    """Entry point of the ``rinscal`` console script.

    Once the command has finished, the process ends without the interpreter's teardown,
    which frees every loaded module's objects one by one (numpy, pandas, pyarrow, numba,
    matplotlib: 0.3-0.4 s of one core after a navigation, for nothing): the output streams
    are flushed and the exit handlers run (:mod:`atexit`), then :func:`os._exit` with the
    command's status. Python's own exit where a thread other than a daemon is still alive,
    the status is a message, or the streams cannot be flushed.
    """
    _reuse_heap()
    try:
        app()
    except SystemExit as exc:
        _leave(exc.code)
        # Python's own exit after all: frozen, the collector's last full pass does not walk
        # every loaded module's objects (0.2 s of a 4 s compensate)
        gc.freeze()
        raise


def _reuse_heap() -> None:
    """glibc's heap settings of a local cluster's workers for this process too
    (:data:`rinscal.cluster.WORKER_HEAP`: an allocation below 32 MiB comes from a heap and is
    reused, a heap gives memory back beyond 64 MiB free at its top), set through ``mallopt``,
    which takes them at any time (the environment variables only at the start). With glibc's
    own, which follow the largest block freed so far, a thread's heap gave its large arrays'
    pages back and faulted them in anew: ``navigate --log`` on two threads spent 0.4-0.5 s
    more in the kernel than on one (the second pass of the 8 h run: 0.5-0.8 s against
    0.2-0.3 s, 110-130 thousand page faults against 50-60). Nothing but with glibc."""
    try:
        if not (os.confstr("CS_GNU_LIBC_VERSION") or "").startswith("glibc"):
            return
        mallopt = ctypes.CDLL(None).mallopt
    except (ValueError, OSError, AttributeError):  # no such name, no C library, no mallopt
        return
    mallopt(_M_MMAP_THRESHOLD, int(WORKER_HEAP["MALLOC_MMAP_THRESHOLD_"]))
    mallopt(_M_TRIM_THRESHOLD, int(WORKER_HEAP["MALLOC_TRIM_THRESHOLD_"]))


#: glibc's ``mallopt`` parameters (malloc.h).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def _leave(code: object) -> None:
    """End the process now with ``code`` (None: 0), as :func:`main` says; return where
    Python's own exit must do it."""
    if code is not None and not isinstance(code, int):
        return  # a message: Python's exit prints it
    main_thread = threading.main_thread()
    if any(t is not main_thread and not t.daemon and t.is_alive() for t in threading.enumerate()):
        return
    try:
        sys.stdout.flush()
        sys.stderr.flush()
        atexit._run_exitfuncs()
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:  # e.g. a closed pipe: Python's exit reports it as it always has
        return
    os._exit(code or 0)


__all__ = ["SUMMARIES", "app", "main"]

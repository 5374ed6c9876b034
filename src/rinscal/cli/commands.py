"""The ``rinscal`` command: every command module registered on one Typer app, in workflow order."""

from __future__ import annotations

import gc
import os

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
    """Entry point of the ``rinscal`` console script."""
    try:
        app()
    finally:
        # The process ends here. Its objects (numpy, pandas, numba and their modules) go
        # with it: frozen, the collector's last full pass at exit does not walk them all
        # (0.2 s of a 4 s compensate). Files are closed by the commands themselves.
        gc.freeze()


__all__ = ["SUMMARIES", "app", "main"]

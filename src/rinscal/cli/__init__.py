"""Command-line interface: thin commands over plain functions that return data.

Each command module registers its commands on :data:`rinscal.cli._app.app`; library
functions raise :class:`rinscal.errors.RinscalError` subclasses, which only this layer turns
into a message and an exit code.
"""

from __future__ import annotations

import os

# Arrow's allocator (mimalloc) keeps freed pages for a while by default; a command that reads
# a log run by run frees a run's buffers before the next, and should give them back at once
# (peak memory of a 400 Hz soak run read: 0.92 GB instead of 1.32 GB). Read when pyarrow
# loads, which no command does before this point.
os.environ.setdefault("MIMALLOC_PURGE_DELAY", "0")

from rinscal.cli import (  # noqa: F401  (registers)
    calibrate,
    fleet,
    navigate,
    reproduce,
    simulate,
    study,
)
from rinscal.cli._app import app, guard_os_errors

for _info in [  # one place turns OS errors into a message
    *app.registered_commands,
    *(c for g in app.registered_groups for c in g.typer_instance.registered_commands),
]:
    _info.callback = guard_os_errors(_info.callback)


def main() -> None:
    """Entry point of the ``rinscal`` console script."""
    app()


__all__ = ["app", "main"]

"""Command-line interface: thin commands over plain functions that return data.

Each command module (:mod:`~rinscal.cli.calibrate`, :mod:`~rinscal.cli.simulate`,
:mod:`~rinscal.cli.navigate`, :mod:`~rinscal.cli.reproduce`, :mod:`~rinscal.cli.study`,
:mod:`~rinscal.cli.fleet`) parses options, calls one library function that returns data,
prints and writes; it registers its commands on :data:`rinscal.cli._app.app`.
:mod:`~rinscal.cli.commands` gathers them (``rinscal = "rinscal.cli:main"``). Library functions
raise :class:`rinscal.errors.RinscalError` subclasses, which only this layer turns into a
message and an exit code. Nothing here is a Python API: use the names of :mod:`rinscal`.
"""

from __future__ import annotations

from typing import Any

__all__ = ["SUMMARIES", "app", "main"]


def __getattr__(name: str) -> Any:
    """``app``, ``main`` and ``SUMMARIES``, from :mod:`rinscal.cli.commands` on first use (PEP 562).

    Lazy, so that importing one command module does not register every other first.
    """
    if name in __all__:
        # deferred: a lazy re-export (PEP 562), run on first attribute access only
        from rinscal.cli import commands

        return getattr(commands, name)
    raise AttributeError(f"module 'rinscal.cli' has no attribute {name!r}")

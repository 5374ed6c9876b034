"""CLI commands: reproduce."""

from __future__ import annotations

from rinscal.cli._app import app  # noqa: F401

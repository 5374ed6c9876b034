"""The Typer application shared by every command module, and the error boundary."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import typer
from rich.console import Console
from rich.text import Text

app = typer.Typer(
    name="rinscal",
    help="Thermal calibration of IMUs and its proof in a single-axis rotational INS.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help text is plain: units in brackets ([h], [s]) are kept
)

#: Messages and tables go to stdout; errors and warnings to stderr. No markup: text in
#: brackets (units such as [s], TOML sections such as [study]) is printed as it is; styles
#: are given with :func:`styled`.
console = Console(markup=False)
err_console = Console(stderr=True, markup=False)


def styled(label: str, style: str, rest: str = "") -> Text:
    """``label`` in ``style`` (e.g. "bold red"), then ``rest`` as plain text."""
    return Text.assemble((label, style), rest)


def fail(message: str, code: int = 2) -> typer.Exit:
    """Print ``message`` as an error and return the exit to raise.

    Parameters
    ----------
    message : str
        What went wrong, naming the file, column or parameter.
    code : int
        Process exit code.
    """
    err_console.print(styled("error:", "bold red", f" {message}"), highlight=False, soft_wrap=True)
    return typer.Exit(code)


def guard_os_errors(command: Callable[..., Any] | None) -> Callable[..., Any] | None:
    """Wrap a command: an operating-system error becomes one line naming the path, exit 2.

    Permission denied, a missing folder, a full disk: wherever a command meets one (an output
    folder it creates, a figure it saves), the user reads the path and what to do, not a
    traceback.
    """
    if command is None:
        return None

    @functools.wraps(command)
    def run(*args: Any, **kwargs: Any) -> Any:
        from rinscal.errors import describe_os_error

        try:
            return command(*args, **kwargs)
        except OSError as exc:
            if exc.filename is None:  # not about a path: a bug or the system, not the input
                raise
            raise fail(describe_os_error(exc).replace("cannot write", "cannot use")) from None

    return run


def _version(value: bool) -> None:
    if value:
        from rinscal import __version__

        console.print(f"rinscal {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """Thermal calibration of IMUs and its proof in a single-axis rotational INS."""

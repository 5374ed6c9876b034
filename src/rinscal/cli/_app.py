"""The Typer application shared by every command module, and the error boundary."""

from __future__ import annotations

import functools
import re
import warnings
from collections.abc import Callable
from typing import Any

import typer
import typer.core
from rich.console import Console
from rich.text import Text

from rinscal.errors import LogNoteWarning

#: Old option names still accepted, with a one-line deprecation note: old -> new.
OLD_OPTIONS: dict[str, str] = {"--mapping": "--map"}


def renamed_options(args: list[str]) -> list[str]:
    """``args`` with each old option name (:data:`OLD_OPTIONS`) replaced by its new one, and a
    ``note:`` line on stderr for each old name used (arguments after ``--`` are left)."""
    out: list[str] = []
    for k, arg in enumerate(args):
        if arg == "--":
            return out + args[k:]
        name, eq, value = arg.partition("=")
        if name in OLD_OPTIONS:
            new = OLD_OPTIONS[name]
            err_console.print(
                styled("note:", "cyan", f" {name} is deprecated: use {new} (the same file)"),
                highlight=False,
                soft_wrap=True,
            )
            arg = new + eq + value
        out.append(arg)
    return out


class RenamingGroup(typer.core.TyperGroup):
    """The root command group: old option names (:data:`OLD_OPTIONS`) read as the new."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        """Click's parsing of ``args`` after :func:`renamed_options`."""
        return super().parse_args(ctx, renamed_options(args))


app = typer.Typer(
    name="rinscal",
    cls=RenamingGroup,
    help="Thermal calibration of IMUs and its proof in a single-axis rotational INS.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help text is plain: units in brackets ([h], [s]) are kept
)


class PlainUsageCommand(typer.core.TyperCommand):
    """A command whose usage line names its arguments as click does (``LOG``, ``LOGS...``).

    Typer writes a required argument as ``{log}``, which reads as a set of choices.
    """

    def collect_usage_pieces(self, ctx: Any) -> list[str]:
        """``[OPTIONS]``, then each argument: its metavar or its name in capitals."""
        pieces = [self.options_metavar] if self.options_metavar else []
        for param in self.get_params(ctx):
            if param.param_type_name != "argument":
                pieces.extend(param.get_usage_pieces(ctx))
                continue
            name = param.metavar or (param.name or "").upper()
            name += "..." if param.nargs != 1 else ""
            pieces.append(name if param.required else f"[{name}]")
        return pieces


#: Messages and tables go to stdout; errors and warnings to stderr. No markup: text in
#: brackets (units such as [s], TOML sections such as [study]) is printed as it is; styles
#: are given with :func:`styled`.
console = Console(markup=False)
err_console = Console(stderr=True, markup=False)


def styled(label: str, style: str, rest: str = "") -> Text:
    """``label`` in ``style`` (e.g. "bold red"), then ``rest`` as plain text."""
    return Text.assemble((label, style), rest)


#: A library argument -> the flag that gives it: library errors name the argument
#: (``site='x': ...``), the command line its flag (``--site 'x': ...``), see :func:`flag_text`.
ARG_FLAGS: dict[str, str] = {
    "map_file": "--map",
    "col": "--col",
    "columns": "--col",
    "time_col": "--time-col",
    "time_unit": "--time-unit",
    "sep": "--sep",
    "temp_col": "--temp-col",
    "drop": "--drop",
    "run_name": "--run-name",
    "relative_time": "--relative-time",
    "instance": "--instance",
    "site": "--site",
    "policy": "--policy",
    "heading_deg": "--heading",
    "track": "--track",
    "track_utc_start": "--track-utc-start",
    "aiding": "--aiding",
    "gnss_sd_m": "--gnss-sd",
    "run": "--run",
    "allow_gaps": "--allow-gaps",
    "align_s": "--align-s",
    "align_start_s": "--align-start-s",
    "mapping": "--map",
    "settle_s": "--settle",
    "max_degree": "--max-degree",
    "temp_range": "--temp-range",
    "ignore_units": "--ignore-units",
    "scheduler": "--scheduler",
    "rates_dps": "--rates",
    "orders": "--orders",
    "method": "--method",
    "tls": "--tls-ca-file, --tls-cert and --tls-key",
}
_ARG_RE = re.compile(r"(?<![\w.\-])(" + "|".join(ARG_FLAGS) + r")=(True\b)?(\S?)")


def flag_text(message: str) -> str:
    """A library message as the command line says it: each ``name=`` of :data:`ARG_FLAGS`
    becomes its flag (``site='x'`` -> ``--site 'x'``, ``instance=,`` -> ``--instance,``,
    ``allow_gaps=True`` -> ``--allow-gaps``)."""

    def flag(m: re.Match[str]) -> str:
        if m.group(2):  # a switch turned on
            return ARG_FLAGS[m.group(1)] + m.group(3)
        nxt = m.group(3)
        gap = " " if nxt and nxt not in ",;:)" else ""
        return ARG_FLAGS[m.group(1)] + gap + nxt

    return _ARG_RE.sub(flag, message)


def fail(message: str, code: int = 2) -> typer.Exit:
    """Print ``message`` as an error and return the exit to raise.

    Library messages name arguments (``site=``); they are printed with the flags instead
    (:func:`flag_text`), so every command's errors pass through here.

    Parameters
    ----------
    message : str
        What went wrong, naming the file, column or parameter.
    code : int
        Process exit code.
    """
    text = flag_text(message)
    err_console.print(styled("error:", "bold red", f" {text}"), highlight=False, soft_wrap=True)
    return typer.Exit(code)


#: The folders the running command created for its outputs (:func:`rinscal.cli._options.
#: prepare_outputs`); removed again, when empty, if the command fails.
created_folders: list[Any] = []


def guard_os_errors(command: Callable[..., Any] | None) -> Callable[..., Any] | None:
    """Wrap a command: an operating-system error becomes one line naming the path, exit 2.

    Permission denied, a missing folder, a full disk: wherever a command meets one (an output
    folder it creates, a figure it saves), the user reads the path and what to do, not a
    traceback. A command that fails removes the output folders it created, if they are empty.
    """
    if command is None:
        return None

    @functools.wraps(command)
    def run(*args: Any, **kwargs: Any) -> Any:
        # deferred: loaded when the command runs, so that `rinscal --help` starts fast
        import warnings

        from rinscal.errors import OutputError, describe_os_error
        from rinscal.io.atomic import remove_empty_folders

        recorded: list[warnings.WarningMessage] = []
        created_folders.clear()
        ok = False
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", LogNoteWarning)
                try:
                    value = command(*args, **kwargs)
                    ok = True
                    return value
                except typer.Exit as exc:
                    ok = exc.exit_code == 0
                    raise
                finally:
                    recorded = list(caught)
        except OSError as exc:
            if isinstance(exc, OutputError):  # a write that failed late (disk full): its message
                raise fail(str(exc)) from None
            if exc.filename is None:  # not about a path: a bug or the system, not the input
                raise
            raise fail(describe_os_error(exc).replace("cannot write", "cannot use")) from None
        finally:  # once the command's filters are gone, so that Python shows the others
            if not ok:
                remove_empty_folders(created_folders)
            created_folders.clear()
            report_warnings(recorded)

    return run


def streaming_process() -> None:
    """Let this command's process take Arrow's memory from jemalloc, where pyarrow has it.

    For a command that streams a large log run by run (``compensate``): Arrow's default
    allocator (mimalloc, told by :mod:`rinscal.cli.commands` to give freed pages back at
    once) has each run's new buffers faulted in again as transparent huge pages, each zeroed
    whole by the system; with jemalloc about half of that zeroing goes (on a 7.6 M-row log,
    about a second of system time: a quarter of the command's CPU was page zeroing; peak
    memory about 0.1 GB more). Process-wide, so for a command's own process only; nothing read
    or written depends on it.

    jemalloc is also told to keep the pages freed (no decay), before it makes its arenas: a
    run's buffers then reuse the previous run's pages instead of having new ones faulted in
    and zeroed (on the 7.6 M-row log, 0.29-0.31 instead of 0.40-0.42 million page faults,
    system time 1.1-1.3 s against 1.2-1.8 s; peak memory 1.36-1.44 GB against 1.24-1.30 GB:
    3 runs each, load 4.5-6). The pages kept are reused, so memory stays bounded by what the
    command holds at once.
    """
    # deferred: pyarrow is heavy and only a command that reads a log needs it
    import pyarrow as pa

    try:
        pa.jemalloc_set_decay_ms(-1)  # -1: never give freed pages back (read at arena creation)
        pa.set_memory_pool(pa.jemalloc_memory_pool())
    except NotImplementedError:  # a pyarrow built without jemalloc: its default allocator
        pass


def report_warnings(recorded: list[Any]) -> None:
    """What a reader did to the log (:class:`LogNoteWarning`), once each, as a ``note:``
    line; any other warning as Python shows it (call outside ``catch_warnings(record=True)``,
    where showing a warning would record it again)."""

    seen: set[str] = set()
    for w in recorded:
        if not issubclass(w.category, LogNoteWarning):
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        elif str(w.message) not in seen:
            seen.add(str(w.message))
            err_console.print(styled("note:", "cyan", f" {w.message}"), highlight=False)


def _widths(cols: list[Any], total: int) -> tuple[list[int], list[int]]:
    """Fixed widths for columns (see :func:`_print_table`), and each column's least width."""
    floor, size = [], []
    for col in cols:
        cells = [str(c) for c in col._cells]
        head = str(col.header)
        words = [len(w) for t in [*cells, head] for w in t.split()] or [1]
        if col.justify == "right":  # never below its widest number; the header wraps
            floor.append(max([len(c) for c in cells] or [1]))
            size.append(max(floor[-1], max(len(w) for w in head.split()) if head.split() else 1))
        else:  # text wraps at spaces, never inside a word
            floor.append(max(words))
            size.append(max([len(c) for c in cells] + [len(head), 1]))
    gaps = 3 * (len(cols) - 1)  # padding (1 + 1) and the blank rule between columns
    while sum(size) + gaps > total:
        # text first (it wraps at spaces), a number's header only when no text can give way
        text = [k for k, c in enumerate(cols) if c.justify != "right" and size[k] > floor[k]]
        shrinkable = text or [k for k in range(len(cols)) if size[k] > floor[k]]
        if not shrinkable:
            break
        k = max(shrinkable, key=lambda v: size[v])
        size[k] -= 1
    return size, floor


def print_table(console: Console, table: Any) -> None:
    """Print a table that fits the terminal's width and cuts no number.

    Columns get fixed widths (:func:`_widths`): a number column its widest cell, its header
    wrapped; text wrapped at spaces. If even that is too wide, the number columns are split
    over several tables, each repeating the leading text columns (run, channel, ...). Rich
    would otherwise end a cut cell with "…", numbers included.
    """
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich import box
    from rich.table import Table

    total = console.width
    cols = list(table.columns)
    n_id = next((k for k, c in enumerate(cols) if c.justify == "right"), len(cols))
    ids, rest = cols[:n_id], cols[n_id:]
    _, floor = _widths(cols, total)
    chunks: list[list[Any]] = [[]]
    used = sum(floor[:n_id]) + 3 * max(n_id - 1, 0)
    for k, col in enumerate(rest):
        head = max((len(w) for w in str(col.header).split()), default=1)
        need = max(floor[n_id + k], head) + 3  # a number and its header's longest word
        if chunks[-1] and used + need > total:
            chunks.append([])
            used = sum(floor[:n_id]) + 3 * max(n_id - 1, 0)
        chunks[-1].append(col)
        used += need
    for i, chunk in enumerate(chunks):
        part = Table(
            title=table.title if i == 0 else None,
            box=box.SIMPLE_HEAD,
            pad_edge=False,
            show_edge=False,
        )
        for col in [*ids, *chunk]:
            part.add_column(col.header, justify=col.justify)
        n_rows = len(cols[0]._cells) if cols else 0
        for r in range(n_rows):
            part.add_row(*[str(col._cells[r]) for col in [*ids, *chunk]])
        size, _ = _widths(list(part.columns), total)
        for col, w in zip(part.columns, size, strict=True):
            col.width, col.overflow = w, "fold"
        console.print(part)


def _version(value: bool) -> None:
    if value:
        # deferred: loaded when the command runs, so that `rinscal --help` starts fast
        from rinscal._version import __version__

        console.print(f"rinscal {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """Thermal calibration of IMUs and its proof in a single-axis rotational INS."""

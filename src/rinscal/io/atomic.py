"""Atomic writing: a file appears whole under its final name, or not at all.

A writer writes a temporary file in the destination's folder, which is then moved onto the
final name with :func:`os.replace`, so a crash never leaves a half-written file behind.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from rinscal.errors import OutputError, describe_os_error

__all__ = [
    "OUTPUT_RULE",
    "atomic_path",
    "check_output",
    "make_folders",
    "missing_folder_error",
    "remove_empty_folders",
    "write_atomic",
]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` if the block succeeds.

    The temporary file keeps the suffix of ``path`` (writers that pick the format from it
    work) and is removed if the block raises. An operating-system error (permission, missing
    folder, full disk) becomes :class:`rinscal.errors.OutputError` naming ``path``.
    """
    p = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=f".tmp{p.suffix}", dir=p.parent)
    except OSError as exc:
        raise OutputError(describe_os_error(exc, p)) from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes the file private (0600); give it the permissions of a normal file
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp_path, 0o666 & ~umask)
        os.replace(tmp_path, p)
    except OutputError:
        raise
    except OSError as exc:  # disk full while writing, a folder in the way of the name...
        raise OutputError(describe_os_error(exc, p)) from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()


def write_atomic(path: str | os.PathLike[str], writer: Callable[[Path], None]) -> None:
    """Call ``writer(tmp_path)`` and move the result onto ``path`` atomically."""
    with atomic_path(path) as tmp:
        writer(tmp)


#: The one rule for outputs, in the words the README and the docs use.
OUTPUT_RULE = (
    "a file is written into a folder that exists (no folder is created to hold it, so a "
    "mistyped folder is refused, naming it); a folder a command writes into (--out DIR) is "
    "created with its missing parents"
)


def check_output(
    path: str | os.PathLike[str], *, what: str = "--out", folder: bool = False
) -> list[Path]:
    """Check, creating nothing, that ``path`` can be written; return the folders to create.

    The rule every command follows (:data:`OUTPUT_RULE`): a file is written into a folder
    that exists, and no folder is created to hold it (a mistyped folder is refused, naming it);
    a folder the command writes into (``--out DIR``) is created, with its missing parents (by
    :func:`make_folders`, once every output of the command has been checked). An output whose
    path goes through a file, or whose folder cannot be written, is refused before any work.

    Parameters
    ----------
    path : path-like
        The output: a file, or a folder when ``folder`` is true.
    what : str
        The option or argument that gave it, for the message (e.g. ``"--out"``).
    folder : bool
        ``path`` is a folder the command writes into (else a file).

    Returns
    -------
    list of Path
        The missing folders, outermost first (empty when the folder exists); for a file,
        those of its folder, which the caller refuses (:func:`missing_folder_error`) unless
        one of the command's folder outputs creates them.

    Raises
    ------
    rinscal.errors.OutputError
        Naming ``what`` and the path: a file in the way of a folder, a folder in the way of
        the file, or a folder that cannot be written (permissions, read-only file system).
    """
    p = Path(path)
    label = f"{what} {p}" if what else str(p)
    if folder and p.exists() and not p.is_dir():
        raise OutputError(f"{label}: exists and is not a folder; {what} takes a folder")
    if not folder and p.is_dir():
        raise OutputError(f"{p}: a folder is in the way; {what} takes a file name")
    target = Path(os.path.abspath(p if folder else p.parent))
    missing: list[Path] = []
    existing = target
    while not existing.exists():
        if existing.is_symlink():  # a dangling link: mkdir would fail on it
            raise OutputError(f"{label}: {existing} is a broken link; choose another location")
        missing.append(existing)
        existing = existing.parent
    if not existing.is_dir():
        raise OutputError(f"{label}: {existing} is a file, not a folder; choose another location")
    try:  # the one reliable test (root, read-only mounts, /proc): write a file there
        fd, tmp = tempfile.mkstemp(prefix=".rinscal-check.", dir=existing)
    except OSError as exc:
        if exc.errno == errno.ENOENT:  # the folder is there but takes no files (/proc, /sys)
            raise OutputError(
                f"{label}: cannot write: the folder {existing} does not take new files; "
                "choose another location"
            ) from None
        raise OutputError(describe_os_error(exc, label)) from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(tmp)
    return missing[::-1]


def make_folders(folders: list[Path]) -> list[Path]:
    """Create ``folders`` (outermost first, as :func:`check_output` returns them).

    Returns the folders created; an operating-system error becomes
    :class:`rinscal.errors.OutputError` naming the folder (the ones already created are
    removed again).
    """
    created: list[Path] = []
    for f in folders:
        try:
            f.mkdir()
        except FileExistsError:
            if not f.is_dir():
                remove_empty_folders(created)
                msg = f"{f}: cannot write: a file is in the way of the folder"
                raise OutputError(msg) from None
            continue
        except OSError as exc:
            remove_empty_folders(created)
            raise OutputError(describe_os_error(exc, f)) from None
        created.append(f)
    return created


def missing_folder_error(
    path: str | os.PathLike[str], missing: list[Path], *, what: str = "--out"
) -> OutputError:
    """The refusal of a file whose folder does not exist (``missing``: outermost first)."""
    p = Path(path)
    label = f"{what} {p}" if what else str(p)
    return OutputError(
        f"{label}: the folder {missing[0]} does not exist; a file is written into a folder "
        f"that exists (no folder is created to hold it): create it first (mkdir -p "
        f"{missing[-1]}) or choose another location"
    )


def remove_empty_folders(folders: list[Path]) -> None:
    """Remove those of ``folders`` that are empty, innermost first (a failed command's)."""
    for f in sorted(folders, key=lambda q: len(q.parts), reverse=True):
        with contextlib.suppress(OSError):
            f.rmdir()

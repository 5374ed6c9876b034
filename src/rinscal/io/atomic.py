"""Atomic writing: a file appears whole under its final name, or not at all.

A writer writes a temporary file in the destination's folder, which is then moved onto the
final name with :func:`os.replace`, so a crash never leaves a half-written file behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from rinscal.errors import OutputError, describe_os_error

__all__ = [
    "atomic_path",
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

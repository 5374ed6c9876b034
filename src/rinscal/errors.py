"""Exceptions raised by rinscal's library functions; the CLI turns them into messages."""

from __future__ import annotations

import errno


class RinscalError(Exception):
    """Base class of every error rinscal raises on bad input or configuration."""


class LogError(RinscalError, ValueError):
    """A calibration log is malformed: the message names the file, column and first row."""


class LogNoteWarning(UserWarning):
    """Something a reader did to a log that the user should know (truncation, samples left out)."""


class ConfigError(RinscalError, ValueError):
    """A configuration (TOML file or parameter) is invalid: the message names the key."""


class ArgumentTypeError(ConfigError, TypeError):
    """An argument of a library function has the wrong type (a string where a number is
    asked, a number where a path is asked): the message names the argument, what was given
    and what is accepted. Both a :class:`TypeError` and a :class:`ConfigError`."""


class ModelFileError(RinscalError, ValueError):
    """A model file is truncated, tampered with, or of an unknown schema version."""


class RangeError(RinscalError, ValueError):
    """An input lies outside the range a model was trained on and the policy is ``error``."""


class DesignError(RinscalError, ValueError):
    """A calibration design cannot give what is asked of it: a parameter the positions and
    rates do not observe, a position that was not static, a missing temperature point, mixed
    units. The message names the run, segment, parameter or column, and what is lacking."""


class OutputError(RinscalError, OSError):
    """An output file or folder cannot be written: the message names the path and the cause."""


def describe_os_error(exc: OSError, path: object = None) -> str:
    """A one-line message for an operating-system error, naming the path and what to do.

    Parameters
    ----------
    exc : OSError
        The error (permission denied, no such folder, disk full, ...).
    path : path-like, optional
        The path the user gave (default: the one the error names).

    Returns
    -------
    str
    """
    where = str(path if path is not None else (exc.filename or "output"))
    why = exc.strerror or str(exc)
    hint = {
        errno.EACCES: "choose another location or change the folder's permissions",
        errno.EPERM: "choose another location or change the folder's permissions",
        errno.EROFS: "the file system is read-only; choose another location",
        errno.ENOENT: "the folder does not exist; create it or choose another",
        errno.ENOSPC: "the disk is full; free space or choose another location",
        errno.EDQUOT: "the disk quota is exceeded; free space or choose another location",
        errno.EISDIR: "that is a folder; give a file name",
        errno.ENOTDIR: "a part of the path is a file, not a folder",
    }.get(exc.errno or 0)
    return f"{where}: cannot write: {why}" + (f"; {hint}" if hint else "")

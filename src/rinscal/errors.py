"""Exceptions raised by rinscal's library functions; the CLI turns them into messages."""

from __future__ import annotations


class RinscalError(Exception):
    """Base class of every error rinscal raises on bad input or configuration."""


class LogError(RinscalError, ValueError):
    """A calibration log is malformed: the message names the file, column and first row."""


class ConfigError(RinscalError, ValueError):
    """A configuration (TOML file or parameter) is invalid: the message names the key."""


class ModelFileError(RinscalError, ValueError):
    """A model file is truncated, tampered with, or of an unknown schema version."""


class RangeError(RinscalError, ValueError):
    """An input lies outside the range a model was trained on and the policy is ``error``."""

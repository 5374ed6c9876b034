"""The argument checks every public function shares (``rinscal._check``), the thermal
configuration's two number checks (``rinscal.sim._checks``) and the version string."""

from __future__ import annotations

import importlib.metadata

import numpy as np
import pytest

import rinscal
from rinscal import _check
from rinscal._version import __version__
from rinscal.errors import ConfigError
from rinscal.sim._checks import _finite, _nonneg


def test_number_accepts_reals_and_names_what_it_refuses() -> None:
    assert _check.number("hours", np.float32(1.5)) == 1.5
    assert _check.number("n", 4.0, integer=True) == 4 and isinstance(
        _check.number("n", 4.0, integer=True), int
    )
    with pytest.raises(TypeError, match=r"hours: expected a number .*give 1\.5 without quotes"):
        _check.number("hours", " 1.5")
    with pytest.raises(TypeError, match="hours"):
        _check.number("hours", True)  # a bool is not a number here
    with pytest.raises(ConfigError, match=r"rate_hz must be > 0 Hz, got 0"):
        _check.number("rate_hz", 0, above=0, unit="Hz")
    with pytest.raises(ConfigError, match="finite"):
        _check.number("hours", float("inf"))
    assert _check.number("seed", None, optional=True) is None


def test_numbers_of_checks_each_item_naming_its_index() -> None:
    assert _check.numbers_of("set_points", [10, 20.5]) == (10.0, 20.5)
    with pytest.raises(ConfigError, match=r"set_points\[1\] must be >= 0"):
        _check.numbers_of("set_points", (1.0, -2.0), min=0)
    with pytest.raises(ConfigError, match="must hold 3 numbers, got 2"):
        _check.numbers_of("lever_m", [0.0, 1.0], length=3)


def test_thermal_number_checks_return_floats_and_refuse_text() -> None:
    assert _finite("tau_s", 30) == 30.0 and isinstance(_finite("tau_s", 30), float)
    assert _nonneg("sd", 0) == 0.0
    with pytest.raises(ConfigError, match="sd must be >= 0"):
        _nonneg("sd", -1e-9)
    with pytest.raises(TypeError, match="tau_s"):
        _finite("tau_s", "30")


def test_the_version_is_the_installed_distributions() -> None:
    assert rinscal.__version__ == __version__ == importlib.metadata.version("rinscal")

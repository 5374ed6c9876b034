"""The old package name :mod:`rinscal.thermal` still imports for one release, warns, and
gives the very modules that now live in :mod:`rinscal.sim` (and :mod:`rinscal.presets`)."""

from __future__ import annotations

import importlib
import sys
import warnings

import pytest

import rinscal.presets
import rinscal.sim.config
import rinscal.sim.protocols

with warnings.catch_warnings():  # the old name, imported as a user's old notebook would
    warnings.simplefilter("ignore", DeprecationWarning)
    import rinscal.thermal


def test_the_old_names_warn_and_are_the_new_modules() -> None:
    for name in [
        m for m in sys.modules if m == "rinscal.thermal" or m.startswith("rinscal.thermal.")
    ]:
        del sys.modules[name]
    with pytest.deprecated_call(match="rinscal.thermal is deprecated: import rinscal.sim"):
        old = importlib.import_module("rinscal.thermal.config")
    assert old is rinscal.sim.config
    assert old.load_imu("paper") == rinscal.sim.config.load_imu("paper")
    assert importlib.import_module("rinscal.thermal.protocols") is rinscal.sim.protocols
    assert importlib.import_module("rinscal.thermal.presets") is rinscal.presets


def test_the_old_package_maps_onto_the_new_one() -> None:
    assert rinscal.thermal.field is importlib.import_module("rinscal.sim.field")
    assert sys.modules["rinscal.thermal.plant"] is importlib.import_module("rinscal.sim.plant")

"""rinscal: thermal calibration of IMUs, proven in a single-axis rotational INS.

Implements, and goes beyond, Wang, Cheng, Du, "Thermal Modeling and Calibration Method in
Complex Temperature Field for Single-Axis Rotational Inertial Navigation System", Sensors
20(2), 2020.

Conventions (the contract every module keeps)
---------------------------------------------
Units
    SI inside the code: rad, rad/s, m/s², m, s. Temperatures in °C; temperature rates in
    °C/min where they are model features (as in the paper), °C/s inside ODEs. Degrees,
    deg/h, µg and nautical miles appear only at the edges (files, CLI, plots) and are
    converted by the named constants in :mod:`rinscal.units`.
Frames (after Groves)
    ``i`` inertial, ``e`` Earth-fixed, ``n`` navigation (East-North-Up, as in the paper),
    ``b`` body/carrier, ``r`` the rotating IMU frame on the turntable (coincides with ``b``
    when the encoder angle is zero; the turntable axis is body z). A vector ``v`` resolved
    in frame ``a`` is written ``v_a``; the rotation matrix taking frame ``b`` to ``a`` is
    ``C_ab`` (so ``v_a = C_ab @ v_b``). Body axes: x right, y forward, z up. Sensor errors,
    thermal ones included, live in ``r`` and are applied before any rotation.
Calibration log (see :mod:`rinscal.schema`)
    One table, one row per sample, several runs stacked: ``time_s`` (seconds since this
    run's power-on, strictly increasing within a run), ``run`` (name of one continuous
    recording), the six sensor channels ``gyro_x gyro_y gyro_z accel_x accel_y accel_z``
    (any consistent unit; simulated logs write deg/h and µg, or pulses), inner temperatures
    ``temp_<channel>`` or one shared ``temp_in`` [°C], optional ``temp_out`` (package
    surface) [°C] and ``chamber_temp`` [°C].
Naming
    Standard deviations end in ``_sd``; fitted attributes end in ``_`` (scikit-learn style).
Randomness
    Only through a seeded :class:`numpy.random.Generator` passed in; configs are frozen
    dataclasses; nothing random or mutable at import time.

Python API
----------
The names below are the supported API; everything else is private unless it is in the
``__all__`` of its own module (and the ``_``-prefixed modules and names never are). They are
imported on first use (PEP 562), so ``import rinscal`` stays as light as the CLI's start-up.

Data
    :func:`read_log` (a calibration log file → validated table), :func:`write_log` and
    :func:`write_meta` (a table and its ``.meta.json`` sidecar, atomically),
    :func:`simulate` (a chamber protocol → log, truth, metadata),
    :func:`simulate_multiposition` (the IMU on a two-axis turntable in the chamber → log,
    truth parameter table, metadata), :func:`load_imu` (an IMU preset or TOML file).
Calibration
    :func:`fit` (→ :class:`FitResult`: the model and its report), :class:`ThermalFitter`
    (the fitter itself, scikit-learn style), :func:`calibrate_imu` (a multi-position
    turntable log → scale factors, misalignments and biases over temperature,
    :class:`ImuCalibrationResult`; its laws an :class:`ImuCalibration`, whose ``correct``
    applies the inverse model),
    :func:`load_model` (a JSON model file → :class:`FittedModel`, the fitted model),
    :func:`compensate` (in memory), :func:`compensate_file` (streamed, file to file),
    :func:`evaluate` (RMS before/after, steps, Allan), :func:`select` (held-out RMS of
    every ``auto`` candidate, as ``rinscal select``, or per setting, Tables 5 and 7).
    ``ThermalModel`` and ``ThermalModelFile``, the old names of :class:`ThermalFitter` and
    :class:`FittedModel`, still work for one release.
Navigation
    :func:`navigate` (a scenario or a recording, with and without models), :class:`Scenario`
    (a scenario built in code), :func:`scenario` (the paper's, by name).

Every function that takes an IMU takes it as ``imu=`` (a preset name, a TOML file or an
:class:`ImuConfig`), default ``"paper"``, as the commands do. Arguments are checked at the
boundary (:mod:`rinscal._check`): a wrong type raises
:class:`~rinscal.errors.ArgumentTypeError` (a ``TypeError``; a number given as a string
too), a wrong value :class:`~rinscal.errors.ConfigError`, an empty table or one that is not a
log :class:`~rinscal.errors.LogError` (both ``ValueError``); the message names the argument.

A notebook session: ``docs/api.md``.

>>> import rinscal
>>> log, truth, meta = rinscal.simulate("soak", hours=1.0)  # doctest: +SKIP
>>> result = rinscal.fit(log, "regression", meta=meta)  # doctest: +SKIP
>>> nav = rinscal.navigate("quasi-static", hours=1.0, models={"m2": result.model})  # doctest: +SKIP
"""

from __future__ import annotations

import importlib
from typing import Any

from rinscal._version import __version__

#: The public API: name -> "module" or "module:attribute" it is defined in (loaded lazily).
_API: dict[str, str] = {
    "read_log": "rinscal.io.tables",
    "write_log": "rinscal.io.tables",
    "write_meta": "rinscal.io.metadata",
    "simulate": "rinscal.sim.protocols:simulate_protocol",
    "simulate_multiposition": "rinscal.sim.multiposition",
    "ImuCalibration": "rinscal.sensormodel",
    "load_imu": "rinscal.sim.config",
    "ImuConfig": "rinscal.sim.config",
    "fit": "rinscal.calibration.workflow",
    "calibrate_imu": "rinscal.calibration.imu.workflow",
    "ImuCalibrationResult": "rinscal.calibration.imu.workflow",
    "FitResult": "rinscal.calibration.workflow",
    "ThermalFitter": "rinscal.calibration.thermal.model",
    "load_model": "rinscal.calibration.workflow",
    "FittedModel": "rinscal.calibration.modelfile",
    "compensate": "rinscal.calibration.workflow",
    "compensate_file": "rinscal.calibration.workflow",
    "evaluate": "rinscal.calibration.workflow",
    "select": "rinscal.calibration.selection.heldout:select_model",
    "navigate": "rinscal.sim.workflow",
    "Scenario": "rinscal.sim.scenario_config:ScenarioConfig",
    "scenario": "rinscal.sim.scenario:preset",
}

#: Old names, kept for one release: the same objects as the names they point to.
_ALIASES: dict[str, str] = {"ThermalModel": "ThermalFitter", "ThermalModelFile": "FittedModel"}

__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    """Load a public name on first use (PEP 562)."""
    if name in _ALIASES:
        value = __getattr__(_ALIASES[name])
        globals()[name] = value
        return value
    target = _API.get(name)
    if target is None:
        raise AttributeError(f"module 'rinscal' has no attribute {name!r}")
    module, _, attr = target.partition(":")
    value = getattr(importlib.import_module(module), attr or name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(__all__)

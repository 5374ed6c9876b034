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
Each function has one signature, shared conventions and a typed result:

- the IMU is ``imu=``: a preset name, an IMU TOML file's path or an :class:`ImuConfig`,
  default ``"paper"`` (the paper's own, Tables 1-2), as the commands do (a recording's
  navigation: default its metadata's);
- randomness is ``seed=`` (an int; one seed, every random number);
- a long call takes ``progress=``, called ``progress(done, total)`` as it goes (``total``
  NaN while it is not known yet, e.g. while a file is read);
- results are typed (frozen dataclasses or named tuples); those that were tuples still
  unpack as before (``log, truth, meta = simulate(...)``).

Data
    :func:`read_log` (a calibration log file → validated table), :func:`write_log` and
    :func:`write_meta` (a table and its ``.meta.json`` sidecar, atomically),
    :func:`simulate` (a chamber protocol → :class:`Simulation`: log, truth, metadata),
    :func:`simulate_multiposition` (the IMU on a two-axis turntable in the chamber →
    :class:`Simulation`: log, truth parameter table, metadata),
    :func:`simulate_field_starts` (parked cold starts at given ambients → recorded-navigation
    logs with metadata and truth in a folder), :func:`load_imu` (an IMU preset or TOML file
    → :class:`ImuConfig`).
Calibration
    :func:`fit` (→ :class:`FitResult`: the model and its report), :func:`load_model` (a
    JSON model file → :class:`FittedModel`, the fitted model), :func:`compensate` (in
    memory), :func:`compensate_file` (streamed, file to file), :func:`evaluate` (RMS
    before/after, steps, Allan), :func:`select` (held-out RMS of every ``auto`` candidate,
    as ``rinscal select``, or per setting, Tables 5 and 7), :func:`calibrate_imu` (a
    multi-position turntable log → scale factors, misalignments and biases over
    temperature, :class:`ImuCalibrationResult`; its laws an :class:`ImuCalibration`),
    :func:`calibrate_field` (recordings of parked cold starts → a thermal model with no
    chamber, :class:`FieldCalibration`: the model and what the starts determined).
    :class:`ThermalFitter` is the fitter (scikit-learn style, all channels), and the six
    channel estimators it uses are scikit-learn regressors: :class:`PolyT`,
    :class:`Regression` (the paper's method 2), :class:`Sectional` (method 1),
    :class:`Neural` (method 3), :class:`PX4Fit` and :class:`ArduPilotFit` (the autopilots'
    own fits).
Navigation
    :func:`navigate_scenario` (a simulated cold start, with and without models →
    ``Navigation``), :func:`navigate_log` (a recording → ``RecordedNavigation``),
    :class:`ScenarioConfig` (a scenario built in code), :func:`paper_scenario` (the paper's,
    by name).
Experiments
    :func:`study` (a Monte Carlo study into a folder → :class:`Study`), :func:`reproduce`
    (the paper's Section 5 into a folder → :class:`Reproduction`).

Old names, kept for one release and left out of ``__all__`` (so ``help(rinscal)`` lists
each function once): ``navigate`` (dispatches to :func:`navigate_scenario` or, with
``log=``, :func:`navigate_log`), ``Scenario`` (:class:`ScenarioConfig`), ``scenario``
(:func:`paper_scenario`), ``ThermalModel`` (:class:`ThermalFitter`), ``ThermalModelFile``
(:class:`FittedModel`); ``simulate(config=)`` (``imu=``), ``select(random_state=)``
(``seed=``) and the progress hooks ``on_run``, ``on_channel``, ``on_fit``, ``on_progress``
(``progress=``) warn.

Arguments are checked at the boundary (:mod:`rinscal._check`): a wrong type raises
:class:`~rinscal.errors.ArgumentTypeError` (a ``TypeError``; a number given as a string
too), a wrong value :class:`~rinscal.errors.ConfigError`, an empty table or one that is not a
log :class:`~rinscal.errors.LogError` (both ``ValueError``); the message names the argument.

A notebook session: ``docs/api.md``.

>>> import rinscal
>>> log, truth, meta = rinscal.simulate("soak", hours=1.0)  # doctest: +SKIP
>>> result = rinscal.fit(log, "regression", meta=meta)  # doctest: +SKIP
>>> nav = rinscal.navigate_scenario("quasi-static", models=[result.model])  # doctest: +SKIP
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
    "simulate_field_starts": "rinscal.sim.fieldstarts",
    "Simulation": "rinscal.sim.protocols",
    "load_imu": "rinscal.sim.config",
    "ImuConfig": "rinscal.sim.config",
    "fit": "rinscal.calibration.workflow",
    "FitResult": "rinscal.calibration.workflow",
    "ThermalFitter": "rinscal.calibration.thermal.model",
    "load_model": "rinscal.calibration.workflow",
    "FittedModel": "rinscal.calibration.modelfile",
    "compensate": "rinscal.calibration.workflow",
    "compensate_file": "rinscal.calibration.workflow",
    "evaluate": "rinscal.calibration.workflow",
    "select": "rinscal.calibration.selection.heldout:select_model",
    "calibrate_imu": "rinscal.calibration.imu.workflow",
    "ImuCalibrationResult": "rinscal.calibration.imu.workflow",
    "ImuCalibration": "rinscal.sensormodel",
    "calibrate_field": "rinscal.nav.fieldcal",
    "FieldCalibration": "rinscal.nav.fieldcal",
    "PolyT": "rinscal.calibration.thermal.estimators",
    "Regression": "rinscal.calibration.thermal.estimators",
    "Sectional": "rinscal.calibration.thermal.estimators",
    "Neural": "rinscal.calibration.thermal.estimators",
    "PX4Fit": "rinscal.calibration.thermal.estimators",
    "ArduPilotFit": "rinscal.calibration.thermal.estimators",
    "navigate_scenario": "rinscal.sim.workflow",
    "navigate_log": "rinscal.nav.recording",
    "ScenarioConfig": "rinscal.sim.scenario_config",
    "paper_scenario": "rinscal.sim.scenario:preset",
    "study": "rinscal.report.runs",
    "Study": "rinscal.report.runs",
    "reproduce": "rinscal.report.runs",
    "Reproduction": "rinscal.report.runs",
}

#: Old names, kept for one release and left out of ``__all__``: the new name they stand for,
#: or (``navigate``) a "module:attribute" of their own.
_ALIASES: dict[str, str] = {
    "ThermalModel": "ThermalFitter",
    "ThermalModelFile": "FittedModel",
    "Scenario": "ScenarioConfig",
    "scenario": "paper_scenario",
    "navigate": "rinscal.sim.workflow:navigate",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    """Load a public name, or an old one, on first use (PEP 562)."""
    target = _API.get(name) or _ALIASES.get(name)
    if target is None:
        raise AttributeError(f"module 'rinscal' has no attribute {name!r}")
    if target in _API:  # an old name of a public one: the same object
        value = __getattr__(target)
    else:
        module, _, attr = target.partition(":")
        value = getattr(importlib.import_module(module), attr or name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(__all__)

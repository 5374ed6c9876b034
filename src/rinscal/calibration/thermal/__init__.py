"""Thermal bias models of one IMU and their fitting.

Modules
-------
:mod:`~rinscal.calibration.thermal.features`
    Per-run model inputs ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C] and outlier masks.
:mod:`~rinscal.calibration.thermal.rate`
    Compiled temperature-rate kernels (windowed slopes, centred and causal).
:mod:`~rinscal.calibration.thermal.estimators`
    ``PolyT``, ``Sectional`` (method 1), ``Regression`` (method 2), ``Neural`` (method 3):
    scikit-learn estimators of one channel.
:mod:`~rinscal.calibration.thermal.baselines`
    The field's fits: PX4 and ArduPilot temperature calibration.
:mod:`~rinscal.calibration.thermal.guards`
    Checks of the training data and of the design (warnings, singular designs).
:mod:`~rinscal.calibration.thermal.model`
    ``ThermalFitter``: one estimator per channel, fitted on a calibration log.
``_fit``, ``_dispatch``, ``_runs``
    Numpy fitting of the polynomial models, the dispatch of every method, and the per-run
    factors a log read run by run leaves behind.

This package imports nothing on purpose.
"""

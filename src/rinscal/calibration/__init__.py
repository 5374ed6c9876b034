"""Thermal calibration: features, the paper's three models and the field's baseline.

Modules
-------
:mod:`~rinscal.calibration.features`
    Per-run model inputs ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C] and outlier masks.
:mod:`~rinscal.calibration.estimators`
    ``PolyT``, ``Sectional`` (method 1), ``Regression`` (method 2), ``Neural`` (method 3):
    scikit-learn estimators of one channel.
:mod:`~rinscal.calibration.model`
    ``ThermalModel``: one estimator per channel, fitted on a calibration log.
:mod:`~rinscal.calibration.modelfile`
    ``ThermalModelFile``: the validated JSON model file and numpy-only inference
    (``predict``, ``predict_bias_si``).
:mod:`~rinscal.calibration.compensate`
    Batch and streaming compensation (Eq. 10).
:mod:`~rinscal.calibration.evaluate`
    RMS before/after (Eq. 16) and steps at segment edges (Figure 7).
:mod:`~rinscal.calibration.selection`
    Order / neuron-count selection on held-out runs (Tables 5 and 7, honestly).
:mod:`~rinscal.calibration.export`
    PX4 ``.params``, ArduPilot ``.parm`` and C headers.

This package imports nothing on purpose: loading a model file and predicting with it
(:mod:`rinscal.calibration.modelfile`) needs numpy alone, never scikit-learn.
"""

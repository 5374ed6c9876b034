"""Calibration: thermal bias models, their selection, model files and compensation.

Sub-packages
------------
:mod:`~rinscal.calibration.thermal`
    Thermal bias models and their fitting (features, estimators, the field's baselines,
    ``ThermalFitter``).
:mod:`~rinscal.calibration.selection`
    Model selection on held-out data (``fit --method auto``, Tables 5 and 7, honestly).

Modules
-------
:mod:`~rinscal.calibration.inference`
    Numpy-only inference of every method from its stored parameters.
:mod:`~rinscal.calibration.modelfile`
    ``FittedModel``: the validated JSON model file and numpy-only inference
    (``predict``, ``predict_bias_si``).
:mod:`~rinscal.calibration.compensator`
    ``Compensator``: the one compensator, batch, streaming and causal (held between
    thermometer readings) modes of one bias computation.
:mod:`~rinscal.calibration.compensate`
    Compensation of a log (Eq. 10) and what it reports, through ``Compensator``.
:mod:`~rinscal.calibration.evaluate`
    RMS before/after (Eq. 16) and steps at segment edges (Figure 7).
:mod:`~rinscal.calibration.allan`
    Allan deviation and noise parameters.
:mod:`~rinscal.calibration.export`
    PX4 ``.params``, ArduPilot ``.parm`` and C headers.
``_domain``
    The joint input domain (occupancy grid) a model file stores and checks.

This package imports nothing on purpose: loading a model file and predicting with it
(:mod:`rinscal.calibration.modelfile`) needs numpy alone, never scikit-learn.
"""

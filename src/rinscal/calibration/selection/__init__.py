"""Model selection on held-out data: ``fit --method auto`` and order selection on runs.

Modules
-------
:mod:`~rinscal.calibration.selection.folds`
    Held-out folds: runs, or the heating and cooling legs of a run.
:mod:`~rinscal.calibration.selection.candidates`
    The candidate models of ``auto`` and their fits.
:mod:`~rinscal.calibration.selection.auto`
    ``fit --method auto``: each channel's model chosen by held-out error.
:mod:`~rinscal.calibration.selection.heldout`
    Polynomial orders or hidden-layer size on runs the model never saw (Tables 5 and 7).

This package imports nothing on purpose.
"""

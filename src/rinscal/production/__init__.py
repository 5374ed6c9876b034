"""Production: calibrating a fleet of units.

Modules
-------
:mod:`~rinscal.production.fleet`
    Fleet calibration on Dask: one task per unit's log, a resumable results folder, verdicts
    against limits.
"""

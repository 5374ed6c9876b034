"""Monte Carlo studies: many units, many cold starts, every method on the same raw data.

Modules
-------
:mod:`~rinscal.experiments.study.spec`
    The study spec: built-in studies, the TOML layout, validation and sweeps.
:mod:`~rinscal.experiments.study.tasks`
    The calibration and navigation tasks a spec expands into, and the pure functions that
    run them.
:mod:`~rinscal.experiments.study.runner`
    Execution on Dask and the results folder (resumable).
:mod:`~rinscal.experiments.study.stats`
    Statistics over a study's results: paired comparisons, sweeps, claims.
"""

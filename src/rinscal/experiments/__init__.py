"""The paper's experiments, one function per table or figure, and Monte Carlo studies of them.

Packages
--------
:mod:`~rinscal.experiments.paper`
    The paper's Section 5 re-run end to end on one simulated plant (``rinscal reproduce``).
:mod:`~rinscal.experiments.study`
    Many units and cold starts on Dask, every method on the same raw data (``rinscal study``).
"""

"""The paper's Section 5, re-run end to end on one simulated plant.

Stages (each a plain function returning data; :mod:`rinscal.cli.reproduce` adds files,
progress bars and the report):

1. :func:`~rinscal.experiments.paper.calibration.calibration_stage` — soak calibration data
   (Table 3), the three methods' fits plus the field's cubic-in-T baseline (Tables 4, 6, 8),
   the order and neuron tables with training *and* held-out RMS (Tables 5, 7), the held-out
   thermal residual on the repetition-priming start and the chamber ramp, and the step at the
   segment edges (Figures 7, 8).
2. :func:`~rinscal.experiments.paper.navigation.navigation_stage` — the chamber ramp
   (Figure 9), five quasi-static and five swing cold starts with self-alignment (Figures
   11-13), three vehicle runs (Figures 15-16, Table 10); every method navigates on the
   *same* raw IMU output of each run.
3. :func:`~rinscal.experiments.paper.claims.summary_table` — each of the paper's headline
   numbers beside ours.

Everything is simulation on one plant, chosen by
:attr:`~rinscal.experiments.paper.config.ReproConfig.imu` (a preset of
:data:`rinscal.presets.PRESETS`, by default
:data:`~rinscal.presets.DEFAULT_PRESET`, or a TOML file) and loaded once by
:func:`~rinscal.experiments.paper.config.load_plant`: the calibration protocols and every
navigation run simulate that same IMU. No plant is tuned to agree with the paper.

Modules
-------
:mod:`~rinscal.experiments.paper.config`
    The methods, labels and the paper's numbers; :class:`ReproConfig`, the plant.
:mod:`~rinscal.experiments.paper.calibration`
    The calibration stage and its tables; the held-out table on the simulated plant and the
    real log's legs.
:mod:`~rinscal.experiments.paper.navigation`
    The navigation jobs and stage, the thermal residual of a cold start, the per-run tables.
:mod:`~rinscal.experiments.paper.claims`
    The headline and per-method summary tables, and the paper's claims checked.
"""

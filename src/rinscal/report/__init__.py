"""Figures and reports: functions that take data and return matplotlib Figures.

Nothing here reads or writes files; the CLI saves what these functions return. Figures are
built with :class:`matplotlib.figure.Figure` directly (no pyplot state, no GUI backend).

Modules
-------
:mod:`~rinscal.report.logplot`
    IMU outputs and temperatures of a calibration log against time (the paper's Figure 3).
:mod:`~rinscal.report.allan_plot`
    Allan deviation figures.
:mod:`~rinscal.report.nav_plots`
    Figures of a navigation run (the paper's Figures 9, 11, 12, 15, 16).
:mod:`~rinscal.report.html`
    The self-contained HTML report builder.
:mod:`~rinscal.report.paper_figures`
    The reproduction's figures.
:mod:`~rinscal.report.paper_report`
    The reproduction's report and files.
:mod:`~rinscal.report.study_report`
    A study's figures and report.
:mod:`~rinscal.report.fleet_report`
    The fleet's HTML report.
"""

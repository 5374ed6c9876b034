"""Figures and reports: functions that take data and return matplotlib Figures.

Nothing here reads or writes files; the CLI saves what these functions return. Figures are
built with :class:`matplotlib.figure.Figure` directly (no pyplot state, no GUI backend).
"""

from rinscal.report.logplot import Decimated, decimate, plot_log, units_from_meta

__all__ = ["Decimated", "decimate", "plot_log", "units_from_meta"]

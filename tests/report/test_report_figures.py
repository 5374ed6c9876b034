"""Figures drawn from tables whose numbers are known: the lab bars (Figure 13,
``rinscal.report.paper_figures``), the thermal field (``rinscal.report.nav_plots``) and the
fleet's per-unit figures (``rinscal.report.fleet_report``) show exactly the table's values."""

from __future__ import annotations

import numpy as np
import pandas as pd

from rinscal.report.fleet_report import FIGURES, fleet_figure
from rinscal.report.nav_plots import plot_temperatures
from rinscal.report.paper_figures import fig_lab_bars

METHODS = ("none", "sectional", "regression", "neural", "poly-t")


def test_lab_bars_are_the_lab_rows_maximum_errors_in_order() -> None:
    rows = []
    for number, experiment in ((2, "lab"), (1, "lab"), (3, "vehicle")):
        row = {"number": number, "experiment": experiment, "scenario": "quasi-static"}
        row |= {"ambient_c": 25.0} | {m: number + 0.1 * k for k, m in enumerate(METHODS)}
        rows.append(row)
    ax = fig_lab_bars(pd.DataFrame(rows)).axes[0]
    heights = [p.get_height() for p in ax.patches]
    # method by method, experiments 1 then 2 (sorted by number); the vehicle row left out
    assert heights == [n + 0.1 * k for k in range(len(METHODS)) for n in (1, 2)]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1\nquasi, 25 °C", "2\nquasi, 25 °C"]


def test_the_thermal_field_plots_each_column_in_hours() -> None:
    temps = pd.DataFrame(
        {
            "time_s": [0.0, 1800.0, 3600.0],
            "chamber": [20.0, 20.0, 20.0],
            "outer": [20.0, 25.0, 28.0],
            "sensor_gyro_x": [20.0, 30.0, 35.0],
        }
    )
    lines = plot_temperatures(temps).axes[0].get_lines()
    assert [ln.get_label() for ln in lines] == ["ambient / chamber", "outer (package)", "gyro_x"]
    np.testing.assert_array_equal(lines[2].get_xdata(), [0.0, 0.5, 1.0])
    np.testing.assert_array_equal(lines[2].get_ydata(), [20.0, 30.0, 35.0])


def test_the_fleet_figure_shows_every_finite_value_once() -> None:
    rows = []
    for unit, value in enumerate((0.5, 2.0, np.nan)):
        for name in FIGURES:
            rows.append(
                {"unit": unit, "channel": "gyro_x", "name": name, "value": value, "unit_of": ""}
            )
    fig = fleet_figure(pd.DataFrame(rows))
    gyro_axes = fig.axes[: len(FIGURES)]
    for ax in gyro_axes:
        (line,) = ax.get_lines()
        assert sorted(line.get_ydata()) == [0.5, 2.0]  # the NaN unit is not drawn
        assert ax.get_yscale() == "log"  # positive figures span decades
    assert all(not ax.get_lines() for ax in fig.axes[len(FIGURES) :])  # no accel rows given

"""Issue 36's smaller points, on the table and figure builders with known inputs: readable
per-run headers, each row's own significant digits, the fleet's physical units, whole-number
ticks on the Tables 5/7 figure."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from rinscal.calibration.inference import coefficient_unit, physical_coefficients
from rinscal.experiments.paper.config import LABELS
from rinscal.report.fleet_report import distribution_view
from rinscal.report.paper_cal_sections import imu_recovery_view
from rinscal.report.paper_figures import fig_selection
from rinscal.report.paper_nav_sections import run_table_view


def test_per_run_table_has_readable_headers_with_units() -> None:
    raw = pd.DataFrame(
        {
            "experiment": ["ramp", "lab", "vehicle"],
            "scenario": ["ramp", "quasi-static", "vehicle"],
            "number": [1, 2, 3],
            "ambient_c": [np.nan, 20.0, 5.0],
            "hours": [4.5, 2.0, 2.075],
            "none": [0.45, 0.42, 1.58],
            "true": [1.54, 0.26, 0.50],
        }
    )
    view = run_table_view(raw, LABELS, "nmi")
    assert list(view.columns) == [
        "run", "ambient [°C]", "duration [h]", "uncompensated [nmi]", "true bias (oracle) [nmi]",
    ]  # fmt: skip
    assert list(view["run"]) == ["ramp 1", "lab quasi-static 2", "vehicle 3"]  # not "ramp ramp"
    assert list(view["ambient [°C]"]) == ["chamber ramp", "20", "5"]  # no blank for the ramp
    assert view["true bias (oracle) [nmi]"].tolist() == [1.54, 0.26, 0.50]  # values untouched


def test_imu_recovery_rows_keep_their_digits_beside_the_sd() -> None:
    rec = pd.DataFrame(
        {
            "parameter": ["gyro_bias_x", "accel_mis_xy"],
            "unit": ["deg/h", "arcsec"],
            "set points": [5, 5],
            "max |error|": [0.0020693245, 1.0675787],
            "max |error|/sd": [1.4004431, 1.1287375],
            "truth slope /°C": [0.000138244, 0.8],
            "estimated slope /°C": [0.000163091, 0.78],
        }
    )
    v = imu_recovery_view(rec)
    # the "max |error| 0.00 °/h beside 1.40 sd": now 0.00207 °/h beside 1.4
    assert v.loc[0, "max |error| [unit]"] == "0.00207" and v.loc[0, "unit"] == "°/h"
    assert v.loc[0, "max |error| / sd"] == "1.4"
    assert v.loc[0, "true slope [unit/°C]"] == "0.000138"
    assert v.loc[1, "max |error| [unit]"] == "1.07"


def test_fleet_coefficients_in_physical_units() -> None:
    # f = 1 + 2 (T − 25) = −49 + 2 T
    c = physical_coefficients({"method": "poly-t", "t_ref": 25.0, "coef": [1.0, 2.0, 0.0, 0.0]})
    assert c["T⁰"] == pytest.approx(-49.0) and c["T¹"] == pytest.approx(2.0)
    assert c["T²"] == pytest.approx(0.0) and not any("[" in k for k in c)
    # f = 0.5 + 3 (T − 20)/10 = −5.5 + 0.3 T
    r = physical_coefficients({"method": "regression", "orders": [1], "center": [20.0],
                               "scale": [10.0], "intercept": 0.5, "coef": [[3.0]]})  # fmt: skip
    assert r == pytest.approx({"a₀": -5.5, "T¹": 0.3})
    assert coefficient_unit("T¹", "deg/h") == "°/h/°C"
    assert coefficient_unit("Ṫ²", "ug") == "µg/(°C/min)²"
    assert coefficient_unit("ΔT¹", "ug") == "µg/°C"
    assert coefficient_unit("a₀", "ug") == "µg"


def test_fleet_distribution_in_data_sheet_units_without_zeros() -> None:
    dist = pd.DataFrame(
        {
            "channel": ["gyro_x", "gyro_x", "accel_x", "gyro_x"],
            "model": ["poly-t"] * 4,
            "name": ["heldout_rms", "noise_density", "noise_density", "T¹"],
            "unit_of": ["deg/h", "deg/h", "ug", "°/h/°C"],
            "n": [5, 5, 5, 5],
            "mean": [0.0012, 0.03, 50.0, -0.00041],
            "sd": [0.0001, 0.003, 2.0, 0.00002],
            "min": [0.001, 0.027, 48.0, -0.00044],
            "median": [0.0012, 0.03, 50.0, -0.00041],
            "max": [0.0014, 0.033, 52.0, -0.00039],
        }
    )
    v = distribution_view(dist)
    assert list(v["figure or coefficient"]) == [
        "held-out RMS", "white-noise density", "white-noise density", "T¹"]  # fmt: skip
    # a gyro's white noise 0.03 °/h·√s = 0.0005 °/√h; an accelerometer's µg·√s = µg/√Hz
    assert list(v["unit"]) == ["°/h", "°/√h", "µg/√Hz", "°/h/°C"]
    assert list(v["mean"]) == ["0.0012", "0.0005", "50", "-0.00041"]
    assert list(v["sd"]) == ["0.0001", "0.00005", "2", "0.00002"]


def test_selection_figure_ticks_whole_orders() -> None:
    def sel(settings: list[int]) -> SimpleNamespace:
        rows = [{"channel": c, "setting": k, "rms_train": 1.0 / k, "rms_heldout": 1.1 / k}
                for c in ("accel_x", "accel_y", "accel_z", "gyro_x", "gyro_y", "gyro_z")
                for k in settings]  # fmt: skip
        return SimpleNamespace(table=pd.DataFrame(rows), recommended={})

    cal = SimpleNamespace(selection={"regression": sel([1, 2, 3, 4]),
                                     "neural": sel(list(range(1, 9)))}, tables={})  # fmt: skip
    fig = fig_selection(cal)  # type: ignore[arg-type]
    reg, nn = fig.axes[0], fig.axes[1]
    assert list(reg.get_xticks()) == [1, 2, 3, 4]  # not 1.0, 1.5, ... 4.0
    assert list(nn.get_xticks()) == list(range(1, 9))
    assert [t.get_text() for t in reg.get_xticklabels()] == ["1", "2", "3", "4"]


def test_forest_plot_is_readable_and_holds_every_interval() -> None:
    from rinscal.report.study_figures import MAX_WIDTH_IN, paired_figure

    rows = []
    scens = ("quasi-static", "swing", "vehicle")  # three panels: two rows of two
    for k, scen in enumerate(scens):
        for m in ("sectional", "regression", "neural"):
            for ref in ("none", "poly-t"):
                d = (-1.0 if m == "regression" else 2.0) * (k + 1)
                rows.append({"plant": 0, "plant_label": "p", "scenario": scen, "method": m,
                             "reference": ref, "delta": d, "delta ci low": d - 3.0 * (k + 1),
                             "delta ci high": d + 3.0 * (k + 1)})  # fmt: skip
    comp = pd.DataFrame(rows)
    fig = paired_figure(comp, 0)
    # drawn no wider than the page's column at 110 dpi: its titles are not shrunk to 7 px
    assert fig.get_size_inches()[0] <= MAX_WIDTH_IN + 1e-9
    axes = [ax for ax in fig.axes if ax.get_title()]
    assert [ax.get_title() for ax in axes] == list(scens)
    assert all(ax.title.get_fontsize() * 110 / 72 >= 15 for ax in axes)  # px at 110 dpi
    lo, hi = comp["delta ci low"].min(), comp["delta ci high"].max()  # −12 and 15
    for ax in axes:
        left, right = ax.get_xlim()
        assert left < lo and right > hi  # every interval inside the axes, on every panel

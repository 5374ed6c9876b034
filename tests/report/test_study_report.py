"""The study report from synthetic results whose statistics are known in advance."""

from __future__ import annotations

import numpy as np
import pandas as pd

from rinscal.experiments.paper.config import ReproConfig
from rinscal.experiments.study.spec import PlantVariant, load_spec, plant_table, reproduction_spec
from rinscal.experiments.study.stats import (
    claims_table,
    method_summary,
    paired_differences,
    sensitivity_map,
    uncompensated_wins,
)
from rinscal.report.study_report import StudyTables, build_report, verdict_lines


def _results(n_units: int = 8) -> pd.DataFrame:
    """Two plants: on plant 0 method 2 halves method 1's error, on plant 1 it changes
    nothing but noise; no compensation beats the baseline on plant 1."""
    rng = np.random.default_rng(0)
    rows = []
    for plant in (0, 1):
        for u in range(n_units):
            sec = 1.0 + 0.1 * u
            reg = sec / 2 if plant == 0 else sec + rng.normal(0, 0.05)
            vals = {
                "none": 3 * sec if plant == 0 else 0.5,
                "poly-t": 1.2 * sec,
                "sectional": sec,
                "regression": reg,
                "neural": reg * 1.1,
                "true": 0.1,
            }
            for v, e in vals.items():
                rows.append(
                    {
                        "plant": plant,
                        "plant_label": f"nav accel_dynamic_scale={plant}",
                        "unit": u,
                        "scenario": "qs",
                        "kind": "quasi-static",
                        "start": 0,
                        "variant": v,
                        "max_error_nmi": e,
                        "thermal_part_nmi": abs(e - 0.1),
                        "heading_error_arcsec": 20 * e,
                    }
                )
    return pd.DataFrame(rows)


def test_report_states_verdicts_map_and_where_no_compensation_wins() -> None:
    spec = load_spec("sensitivity", quick=True, units_override=8)
    res = _results()
    pairs = paired_differences(res)
    plants = plant_table(spec)
    t = StudyTables(
        res,
        plants,
        method_summary(res),
        pairs,
        claims_table(res, pairs),
        sensitivity_map(pairs, plants),
        pd.DataFrame(columns=["task", "error"]),
        uncompensated_wins(pairs),
    )
    sens = t.sensitivity.set_index("plant")
    assert sens.loc[0, "m2 verdict"] == "pays"
    assert sens.loc[0, "m2 decrease %"] == 50.0
    assert sens.loc[1, "m2 verdict"] == "noise"
    lines = verdict_lines(t)
    assert any("direction holds: 50 % less on average" in x for x in lines)
    assert any("no compensation" in x and "beats baseline" in x for x in lines)
    assert any(
        x.startswith(
            "sensitivity map: method 2 beats method 1 by a margin whose 95 % "
            "interval excludes zero in 1 of 2 cells"
        )
        for x in lines
    )
    page = build_report(spec, t, None).to_html()
    for ident in (
        'data-table="claims"',
        'data-table="pairs"',
        'data-table="sensitivity"',
        'data-figure="sensitivity-map"',
        'data-figure="distribution-p0"',
        'data-figure="paired-p0"',
        "Where no compensation wins",
    ):
        assert ident in page, ident
    assert "<script" not in page  # self-contained, no scripts


def test_reproduction_spec_takes_the_reproduction_sizes() -> None:
    cfg = ReproConfig.quick_preset(seed=4, imu="navigation_grade", align_start_s=300.0)
    spec = reproduction_spec(cfg, 12)
    assert spec.units == 12 and spec.seed == 4
    assert spec.plants == (PlantVariant("navigation_grade"),)
    assert spec.calibration.rate_hz == cfg.cal_rate_hz
    assert spec.calibration.neural_max_samples == cfg.neural_max_samples
    qs, swing, veh = spec.scenarios
    assert (qs.hours, qs.rate_hz, qs.ambient_c) == (cfg.qs_hours, cfg.nav_rate_hz, cfg.lab_temps_c)
    assert (swing.hours, swing.rate_hz) == (cfg.swing_hours, cfg.swing_rate_hz)
    assert veh.ambient_c == cfg.vehicle_ambient_c
    assert {s.align_start_s for s in spec.scenarios} == {300.0}

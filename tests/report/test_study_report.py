"""The study report from synthetic results whose statistics are known in advance: the
verdicts in words, a 3-unit study that never claims "within noise", the sensitivity map
coloured only where resolved, and no overlapping tick labels."""

from __future__ import annotations

import functools
import math
import re

import numpy as np
import pandas as pd

from rinscal.experiments.paper.config import ReproConfig
from rinscal.experiments.study.sensitivity import plant_sensitivities, sensitivity_map
from rinscal.experiments.study.spec import PlantVariant, load_spec, plant_table, reproduction_spec
from rinscal.report.study_figures import CELL_COLORS, label_overlaps, map_figure
from rinscal.report.study_report import build_report, tables_from_results, verdict_lines

SPEC = load_spec("sensitivity", quick=True, units_override=8)


def _results(n_units: int = 8) -> pd.DataFrame:
    """Two plants, two warm-up times: on plant 0 method 2 halves method 1's error and beats
    no compensation; on plant 1 it changes nothing but noise and no compensation (0.5 nmi)
    beats the cubic in T. The oracle has 0.1 nmi less error than none on plant 0."""
    rng = np.random.default_rng(0)
    rows = []
    for plant in (0, 1):
        for align in (0.0, 1800.0):
            for u in range(n_units):
                sec = 1.0 + 0.1 * u
                reg = sec / 2 if plant == 0 else sec + rng.normal(0, 0.05)
                none = 3 * sec if plant == 0 else 0.5
                vals = {
                    "none": none,
                    "poly-t": 1.2 * sec,
                    "sectional": sec,
                    "regression": reg,
                    "regression-no-dT": reg + 0.02,
                    "neural": reg * 1.1,
                    "true": none - 0.1,
                }
                for v, e in vals.items():
                    rows.append(
                        {
                            "plant": plant,
                            "plant_label": SPEC.plants[plant].label,
                            "unit": u,
                            "scenario": f"qs, align at {align:g} s",
                            "kind": "quasi-static",
                            "start": 0,
                            "align_start_s": align,
                            "variant": v,
                            "max_error_nmi": e,
                            "thermal_part_nmi": abs(e - vals["true"]),
                            "heading_error_arcsec": 20 * e,
                            "soak_rate_grad_corr": -0.85 - 0.01 * u,
                            "soak_design_cond": 3.5 + 0.2 * u,
                        }
                    )
    return pd.DataFrame(rows)


@functools.lru_cache(maxsize=4)
def _tables(n_units: int):  # type: ignore[no-untyped-def]
    res = _results(n_units)
    return tables_from_results(res, plant_table(SPEC), sensitivities=_sensitivities())


@functools.cache
def _sensitivities() -> pd.DataFrame:
    """The spec's plant sensitivities, computed once when a test first needs them (about 1 s
    of simulation: not at collection)."""
    return plant_sensitivities(SPEC)


def test_report_states_verdicts_map_oracle_and_ablation() -> None:
    t = _tables(8)
    lines = verdict_lines(t)
    text = "\n".join(lines)
    # plant 0: method 2 halves method 1's error in every unit: the claim holds, and the
    # description of the same pairs says 50 % less
    m12 = [x for x in lines if "method 2 (regression) better than method 1 (sectional) —" in x]
    assert m12 and "holds: " in m12[0] and "mean error 50 % less" in m12[0]
    # plant 1: no compensation (0.5 nmi) beats the cubic in T (1.2·sec ≥ 1.2 nmi), resolved
    assert "baseline (cubic in T) better than no compensation — reversed" in text
    assert "within noise" not in text
    # the oracle: none − oracle = +0.1 nmi exactly, resolved, in every unit
    o = t.oracle.set_index("plant").loc[0].iloc[0]
    assert o["delta"] == 0.1 or math.isclose(o["delta"], 0.1)
    assert any("no compensation − oracle = +0.100 nmi [0.100, 0.100]" in x for x in lines)
    # the ablation: method 2 − method 2 without ΔT = −0.02 nmi in every unit
    a = t.ablation.iloc[0]
    assert math.isclose(a["delta"], -0.02)
    assert a["verdict"] == "holds"
    # the soak design: median correlation −0.885 over the 8 units, condition 4.2
    assert any("r = −0.8" in x and "condition number 4.2" in x for x in lines)
    # the map: plant 0's method 2 beats none (better); plant 1's (≈ 1.35 nmi) is worse than
    # none (0.5 nmi), resolved
    cells = t.sensitivity.set_index(["plant", "warm-up [min]", "method", "reference"])
    assert cells.loc[(0, 0.0, "regression", "none"), "cell"] == "better"
    assert cells.loc[(1, 30.0, "regression", "none"), "cell"] == "worse"
    # physical axes: the ×1 navigation-grade plant's horizontal accelerometers, |25| and |18|
    # µg per °C/min (the preset's first-order rate terms), mean 21.5
    assert math.isclose(cells.loc[(0, 0.0, "regression", "none"), "accel_rate_ug_per_c_min"], 21.5)
    page = build_report(SPEC, t, None).to_html()
    # a sweep's comparisons are in the map (and the CSV); without a sweep, in tables
    flat = tables_from_results(_results(8), plant_table(SPEC))
    flat_page = build_report(SPEC, flat, None).to_html()
    assert 'data-table="against"' in flat_page and 'data-table="pairs"' in flat_page
    assert "m2 − none" in flat_page and "8 of 8" in flat_page
    assert 'data-table="against"' not in page
    for ident in (
        'data-table="claims"',
        'data-table="oracle"',
        'data-table="ablation"',
        'data-table="design"',
        'data-table="sensitivity"',
        'data-table="sensitivity_plants"',
        'data-figure="sensitivity-map"',
        'data-figure="distribution-p0"',
        'data-figure="paired-p0"',
        "Where no compensation wins",
    ):
        assert ident in page, ident
    assert "<script" not in page  # self-contained, no scripts
    assert "within noise" not in page


def _tables_html(page: str) -> list[list[str]]:
    """Header cells of every table of the page."""
    return [re.findall(r"<th>(.*?)</th>", m) for m in re.findall(r"<thead>(.*?)</thead>", page)]


def test_three_units_never_claim_within_noise_and_say_why() -> None:
    t = _tables(3)
    page = build_report(SPEC, t, None).to_html()
    csvs = "\n".join(
        df.to_csv(index=False)
        for df in (t.pairs, t.claims, t.comparisons, t.oracle, t.ablation, t.sensitivity, t.summary)
    )
    for where in (page, csvs, "\n".join(verdict_lines(t))):
        assert "within noise" not in where
        assert "not enough runs" in where
    for where in (page, "\n".join(verdict_lines(t))):
        assert "not enough runs (n = 3 units; needs 5)" in where
    # every verdict of a comparison says why it is undecided, never a direction
    assert set(t.comparisons["verdict"]) == {"not enough runs"}
    assert t.comparisons["delta ci low"].isna().all()
    assert set(t.sensitivity["cell"]) == {"not enough units"}
    # no header promises an interval it does not show; counts as counts
    heads = [h for hs in _tables_html(page) for h in hs]
    assert not any("CI]" in h for h in heads)
    assert "3 of 3" in page
    # every shown table has at most 8 columns
    assert max(len(h) for h in _tables_html(page)) <= 8


def test_map_is_coloured_only_where_resolved() -> None:
    comp = pd.DataFrame(
        [
            {
                "plant": p,
                "scenario": "qs",
                "align_start_s": 0.0,
                "method": m,
                "reference": ref,
                "metric": "max_error_nmi",
                "delta": d,
                "delta ci low": lo,
                "delta ci high": hi,
                "n units": n,
                "verdict": "",
            }
            for p, (d, lo, hi, n) in enumerate(
                [
                    (-0.2, -0.3, -0.1, 10),  # resolved, better
                    (0.2, 0.1, 0.3, 10),  # resolved, worse
                    (-0.2, -0.5, 0.1, 10),  # the point says better; the interval does not
                    (-0.2, math.nan, math.nan, 4),  # no interval
                ]
            )
            for m in ("regression", "neural")
            for ref in ("none", "poly-t")
        ]
    )
    sens = _sensitivities()
    cells = sensitivity_map(comp, sens[sens["plant"] < 4])
    got = cells.drop_duplicates("plant").set_index("plant")["cell"].to_dict()
    assert got == {0: "better", 1: "worse", 2: "unresolved", 3: "not enough units"}
    fig = map_figure(cells)
    fills = {
        tuple(round(c, 3) for c in patch.get_facecolor()[:3])
        for ax in fig.get_axes()
        for patch in ax.patches
    }
    # exactly the four fills, and the unresolved cell is grey, not green
    import matplotlib.colors as mc  # deferred: only this test reads colours

    want = {tuple(round(c, 3) for c in mc.to_rgb(v)) for v in CELL_COLORS.values()}
    assert fills == want
    assert label_overlaps(fig) == []


def test_full_map_has_no_overlapping_labels_and_the_checker_catches_overlaps() -> None:
    t = _tables(8)
    fig = map_figure(t.sensitivity)
    assert label_overlaps(fig) == []
    # a figure whose long x labels run into each other is caught
    import matplotlib.pyplot as plt  # deferred: only this test draws a figure of its own

    bad, ax = plt.subplots(figsize=(3, 2))
    ax.set_xticks(range(6), [f"accel_dynamic_scale={k}" for k in range(6)])
    pairs = label_overlaps(bad)
    plt.close(bad)
    assert ("accel_dynamic_scale=0", "accel_dynamic_scale=1") in pairs


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

"""The reports render in a real browser (headless Chromium, Debian's package): every figure
decodes, every table has rows, and at 1 280 px no element's content is wider than its box
(nothing hides behind a scrollbar). Skipped, naming the reason, where Chromium is absent;
``.ci/run`` installs it."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rinscal.experiments.study.spec import load_spec, plant_table
from rinscal.report.html import Report
from rinscal.report.study_report import build_report, study_tables
from tests.report._browser import chromium, rendered_inventory
from tests.report.test_html import _report

pytestmark = pytest.mark.skipif(
    chromium() is None, reason="Chromium is not installed (apt-get install chromium)"
)

PAGE_PX = 1280


def test_small_report_renders_in_chromium(tmp_path) -> None:
    r = _report()
    page = tmp_path / "report.html"
    page.write_text(r.to_html(), encoding="utf-8")
    inv = rendered_inventory(page, width=500)  # a narrow window (headless Chromium's minimum)
    assert [f["id"] for f in inv["figures"]] == r.figure_ids()
    assert all(f["width"] > 0 for f in inv["figures"])  # the PNG decoded
    assert all(0 < f["shown"] <= 500 for f in inv["figures"])  # and fits the screen
    assert [t["id"] for t in inv["tables"]] == r.table_ids()
    assert all(t["rows"] > 0 for t in inv["tables"])
    assert inv["scrollWidth"] <= 500  # no sideways scrolling of the page itself


def test_the_overflow_check_finds_a_table_too_wide_for_the_page(tmp_path) -> None:
    """The check can fail: 40 numeric columns cannot fit 1 280 px, and it names the table."""
    r = Report("wide")
    s = r.section("Wide", "wide")
    s.table("ok", pd.DataFrame({"a": [1.5], "b": [2.5]}), "narrow")
    s.table("wide", pd.DataFrame({f"column {i}": [123456.789] for i in range(40)}), "wide")
    page = tmp_path / "report.html"
    page.write_text(r.to_html(), encoding="utf-8")
    inv = rendered_inventory(page, width=PAGE_PX)
    assert {o["table"] for o in inv["overflow"]} == {"wide"}


class _Store:
    """The two things the study report reads from a study folder, held in memory."""

    def __init__(self, root, results: pd.DataFrame) -> None:
        self.root = root
        self._results = results

    def read_results(self, spec) -> pd.DataFrame:
        return self._results

    def failures(self) -> pd.DataFrame:
        return pd.DataFrame(columns=["task", "error"])


def _sensitivity_results(spec, n_units: int = 6) -> pd.DataFrame:
    """Synthetic results of the built-in sensitivity study: every plant of its sweep, every
    cold start, every variant, errors growing with the plant's sweep factors."""
    rng = np.random.default_rng(1)
    plants = plant_table(spec)
    rows = []
    for p, plant in enumerate(spec.plants):
        scale = float(np.prod([f for _, f in plant.params])) if plant.params else 1.0
        for sc in spec.scenarios:
            for u in range(n_units):
                base = 0.2 + 0.05 * np.log1p(scale) + rng.normal(0, 0.03)
                for v in spec.methods:
                    e = abs(base * {"none": 1.5, "true": 0.8}.get(v, 1.0) + rng.normal(0, 0.05))
                    rows.append({
                        "plant": p, "plant_label": plants.iloc[p]["plant_label"],
                        "unit": u, "scenario": sc.name, "kind": sc.kind, "start": 0,
                        "ambient_c": sc.ambient_c[0], "align_start_s": sc.align_start_s,
                        "align_s": sc.align_s, "variant": v, "max_error_nmi": e,
                        "final_error_nmi": e, "thermal_part_nmi": abs(e - base * 0.8),
                        "heading_error_arcsec": 100 * e, "gyro_residual_dph": 0.01,
                        "accel_residual_ug": 10 * e, "accel_residual_pct": 50.0,
                    })  # fmt: skip
    return pd.DataFrame(rows)


def test_study_report_fits_1280px(tmp_path) -> None:
    """The sensitivity study's report, built from synthetic results of its 16 plants and 6
    units: no element wider than its box at 1 280 px."""
    spec = load_spec("sensitivity", quick=True, units_override=6)
    store = _Store(tmp_path, _sensitivity_results(spec))
    page = tmp_path / "report.html"
    page.write_text(build_report(spec, study_tables(store, spec), None).to_html(), "utf-8")
    inv = rendered_inventory(page, width=PAGE_PX)
    assert inv["tables"] and inv["figures"]
    assert inv["overflow"] == [], inv["overflow"]
    assert inv["scrollWidth"] <= PAGE_PX


@pytest.mark.slow
@pytest.mark.parametrize("study", ["paper", "sensitivity"])
def test_real_study_reports_fit_1280px(tmp_path, study: str) -> None:
    """Full size: the built-in studies run for real (quick settings, 5 units: enough for
    intervals; the sensitivity study is about 10 min on 2 cores), their reports open at
    1 280 px with nothing wider than its box, and the map's tick labels do not overlap."""
    from typer.testing import CliRunner

    from rinscal.cli import app
    from rinscal.experiments.study.runner import StudyStore
    from rinscal.report.study_figures import label_overlaps, map_figure

    out = tmp_path / study
    res = CliRunner().invoke(
        app, ["study", study, "--quick", "--units", "5", "--workers", "2", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    page = out / "report.html"
    inv = rendered_inventory(page, width=PAGE_PX)
    assert inv["overflow"] == [], inv["overflow"]
    assert inv["scrollWidth"] <= PAGE_PX
    assert "within noise" not in page.read_text(encoding="utf-8")
    if study == "sensitivity":
        spec = load_spec("sensitivity", quick=True, units_override=5)
        t = study_tables(StudyStore(out), spec)
        assert not t.sensitivity.empty
        assert label_overlaps(map_figure(t.sensitivity)) == []

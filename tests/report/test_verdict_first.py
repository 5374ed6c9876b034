"""The verdict first: in headless Chromium at 1280 × 800 the first table of a study's
report is its verdict table, and it starts on the first screen (the reproduction's report is
checked on the quick run, in tests/experiments/test_reproduce.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rinscal.experiments.study.spec import plant_table
from rinscal.report.study_report import build_report, tables_from_results
from tests.report._browser import chromium, first_table
from tests.report.test_study_report import SPEC, _results


@pytest.mark.skipif(chromium() is None, reason="Chromium (Debian package) is not installed")
def test_study_report_opens_with_the_verdict_table(tmp_path: Path) -> None:
    t = tables_from_results(_results(8), plant_table(SPEC))
    page = tmp_path / "report.html"
    page.write_text(build_report(SPEC, t, None).to_html(), encoding="utf-8")
    first = first_table(page, 1280, 800)
    assert first["id"] == "verdict"
    # the table and its first row lie on the first screen
    assert first["row_bottom"] < first["window_height"] <= 800, first
    html = page.read_text(encoding="utf-8")
    # the contents list comes after the verdict, and the verdict's paragraph after its table
    assert html.index('data-table="verdict"') < html.index("<nav>")
    assert html.index('data-table="verdict"') < html.index("Each claim reads")

"""The report renders in a real browser: every figure decodes, every table has rows."""

from __future__ import annotations

import pytest

from tests.report._browser import chromium, rendered_inventory
from tests.report.test_html import _report

pytestmark = pytest.mark.skipif(chromium() is None, reason="Chromium is not installed")


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

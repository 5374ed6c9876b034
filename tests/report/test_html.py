"""The self-contained HTML report: embedded figures, tables, escaping, no external fetches."""

from __future__ import annotations

import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pandas as pd

from rinscal.report.html import Report, figure_to_png


def _report() -> Report:
    r = Report("Test <report>", subtitle="simulation")
    s = r.section("Tables & figures", "tf")
    s.text("A <b>plain</b> paragraph.")
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    s.figure("line", figure_to_png(fig), "A line")
    s.table("t1", pd.DataFrame({"channel": ["accel_x"], "rms": [1.23456789]}), "RMS")
    return r


def test_page_is_self_contained_and_names_every_item() -> None:
    r = _report()
    page = r.to_html()
    assert page.startswith("<!DOCTYPE html>")
    assert 'name="viewport"' in page
    assert r.figure_ids() == ["line"] and r.table_ids() == ["t1"]
    assert 'data-figure="line"' in page and 'data-table="t1"' in page
    assert "data:image/png;base64," in page
    # nothing is fetched from elsewhere: no src/href pointing outside the page
    assert not re.search(r'(src|href)="(https?:|//)', page)
    assert "<script" not in page


def test_text_is_escaped() -> None:
    page = _report().to_html()
    assert "&lt;b&gt;plain&lt;/b&gt;" in page and "Test &lt;report&gt;" in page
    assert "1.235" in page  # 4 significant digits

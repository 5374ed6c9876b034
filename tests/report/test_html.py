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


# ------------------------------------------------------------------ issue 36: folds, minus


def test_negative_numbers_get_the_minus_sign_and_nothing_else_does() -> None:
    from rinscal.report.html import typographic_minus

    assert typographic_minus("2.03 nmi [-0.59, 4.66]") == "2.03 nmi [\u22120.59, 4.66]"
    assert typographic_minus("per run: -9.9 / -65.5; (-.5)") == (
        "per run: \u22129.9 / \u221265.5; (\u2212.5)"
    )
    # ranges, options, names and exponents keep their hyphens
    for kept in ("1-8 hidden neurons", "Figures 11-13", "--seed 0", "fig-1", "1e-05"):
        assert typographic_minus(kept) == kept


def test_table_and_figure_fold_with_their_caption_and_the_page_uses_one_minus() -> None:
    r = Report("t")
    s = r.section("S", "s")
    s.text("A loss of -0.5 nmi.")
    s.table("runs", pd.DataFrame({"run": ["a", "b", "c"], "Δ [nmi]": [-1.5, 0.25, 2.0]}),
            "Per run", fold=True)  # fmt: skip
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    s.figure("line", figure_to_png(fig), "A line", fold=True)
    page = r.to_html()
    fold = re.search(r'<details class="fold"><summary>([^<]*)</summary>(.*?)</details>', page)
    assert fold is not None
    assert fold.group(1) == "Table: Per run (3 rows; also tables/runs.csv)"
    assert '<table id="tab-runs"' in fold.group(2) and "<td>\u22121.500</td>" in fold.group(2)
    assert "<summary>Figure: A line</summary><figure" in page
    assert "loss of \u22120.5 nmi" in page
    body = page.split("<body>")[1]
    assert not re.search(r"(?<![\w.\-])-\d", re.sub(r"data:image/png;base64,[^\"]*", "", body))
    assert r.table_ids() == ["runs"] and r.figure_ids() == ["line"]  # folded, still named


def test_a_folded_section_shows_its_lead_and_folds_the_rest() -> None:
    r = Report("t", folded=("detail",))
    top = r.section("Verdict", "verdict")
    top.table("verdict", pd.DataFrame({"m": ["x"], "v": [1.0]}), "Verdict")
    d = r.section("Detail", "detail")
    d.text("The finding in one sentence.")
    d.table("t1", pd.DataFrame({"a": [1.0]}), "one")
    d.table("t2", pd.DataFrame({"a": [2.0]}), "two")
    d.text("More words.")
    page = r.to_html()
    verdict = page[page.index('<section id="verdict">') : page.index('<section id="detail">')]
    assert "<details" not in verdict  # an open section shows everything
    detail = page[page.index('<section id="detail">') :]
    lead, fold = detail.split("<details", 1)
    assert "The finding in one sentence." in lead and "tab-t1" not in lead
    assert fold.startswith(' class="fold"><summary>The detail: 2 tables and 1 paragraph</summary>')
    assert "tab-t1" in fold and "tab-t2" in fold and "More words." in fold


def test_format_sig_keeps_small_figures_beside_large_ones() -> None:
    from rinscal.report.html import format_sig

    # issue 36: "max |error| 0.00 °/h" beside "1.40 sd": each row to 3 significant digits
    assert [format_sig(x, 3) for x in (0.0020693, 1.4004, 448.2, -0.0199999)] == [
        "0.00207", "1.4", "448", "-0.02"]  # fmt: skip
    assert format_sig(float("nan")) == "" and format_sig(None) == ""

"""The study report's words (``rinscal.report.study_words``): the sensitivity map read in
cell counts, the tables' short names, and sentences escaped into HTML."""

from __future__ import annotations

import re

import pandas as pd

from rinscal.report.study_words import CODES, code, map_lines, ul


def test_the_map_is_read_as_counts_of_its_cells() -> None:
    kinds = ["better"] * 3 + ["worse", "unresolved", "not enough units"]
    cells = pd.DataFrame(
        {"method": "regression", "reference": "none", "cell": kinds, "plant": range(6)}
    )
    cubic = cells.assign(method="neural", reference="poly-t", cell="worse")
    lines = map_lines(pd.concat([cells, cubic], ignore_index=True))
    assert len(lines) == 2
    assert lines[0].startswith(
        "sensitivity map, method 2 against no compensation: better in 3 of 6 cells, worse in 1, "
        "not resolved in 1, no interval"
    )
    assert re.search(r"\(fewer than \d+ units\) in 1$", lines[0])
    assert "method 3 against the cubic in T: better in 0 of 6 cells, worse in 6," in lines[1]


def test_short_names_and_html_lists() -> None:
    assert code("regression") == "m2" and code("poly-t") == "cubic"
    assert code("unknown") == "unknown"  # a variant without a short name keeps its own
    assert len(set(CODES.values())) == len(CODES)  # no two variants share a short name
    assert ul(["a < b", "x & y"]) == "<ul><li>a &lt; b</li><li>x &amp; y</li></ul>"

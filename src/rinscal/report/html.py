"""A self-contained HTML report: figures embedded as PNG data, tables as HTML, no scripts.

The page reads offline, reflows on a phone (tables scroll sideways inside their own box,
figures shrink to the screen width) and prints cleanly (no figure or table split across
pages where the browser can avoid it).
"""

from __future__ import annotations

import base64
import html
import io
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from matplotlib.figure import Figure

_CSS = """
:root { --fg: #1b1f24; --muted: #57606a; --line: #d0d7de; --accent: #0b5cad; --warn: #9a6700; }
* { box-sizing: border-box; }
body { font: 16px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color: var(--fg);
       max-width: 1100px; margin: 0 auto; padding: 1rem; }
h1 { font-size: 1.6rem; margin: .2rem 0 .6rem; }
h2 { font-size: 1.3rem; border-bottom: 1px solid var(--line); padding-bottom: .2rem;
     margin-top: 2rem; }
h3 { font-size: 1.05rem; margin-bottom: .3rem; }
p, li { max-width: 75ch; }
.note { color: var(--muted); font-size: .92rem; }
.banner { border-left: 4px solid var(--warn); background: #fff8c5; padding: .5rem .8rem; }
figure { margin: 1rem 0; break-inside: avoid; page-break-inside: avoid; }
figure img { max-width: 100%; height: auto; border: 1px solid var(--line); }
figcaption { color: var(--muted); font-size: .9rem; }
.table-wrap { overflow-x: auto; margin: .6rem 0 1rem; break-inside: avoid; }
table { border-collapse: collapse; font-size: .88rem; font-variant-numeric: tabular-nums; }
caption { text-align: left; font-weight: 600; padding: .3rem 0; }
th, td { border: 1px solid var(--line); padding: .25rem .5rem; text-align: right;
         white-space: nowrap; }
th { background: #f6f8fa; white-space: normal; vertical-align: bottom; min-width: 6ch;
     max-width: 16ch; }
td:first-child, th:first-child { text-align: left; }
td.wrap { white-space: normal; text-align: left; min-width: 14ch; max-width: 36ch; }
.verdict-pass { color: #1a7f37; font-weight: 600; }
.verdict-fail { color: #cf222e; font-weight: 600; }
nav ol { columns: 2; font-size: .92rem; }
details.fold { margin: .4rem 0 .8rem; }
details.fold > summary { cursor: pointer; color: var(--accent); font-size: .92rem; }
@media (max-width: 600px) { body { font-size: 15px; padding: .6rem; } nav ol { columns: 1; } }
@media print { body { max-width: none; } a { color: inherit; text-decoration: none; }
               .table-wrap { overflow: visible; } }
"""


def figure_to_png(fig: Figure, dpi: int = 110) -> bytes:
    """Render a matplotlib figure to PNG bytes (and close it)."""
    # deferred: pyplot loads in ~0.3 s; pages without figures do not need it
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


@dataclass
class Block:
    """One item of a section: a paragraph, a figure or a table."""

    kind: str
    html: str
    ident: str = ""


@dataclass
class Section:
    """A titled section of the report."""

    title: str
    ident: str
    blocks: list[Block] = field(default_factory=list)
    #: Shown before the contents list (the verdict that opens a report).
    lead: bool = False

    def text(self, text: str, css: str = "") -> None:
        """Add a paragraph of plain text (escaped; negative numbers with the minus sign)."""
        cls = f' class="{css}"' if css else ""
        self.blocks.append(Block("text", f"<p{cls}>{_esc(text)}</p>"))

    def raw(self, fragment: str) -> None:
        """Add trusted HTML made by this package (lists, verdicts); its negative numbers
        get the minus sign (:func:`typographic_minus`: no attribute here holds one)."""
        self.blocks.append(Block("raw", typographic_minus(fragment)))

    def figure(self, ident: str, png: bytes, caption: str, fold: bool = False) -> None:
        """Add a PNG figure with a caption; ``ident`` names it for tests and links.

        ``fold``: the figure sits in a closed ``<details>`` whose summary is the caption,
        so the page reads short and a reader opens it where wanted."""
        data = base64.b64encode(png).decode("ascii")
        cap = _esc(caption)
        fig = (
            f'<figure id="fig-{ident}" data-figure="{ident}"><img alt="{cap}" '
            f'src="data:image/png;base64,{data}"><figcaption>{cap}</figcaption></figure>'
        )
        self.blocks.append(
            Block("figure", _fold(fig, f"Figure: {caption}") if fold else fig, ident)
        )

    def table(
        self,
        ident: str,
        df: pd.DataFrame,
        caption: str,
        float_format: str = "{:.4g}",
        formats: Mapping[str, str] | None = None,
        fold: bool = False,
    ) -> None:
        """Add a table; ``ident`` names it for tests and for its CSV file.

        Every numeric column gets one format (:func:`column_format`: the significant digits
        of ``float_format`` at the column's largest value), so the decimals line up down a
        column; ``formats`` overrides it per column (``{"ambient [°C]": "{:.0f}"}``).
        Headers and long text wrap, so a table is as wide as its numbers, not its words.
        Negative numbers carry the minus sign (U+2212), as in the text.
        ``fold``: the table sits in a closed ``<details>`` whose summary is its caption,
        its row count and its CSV file (``tables/<ident>.csv``), for long per-run tables.
        """
        digits = _digits(float_format)
        fmts = {c: column_format(df[c], digits) for c in df.columns}
        fmts.update(formats or {})

        def fmt(col: object, v: object) -> str:
            if isinstance(v, float | np.floating):
                return "" if pd.isna(v) else fmts[col].format(v)
            return str(v)

        head = "".join(f"<th>{_esc(str(c))}</th>" for c in df.columns)
        rows = []
        for row in df.itertuples(index=False):
            cells = "".join(
                f'<td class="wrap">{_esc(fmt(c, v))}</td>'
                if isinstance(v, str) and len(v) > 24
                else f"<td>{_esc(fmt(c, v))}</td>"
                for c, v in zip(df.columns, row, strict=True)
            )
            rows.append(f"<tr>{cells}</tr>")
        tab = (
            f'<div class="table-wrap"><table id="tab-{ident}" data-table="{ident}">'
            f"<caption>{_esc(caption)}</caption><thead><tr>{head}</tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table></div>"
        )
        if fold:
            n = len(df)
            tab = _fold(tab, f"Table: {caption} ({n} row{'s' if n != 1 else ''}; "
                             f"also tables/{ident}.csv)")  # fmt: skip
        self.blocks.append(Block("table", tab, ident))


# a hyphen-minus that starts a number: not after a letter, digit or point (ranges such as
# "1-8", names such as "fig-1" and exponents keep theirs)
_NEGATIVE = re.compile(r"(?<![\w.\-])-(?=\.?\d)")


def typographic_minus(text: str) -> str:
    """``text`` with every negative number's hyphen-minus replaced by the minus sign
    U+2212 ("-0.59" → "−0.59", "[-1, 2]" → "[−1, 2]"); ranges ("1-8"), options ("--seed 0")
    and names keep their hyphens. The reports' one convention for negative numbers."""
    return _NEGATIVE.sub("\u2212", text)


def _esc(text: str) -> str:
    """HTML-escaped ``text`` with the typographic minus (:func:`typographic_minus`)."""
    return html.escape(typographic_minus(text))


def _contents(blocks: list[Block]) -> str:
    """What a fold holds, in words: "2 tables, 1 figure and 3 paragraphs"."""
    n = {k: sum(b.kind == k for b in blocks) for k in ("table", "figure")}
    words = [f"{v} {k}{'s' if v != 1 else ''}" for k, v in n.items() if v]
    rest = len(blocks) - sum(n.values())
    if rest:
        words.append(f"{rest} paragraph{'s' if rest != 1 else ''}")
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _fold(inner: str, summary: str) -> str:
    """``inner`` HTML in a closed ``<details>`` headed by ``summary`` (plain text)."""
    return f'<details class="fold"><summary>{_esc(summary)}</summary>{inner}</details>'


def format_sig(x: Any, digits: int = 4) -> str:
    """``x`` with ``digits`` significant digits in positional notation (no exponent);
    blank for NaN or None. For a column whose rows differ in unit or scale, where one
    column format would round the small ones to 0."""
    if x is None or (isinstance(x, float | np.floating) and not np.isfinite(x)):
        return ""
    return np.format_float_positional(float(x), precision=digits, fractional=False, trim="-")


def _digits(float_format: str) -> int:
    """Significant digits of a ``"{:.4g}"``-style format (4 if it names none)."""
    m = re.search(r"\.(\d+)[gGeEf]", float_format)
    return int(m.group(1)) if m else 4


def column_format(col: pd.Series, digits: int = 4) -> str:
    """One format for a whole column: fixed decimals giving ``digits`` significant digits
    at the column's largest magnitude (integers without decimals; scientific notation for
    a column whose values span more than 5 decades or exceed 1e6)."""
    if not pd.api.types.is_numeric_dtype(col) or pd.api.types.is_bool_dtype(col):
        return "{}"
    x = pd.to_numeric(col, errors="coerce").to_numpy(dtype=float)
    x = np.abs(x[np.isfinite(x)])
    if x.size == 0:
        return "{}"
    if np.all(x == np.round(x)) and x.max() < 1e6:
        return "{:.0f}"
    top = float(x.max())
    nz = x[x > 0]
    if top >= 1e6 or (nz.size and top / float(nz.min()) > 1e5 and top < 1e-2):
        return f"{{:.{max(digits - 1, 1)}e}}"
    decimals = max(0, digits - 1 - int(np.floor(np.log10(top))))
    return f"{{:.{min(decimals, 6)}f}}"


@dataclass
class Report:
    """A report under construction.

    ``folded``: the identifiers of the sections that show only their lead (the first block,
    where it is a paragraph) and fold the rest into one closed ``<details>``, so that the
    page reads short and its verdict comes first; the others show every block."""

    title: str
    subtitle: str = ""
    sections: list[Section] = field(default_factory=list)
    folded: tuple[str, ...] = ()

    def section(self, title: str, ident: str, lead: bool = False) -> Section:
        """Start a new section and return it; a ``lead`` section is shown first, before the
        contents list."""
        s = Section(title, ident, lead=lead)
        self.sections.append(s)
        return s

    def figure_ids(self) -> list[str]:
        """Identifiers of every figure, in order."""
        return [b.ident for s in self.sections for b in s.blocks if b.kind == "figure"]

    def table_ids(self) -> list[str]:
        """Identifiers of every table, in order."""
        return [b.ident for s in self.sections for b in s.blocks if b.kind == "table"]

    def to_html(self) -> str:
        """The whole page as one string."""
        toc = "".join(f'<li><a href="#{s.ident}">{_esc(s.title)}</a></li>' for s in self.sections)

        def render(sections: list[Section]) -> str:
            body = []
            for s in sections:
                body.append(f'<section id="{s.ident}"><h2>{_esc(s.title)}</h2>')
                blocks = s.blocks
                if s.ident in self.folded and blocks:
                    first = 1 if blocks[0].kind == "text" else 0
                    body.extend(b.html for b in blocks[:first])
                    blocks = blocks[first:]
                    if blocks:
                        inner = "".join(b.html for b in blocks)
                        body.append(_fold(inner, f"The detail: {_contents(blocks)}"))
                        blocks = []
                body.extend(b.html for b in blocks)
                body.append("</section>")
            return "".join(body)

        lead = render([s for s in self.sections if s.lead])
        rest = render([s for s in self.sections if not s.lead])
        sub = f'<p class="note">{_esc(self.subtitle)}</p>' if self.subtitle else ""
        return (
            '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{html.escape(self.title)}</title><style>{_CSS}</style></head><body>"
            f"<header><h1>{html.escape(self.title)}</h1>{sub}</header>"
            f"{lead}<nav><ol>{toc}</ol></nav>{rest}</body></html>\n"
        )


__all__ = [
    "Report",
    "Section",
    "column_format",
    "figure_to_png",
    "format_sig",
    "typographic_minus",
]

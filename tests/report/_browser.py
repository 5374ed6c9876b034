"""Open a page in real headless Chromium (Debian's package) and read back what it rendered."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
]

# Injected into a copy of the page: after load, list every figure (and whether its image
# decoded), every table (and its row count) and every element whose content is wider than
# its box (with every <details> fold open, so folded tables are checked too) into a
# <pre id="browser-check">; then close every fold and record the page's height.
_CHECK_SCRIPT = """
<script>
window.addEventListener('load', () => {
  const folds = [...document.querySelectorAll('details')];
  folds.forEach(d => { d.open = true; });
  const figs = [...document.querySelectorAll('figure[data-figure]')].map(f => {
    const img = f.querySelector('img');
    return {id: f.dataset.figure, width: img ? img.naturalWidth : 0,
            shown: img ? img.getBoundingClientRect().width : 0};
  });
  const tabs = [...document.querySelectorAll('table[data-table]')].map(t => ({
    id: t.dataset.table, rows: t.querySelectorAll('tbody tr').length}));
  // every element whose content is wider than its box (a table scrolling inside its
  // wrapper, a cell's text running out of it), named by the table or figure it belongs to
  const over = [];
  for (const el of document.querySelectorAll('body *')) {
    if (el.id === 'browser-check' || el.clientWidth === 0) continue;
    if (el.scrollWidth > el.clientWidth + 1) {
      const t = el.closest('.table-wrap') ? el.closest('.table-wrap').querySelector('table')
                                          : el.closest('table');
      const f = el.closest('figure');
      over.push({tag: el.tagName, content: el.scrollWidth, box: el.clientWidth,
                 table: t ? t.dataset.table : null, figure: f ? f.dataset.figure : null,
                 text: (el.textContent || '').slice(0, 60)});
    }
  }
  const scrollWidth = document.documentElement.scrollWidth;
  // the height a reader scrolls before opening any fold
  folds.forEach(d => { d.open = false; });
  const visible = el => el.getClientRects().length > 0;
  const pre = document.createElement('pre');
  pre.id = 'browser-check';
  pre.textContent = JSON.stringify({figures: figs, tables: tabs, overflow: over,
                                    scrollWidth: scrollWidth, folds: folds.length,
                                    foldedHeight: document.documentElement.scrollHeight,
                                    firstVisibleTable: ([...document.querySelectorAll(
                                      'table[data-table]')].find(visible) || {dataset: {}})
                                      .dataset.table || null});
  document.body.appendChild(pre);
});
</script>
"""


def chromium() -> str | None:
    """Path of the Chromium binary, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def _probe(page: Path, script: str, pre_id: str, width: int, height: int) -> dict:
    """Open a copy of ``page`` with ``script`` injected in Chromium (a ``width`` x ``height``
    window) and read back the JSON the script left in ``<pre id=pre_id>``."""
    exe = chromium()
    assert exe is not None
    html = page.read_text(encoding="utf-8")
    probe = page.with_name(f"{page.stem}.{pre_id}.html")
    probe.write_text(html.replace("</body>", script + "</body>"), encoding="utf-8")
    try:
        with tempfile.TemporaryDirectory() as profile:
            out = subprocess.run(
                [exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}",
                 f"--window-size={width},{height}", "--virtual-time-budget=10000", "--dump-dom",
                 probe.resolve().as_uri()],
                capture_output=True, text=True, timeout=120, check=True,
            )  # fmt: skip
    finally:
        probe.unlink(missing_ok=True)
    m = re.search(rf'<pre id="{pre_id}">(.*?)</pre>', out.stdout, re.S)
    assert m, "Chromium did not run the check: " + out.stderr[-2000:]
    return json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&"))


def rendered_inventory(page: Path, width: int = 1200, height: int = 900) -> dict:
    """Figures (decoded pixel width), tables (row counts) and ``overflow`` (elements whose
    content is wider than their box, with the table or figure they belong to, every fold
    open) as Chromium rendered the page in a window ``width`` x ``height`` px; ``folds``
    (the number of ``<details>``), ``foldedHeight`` (the document's scrollHeight [px] with
    every fold closed: what a reader scrolls before opening one) and ``firstVisibleTable``
    (the first table shown with the folds closed)."""
    return _probe(page, _CHECK_SCRIPT, "browser-check", width, height)


def screenshot(page: Path, png: Path, width: int = 1200, height: int = 2400) -> Path:
    """Save a screenshot of ``page`` as Chromium renders it at ``width`` x ``height``."""
    exe = chromium()
    assert exe is not None
    with tempfile.TemporaryDirectory() as profile:
        subprocess.run(
            [exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}",
             f"--screenshot={png}", page.resolve().as_uri()],
            capture_output=True, timeout=120, check=True,
        )  # fmt: skip
    return png


# Injected into a copy of the page: the first <table> of the document, where its top edge
# and its first body row lie at load, and the window's height.
_FIRST_TABLE_SCRIPT = """
<script>
window.addEventListener('load', () => {
  const t = document.querySelector('table');
  const row = t ? t.querySelector('tbody tr') : null;
  const pre = document.createElement('pre');
  pre.id = 'first-table';
  pre.textContent = JSON.stringify({
    id: t ? t.dataset.table : null,
    top: t ? t.getBoundingClientRect().top + window.scrollY : null,
    row_bottom: row ? row.getBoundingClientRect().bottom + window.scrollY : null,
    window_height: window.innerHeight});
  document.body.appendChild(pre);
});
</script>
"""


def first_table(page: Path, width: int = 1280, height: int = 800) -> dict:
    """The first ``<table>`` of ``page`` as Chromium lays it out in a ``width`` x ``height``
    window: ``id`` (its ``data-table``), ``top`` and ``row_bottom`` (the top of the table
    and the bottom of its first body row, px from the top of the document) and
    ``window_height`` [px]."""
    return _probe(page, _FIRST_TABLE_SCRIPT, "first-table", width, height)

"""Screenshots of both reports as headless Chromium renders them at 1 280 px.

Run from the repository root after a quick reproduction and a small study::

    rinscal reproduce --quick --seed 0 --out runs/quick-paper
    rinscal study paper --quick --units 5 --out runs/study-paper5
    python docs/scripts/report_screenshots.py runs/quick-paper runs/study-paper5

It writes ``docs/report-screenshot.png`` (the reproduction's report) and
``docs/study-report-screenshot.png`` (the study's): the top of each page, 1 280 × 2 400 px,
after checking that no element of either page is wider than its box at that width (the
check of ``tests/report/test_browser.py``). Needs Debian's ``chromium``.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests.report._browser import chromium, rendered_inventory, screenshot  # noqa: E402

WIDTH = 1280


def main(reproduction: Path, study: Path) -> None:
    if chromium() is None:
        raise SystemExit("Chromium is not installed (apt-get install chromium)")
    for folder, png in (
        (reproduction, ROOT / "docs" / "report-screenshot.png"),
        (study, ROOT / "docs" / "study-report-screenshot.png"),
    ):
        page = folder / "report.html"
        inv = rendered_inventory(page, width=WIDTH)
        if inv["overflow"]:
            raise SystemExit(f"{page}: wider than its box at {WIDTH} px: {inv['overflow']}")
        screenshot(page, png, width=WIDTH, height=2400)
        print(f"{png.relative_to(ROOT)} <- {page}")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))

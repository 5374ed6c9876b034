"""The lower bounds in pyproject.toml allow no version the code cannot run on (issue 34.8):
an API the code imports that a dependency added late is matched by that dependency's floor."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: (text in the source, distribution, first version that has it)
APIS = [
    ("from sklearn.utils.validation import", "scikit-learn", (1, 6), "validate_data"),
]


def _floors() -> dict[str, tuple[int, ...]]:
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    out = {}
    for dep in deps:
        m = re.match(r"([A-Za-z0-9_.\-]+)(?:\[[^]]*\])?\s*>=\s*([0-9.]+)", dep)
        if m:
            out[m.group(1).lower()] = tuple(int(x) for x in m.group(2).split("."))
    return out


def test_every_late_api_the_code_imports_is_within_the_floor() -> None:
    floors = _floors()
    src = "\n".join(p.read_text() for p in (ROOT / "src").rglob("*.py"))
    checked = 0
    for text, dist, since, name in APIS:
        lines = [ln for ln in src.splitlines() if text in ln and name in ln]
        if not lines:
            continue
        checked += 1
        assert floors[dist] >= since, (
            f"the code imports {name} ({dist} {'.'.join(map(str, since))}), "
            f"pyproject.toml allows {dist}>={'.'.join(map(str, floors[dist]))}"
        )
    assert checked, "none of the APIs is imported any more: update APIS"

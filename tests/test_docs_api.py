"""docs/api.md runs: its ```python blocks, in order, in one namespace, from an empty folder.

The tutorial is the Python API's contract with a user: if a block stops running, or a
figure it states stops holding (each block asserts what its prose says), this fails with the
block's number and first line.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

API_MD = Path(__file__).resolve().parents[1] / "docs" / "api.md"


def python_blocks(text: str) -> list[str]:
    """The ```python fenced blocks of a Markdown text, in order."""
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.M | re.S)


def test_the_tutorial_has_blocks() -> None:
    assert len(python_blocks(API_MD.read_text())) >= 5


def test_the_tutorial_runs_in_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert not any(tmp_path.iterdir())
    namespace: dict[str, object] = {"__name__": "__api_md__"}
    for k, block in enumerate(python_blocks(API_MD.read_text()), start=1):
        first = block.strip().splitlines()[0]
        try:
            exec(compile(block, f"docs/api.md block {k}", "exec"), namespace)
        except Exception as exc:  # pragma: no cover - the message is the point
            raise AssertionError(f"docs/api.md block {k} ({first!r}) failed: {exc!r}") from exc

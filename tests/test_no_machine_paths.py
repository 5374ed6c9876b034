"""No source, test or document holds an absolute path of one machine (issue 34.8): a fresh
clone elsewhere must run the same tests (files beside the repository are found relative to it)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: roots of one machine's file system (a user's home, this project's work folder)
MACHINE = re.compile(r"""["'(](/work/|/home/|/Users/|/root/|[A-Z]:\\\\Users)""")


def test_no_file_holds_an_absolute_path_of_one_machine() -> None:
    found = []
    for sub in ("src", "tests", "docs", "examples", "benchmarks"):
        for p in (ROOT / sub).rglob("*"):
            if p.suffix not in {".py", ".md", ".toml"} or p.resolve() == Path(__file__).resolve():
                continue
            for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1):
                if MACHINE.search(line):
                    found.append(f"{p.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not found, "\n".join(found)

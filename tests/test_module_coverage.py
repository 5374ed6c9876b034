"""Every source module is imported by some test, read statically from the tests' import
statements (nothing is imported to find out), and every module imports.

A module counts as imported by a test when a test file

* imports it, or imports a name from it (``import m``, ``from m import x``, ``from p import m``);
* imports a name from a module or package that takes that name from it at import (``from
  rinscal.io import read_log`` reaches ``rinscal.io.tables``), the top package's lazy API
  table included, and ``rinscal.<name>`` after ``import rinscal`` reaches the module the
  table names;
* imports a module inside it (importing ``a.b.c`` runs ``a/__init__`` and ``a/b/__init__``).

A module imported only to count here is not enough: each test checks a behaviour of it.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

from tests.test_layout import SRC, _modules, imports

TESTS = Path(__file__).resolve().parent


def _test_files() -> dict[str, Path]:
    return {
        "tests." + ".".join(p.relative_to(TESTS).with_suffix("").parts): p
        for p in sorted(TESTS.rglob("*.py"))
    }


_TOP_ATTRIBUTE = re.compile(r"\brinscal\.([A-Za-z_]\w*)")


def covered_modules(root: Path = SRC, tests: dict[str, Path] | None = None) -> set[str]:
    """The modules under ``root`` that some file of ``tests`` imports (see the docstring)."""
    tests = _test_files() if tests is None else tests
    mods = _modules(root)
    taken: dict[str, dict[str, str]] = {}  # module -> name -> the module it took it from
    for imp in imports(root):
        binds = not imp.deferred or imp.lazy or imp.source == "rinscal"  # at import or lazily
        if imp.name is not None and binds:
            taken.setdefault(imp.source, {})[imp.name] = imp.target
    reached: list[tuple[str, str | None]] = [(i.target, i.name) for i in imports(root, tests)]
    for path in tests.values():
        reached += [("rinscal", name) for name in _TOP_ATTRIBUTE.findall(path.read_text())]
    covered: set[str] = set()
    seen: set[tuple[str, str | None]] = set()
    while reached:
        item = reached.pop()
        if item in seen or item[0] not in mods:
            continue
        seen.add(item)
        target, name = item
        covered.add(target)
        source = taken.get(target, {}).get(name) if name is not None else None
        if source is not None:  # ``target`` took the name from ``source``: follow it
            reached.append((source, name))
    for mod in list(covered):  # importing a.b.c runs a/__init__ and a/b/__init__
        parts = mod.split(".")
        covered.update(".".join(parts[:k]) for k in range(1, len(parts)))
    return covered


def untested_modules(root: Path = SRC, tests: dict[str, Path] | None = None) -> list[str]:
    """Modules under ``root`` that no test imports."""
    covered = covered_modules(root, tests)
    return sorted(m for m in _modules(root) if m not in covered)


def test_every_module_is_imported_by_some_test() -> None:
    untested = untested_modules()
    assert not untested, "source modules that no test imports (test a behaviour of each):\n" + (
        "\n".join(untested)
    )


def test_the_check_follows_names_to_their_modules_and_misses_an_unused_one(
    tmp_path: Path,
) -> None:
    """Known answers on a made-up package: ``from rinscal.sub import f`` reaches ``sub.a``
    through the package's re-export and runs ``sub/__init__``; ``from rinscal.sub.d import
    k`` reaches ``sub.e``, which ``d`` imports at its top, but not ``sub.b``, which ``d``
    imports inside a function; ``rinscal.g`` reaches ``sub.c`` through the lazy API."""
    root = tmp_path / "src"
    pkg = root / "rinscal"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text('_API = {"g": "rinscal.sub.c:g"}\n')
    files = {
        "__init__": "from rinscal.sub.a import f\n",
        "a": "def f(): ...\n",
        "b": "def h(): ...\n",
        "c": "def g(): ...\n",
        "d": "from rinscal.sub.e import k\n\n\ndef later():\n    from rinscal.sub.b import h\n",
        "e": "def k(): ...\n",
    }
    for name, text in files.items():
        (pkg / "sub" / f"{name}.py").write_text(text)
    test = tmp_path / "tests" / "test_x.py"
    test.parent.mkdir()
    test.write_text("from rinscal.sub import f\nfrom rinscal.sub.d import k\n")
    tests = {"tests.test_x": test}
    assert untested_modules(root, tests) == ["rinscal.sub.b", "rinscal.sub.c"]
    test.write_text(
        "import rinscal\nfrom rinscal.sub import f\nfrom rinscal.sub.d import k\n\nrinscal.g()\n"
    )
    assert untested_modules(root, tests) == ["rinscal.sub.b"]


def test_every_module_imports() -> None:
    """A smoke test under the check above: each module imports on its own terms."""
    failed = []
    for mod in _modules(SRC):
        try:
            importlib.import_module(mod)
        except Exception as exc:  # every failure is reported, by name
            failed.append(f"{mod}: {type(exc).__name__}: {exc}")
    assert not failed, "\n".join(failed)

"""The layout's rules, read from the source with :mod:`ast` (nothing is imported).

* No upward import between layers (deferred imports inside functions included).
* No import cycle between files, including cycles through a package ``__init__`` (the top
  package's lazy API table counts as imports of the modules it names).
* No private name (a ``_module`` or a ``_name``) imported from another package.
* The simulator (:mod:`rinscal.sim`) imported only by itself, the experiments, the reports,
  the command line and the top-level API (and the deprecated ``rinscal.thermal`` shim).
* No module over 900 lines (the numba kernels excepted); one over 700 says in its docstring
  why it is one idea ("Why one module").
* Imports sit at module top; one inside a function says why on its line or the line above
  (a comment containing "deferred").
* Scenarios and recordings are navigated by the same engine function: each feeder
  (:data:`FEEDERS`) calls :data:`ENGINE_FUNCTION`, imported from :data:`ENGINE`.

Each rule is a function of the source tree, so the tests below also run it on a copy of the
package with one bad import added, and check that it fails naming that import.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import os
import shutil
import subprocess
import sys
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

#: Layers, bottom to top; a module may import from its own layer or a lower one. Modules of
#: one layer that must not import each other are listed in :data:`APART`.
LAYERS: tuple[tuple[str, ...], ...] = (
    (
        "rinscal._version",
        "rinscal.units",
        "rinscal.errors",
        "rinscal.schema",
        "rinscal._check",
        "rinscal.earth",
        "rinscal.firmware",
        "rinscal._resources",
        "rinscal.cluster",
        "rinscal.parallel",
        "rinscal.sensormodel",
        "rinscal.turntable",
        "rinscal.presets",
        "rinscal.imunoise",
        "rinscal._kernels",
    ),
    ("rinscal.io",),
    ("rinscal.calibration",),
    ("rinscal.nav",),
    ("rinscal.sim", "rinscal.thermal"),
    ("rinscal.experiments", "rinscal.production"),
    ("rinscal.report",),
    ("rinscal.cli",),
)
APART = (("rinscal.experiments", "rinscal.production"),)
#: The simulator, and the packages that may import it (the top-level API, ``rinscal``, too).
SIM = "rinscal.sim"
SIM_IMPORTERS = (
    SIM,
    "rinscal.thermal",
    "rinscal.experiments",
    "rinscal.report",
    "rinscal.cli",
)
MAX_LINES = 900
EXPLAIN_LINES = 700
EXEMPT_SIZE = {"rinscal._kernels"}
#: The one navigation loop, and the functions that feed it a stream of pieces (the
#: simulator's scenario, a recording's second pass).
ENGINE = "rinscal.nav.engine"
ENGINE_FUNCTION = "navigate_pieces"
FEEDERS = ("run_scenario", "navigate_recording")


@dataclass(frozen=True)
class Import:
    """One import statement's target, as a module of the package."""

    source: str  # importing module
    target: str  # imported module (a package's __init__ is the package's name)
    name: str | None  # the name taken from it (``from m import name``), if any
    line: int
    deferred: bool  # inside a function or method
    text: str
    lazy: bool = False  # a package's PEP 562 ``__getattr__``: runs on attribute access only
    path: str = ""  # the importing file, relative to the source root

    def where(self, root: Path) -> str:
        return f"{self.path}:{self.line}: {self.text}"


def _modules(root: Path) -> dict[str, Path]:
    mods = {}
    for p in sorted(root.rglob("*.py")):
        parts = list(p.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join(parts)] = p
    return mods


def _resolve(name: str, mods: dict[str, Path]) -> str:
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name


@dataclass(frozen=True)
class _Statement:
    """One ``import`` or ``from ... import`` statement as written, before resolution."""

    node: ast.Import | ast.ImportFrom
    function_line: int | None  # first line of the outermost function around it, if any
    lazy: bool  # inside a package's module-level ``__getattr__``


@dataclass(frozen=True)
class _Source:
    """What the rules read from one file: its lines, import statements, docstring, API."""

    lines: tuple[str, ...]
    statements: tuple[_Statement, ...]
    docstring: str
    api: tuple[tuple[str, str], ...]
    tree: ast.Module = dataclasses.field(compare=False, repr=False, default_factory=ast.Module)


@functools.cache
def _source(text: str, package_init: bool) -> _Source:
    """One file's facts, parsed once per distinct text (the altered copies in the tests
    below share every unchanged file's parse with the package itself)."""
    tree = ast.parse(text)
    found: list[_Statement] = []
    _statements(tree.body, None, False, package_init, found)
    return _Source(
        tuple(text.splitlines()),
        tuple(found),
        ast.get_docstring(tree) or "",
        tuple(_lazy_table(tree).items()),
        tree,
    )


_BODIES = ("body", "orelse", "finalbody", "handlers", "cases")


def _statements(
    body: list, function_line: int | None, lazy: bool, top: bool, out: list[_Statement]
) -> None:
    """Import statements under ``body``, walking statements only (an import is a statement,
    so expressions need no visit); ``top`` while at a package's module level."""
    for node in body:
        if isinstance(node, ast.Import | ast.ImportFrom):
            out.append(_Statement(node, function_line, lazy))
            continue
        inner, inner_lazy = function_line, lazy
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            inner = node.lineno if function_line is None else function_line
            inner_lazy = lazy or (
                top and isinstance(node, ast.FunctionDef) and node.name == "__getattr__"
            )
        for field in _BODIES:
            for child in getattr(node, field, None) or ():
                stmts = [child] if isinstance(child, ast.stmt) else child.body
                _statements(stmts, inner, inner_lazy, False, out)


def _lazy_table(tree: ast.Module) -> dict[str, str]:
    """The top package's lazy API: ``_API = {"name": "module[:attribute]", ...}``."""
    for node in tree.body:
        if (
            isinstance(node, ast.AnnAssign | ast.Assign)
            and isinstance(node.value, ast.Dict)
            and any(isinstance(t, ast.Name) and t.id == "_API" for t in _targets(node))
        ):
            return {
                ast.literal_eval(k): ast.literal_eval(v)
                for k, v in zip(node.value.keys, node.value.values, strict=True)
            }
    return {}


def _targets(node: ast.AnnAssign | ast.Assign) -> list[ast.expr]:
    return [node.target] if isinstance(node, ast.AnnAssign) else list(node.targets)


def _sources(root: Path) -> dict[str, tuple[Path, _Source]]:
    """Every module under ``root`` with its parsed facts."""
    return {
        mod: (path, _source(path.read_text(), path.name == "__init__.py"))
        for mod, path in _modules(root).items()
    }


def imports(root: Path = SRC, importers: dict[str, Path] | None = None) -> list[Import]:
    """Every import of a ``rinscal`` module by a ``rinscal`` module under ``root``, or by
    ``importers`` (module name -> file, e.g. the tests) where given."""
    mods = _modules(root)
    files = mods if importers is None else importers
    found: list[Import] = []
    for mod, path in files.items():
        src = _source(path.read_text(), path.name == "__init__.py")
        where = str(path.relative_to(root if path.is_relative_to(root) else root.parent))
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        if mod == "rinscal":
            for name, target in src.api:
                module = target.partition(":")[0]
                found.append(Import(mod, module, name, 0, True, f"_API[{name!r}]", path=where))
        for st in src.statements:
            node = st.node
            text = src.lines[node.lineno - 1].strip()
            nested = st.function_line is not None
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "rinscal":
                        target = _resolve(alias.name, mods)
                        found.append(
                            Import(mod, target, None, node.lineno, nested, text, st.lazy, where)
                        )
                continue
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            if base.split(".")[0] != "rinscal":
                continue
            for alias in node.names:
                full = f"{base}.{alias.name}"
                sub = full in mods
                found.append(
                    Import(
                        mod,
                        full if sub else _resolve(base, mods),
                        None if sub else alias.name,
                        node.lineno,
                        nested,
                        text,
                        st.lazy,
                        where,
                    )
                )
    return found


def _layer(module: str) -> int | None:
    for k, layer in enumerate(LAYERS):
        for top in layer:
            if module == top or module.startswith(top + "."):
                return k
    return None


def upward_imports(root: Path = SRC) -> list[str]:
    """Imports of a higher layer, of the top package, or across modules kept apart."""
    bad = []
    for imp in imports(root):
        if imp.source == "rinscal":
            continue  # the lazy API sits above every layer
        if imp.target == "rinscal":
            bad.append(f"{imp.where(root)}  (imports the top package, which sits above all)")
            continue
        a, b = _layer(imp.source), _layer(imp.target)
        if a is None or b is None:
            bad.append(f"{imp.where(root)}  (module outside every layer)")
        elif b > a:
            bad.append(f"{imp.where(root)}  (layer {LAYERS[a][0]} imports {LAYERS[b][0]})")
        for pair in APART:
            tops = [
                next((t for t in pair if m == t or m.startswith(t + ".")), None)
                for m in (imp.source, imp.target)
            ]
            if None not in tops and tops[0] != tops[1]:
                bad.append(f"{imp.where(root)}  ({tops[0]} and {tops[1]} are kept apart)")
    return bad


def _within(module: str, tops: tuple[str, ...]) -> bool:
    return any(module == t or module.startswith(t + ".") for t in tops)


def sim_imports(root: Path = SRC) -> list[str]:
    """Imports of the simulator from a module that may not import it."""
    return [
        f"{imp.where(root)}  (only {', '.join(SIM_IMPORTERS[2:])} and the API import {SIM})"
        for imp in imports(root)
        if _within(imp.target, (SIM,))
        and imp.source != "rinscal"
        and not _within(imp.source, SIM_IMPORTERS)
    ]


def import_cycles(root: Path = SRC) -> list[str]:
    """Each cycle between files, as its chain of imports (Tarjan's strongly connected parts)."""
    graph: dict[str, dict[str, Import]] = defaultdict(dict)
    for imp in imports(root):
        if imp.target != imp.source and not imp.lazy:
            graph[imp.source].setdefault(imp.target, imp)
    for mod, path in _modules(root).items():  # a.b.c runs a/b/__init__ (the top's API is lazy)
        parts = mod.split(".")
        where = str(path.relative_to(root))
        for k in range(2, len(parts)):
            parent = ".".join(parts[:k])
            runs = Import(mod, parent, None, 0, False, f"(runs {parent})", path=where)
            graph[mod].setdefault(parent, runs)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    parts: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, {}):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            part = []
            while True:
                w = stack.pop()
                on.discard(w)
                part.append(w)
                if w == v:
                    break
            if len(part) > 1:
                parts.append(part)

    for v in list(graph):
        if v not in index:
            visit(v)
    found = []
    for part in parts:
        members = set(part)
        chain = [
            imp.where(root) for v in sorted(members) for w, imp in graph[v].items() if w in members
        ]
        found.append("cycle " + " -> ".join(sorted(members)) + ":\n    " + "\n    ".join(chain))
    return found


def private_imports(root: Path = SRC) -> list[str]:
    """Private modules or names taken from outside the package that owns them."""
    bad = []
    mods = _modules(root)
    for imp in imports(root):
        if imp.source == "rinscal":
            continue
        parts = imp.target.split(".")
        owner = None
        for k, part in enumerate(parts):
            if part.startswith("_"):
                owner = ".".join(parts[:k])
                break
        if owner is None and imp.name is not None and imp.name.startswith("_"):
            module = mods[imp.target].name != "__init__.py"  # a package owns its own names
            owner = imp.target.rpartition(".")[0] if module else imp.target
        if owner is None:
            continue
        if not (imp.source == owner or imp.source.startswith(owner + ".")):
            bad.append(f"{imp.where(root)}  (private to {owner})")
    return bad


def module_sizes(root: Path = SRC) -> list[str]:
    """Modules over the limit, and long ones that do not say why they are one idea."""
    bad = []
    for mod, (path, src) in _sources(root).items():
        n = len(src.lines)
        if mod in EXEMPT_SIZE:
            continue
        if n > MAX_LINES:
            bad.append(f"{path.relative_to(root)}: {n} lines (at most {MAX_LINES})")
        elif n > EXPLAIN_LINES and "Why one module" not in src.docstring:
            bad.append(
                f"{path.relative_to(root)}: {n} lines and no 'Why one module' paragraph "
                "in its docstring"
            )
    return bad


def undeclared_deferred(root: Path = SRC) -> list[str]:
    """Imports inside a function with no comment saying why they are deferred.

    The comment (containing "deferred") may sit on the import's line or anywhere above it
    in the same (outermost) function: one comment serves a block of imports.
    """
    bad = []
    for path, src in _sources(root).values():
        for st in src.statements:
            if st.function_line is None:
                continue
            node = st.node
            above = src.lines[st.function_line - 1 : node.end_lineno or node.lineno]
            if not any("#" in ln and "deferred" in ln.split("#", 1)[1] for ln in above):
                line = src.lines[node.lineno - 1].strip()
                bad.append(f"{path.relative_to(root)}:{node.lineno}: {line}")
    return bad


def engine_feeders(root: Path = SRC) -> list[str]:
    """Feeders that do not call the engine function (imported from the engine), and
    feeders defined nowhere or twice."""
    bad = []
    found: dict[str, list[str]] = {f: [] for f in FEEDERS}
    for path in _modules(root).values():
        text = path.read_text()
        if not any(f"def {f}(" in text for f in FEEDERS):
            continue  # most files: no parse
        tree = ast.parse(text)
        imported = any(
            isinstance(n, ast.ImportFrom)
            and n.module == ENGINE
            and any(a.name == ENGINE_FUNCTION and a.asname is None for a in n.names)
            for n in ast.walk(tree)
        )
        for node in tree.body:
            if not (isinstance(node, ast.FunctionDef) and node.name in FEEDERS):
                continue
            where = f"{path.relative_to(root)}:{node.lineno}: {node.name}"
            found[node.name].append(where)
            calls = any(
                isinstance(n, ast.Call)
                and isinstance(n.func, ast.Name)
                and n.func.id == ENGINE_FUNCTION
                for n in ast.walk(node)
            )
            if not (calls and imported):
                bad.append(f"{where} does not call {ENGINE}.{ENGINE_FUNCTION}")
    for f, where in found.items():
        if len(where) != 1:
            bad.append(f"{f}: defined {len(where)} times ({', '.join(where) or 'nowhere'})")
    return bad


RULES = {
    "upward imports": upward_imports,
    "import cycles": import_cycles,
    "simulator imported outside its layers": sim_imports,
    "private names across packages": private_imports,
    "module sizes": module_sizes,
    "undeclared deferred imports": undeclared_deferred,
    "scenarios and recordings navigated by the same engine function": engine_feeders,
}


@pytest.mark.parametrize("rule", list(RULES))
def test_layout_rule_holds(rule: str) -> None:
    bad = RULES[rule](SRC)
    assert not bad, f"{rule}:\n" + "\n".join(bad)


def test_every_module_has_a_layer() -> None:
    outside = [m for m in _modules(SRC) if m != "rinscal" and _layer(m) is None]
    assert not outside, f"modules outside every layer (add them to LAYERS): {outside}"


def _copy(tmp_path: Path) -> Path:
    root = tmp_path / "src"
    shutil.copytree(SRC / "rinscal", root / "rinscal", ignore=shutil.ignore_patterns("__pycache__"))
    return root


def _new(rule, root: Path) -> list[str]:
    """What ``rule`` finds in the altered copy and not in the package itself."""
    before = set(rule(SRC))
    return [b for b in rule(root) if b not in before]


def _append(root: Path, rel: str, text: str) -> None:
    p = root / "rinscal" / rel
    p.write_text(p.read_text() + text)


def test_an_upward_import_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    _append(root, "nav/metrics.py", "\n\ndef _f():\n    import rinscal.sim.field  # deferred\n")
    bad = _new(upward_imports, root)
    assert len(bad) == 1 and "nav/metrics.py" in bad[0] and "rinscal.sim.field" in bad[0]


def test_a_cycle_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    # earth <- units is fine; units -> earth and earth -> units closes a cycle
    _append(root, "units.py", "\n\ndef _f():\n    from rinscal import earth  # deferred\n")
    _append(root, "earth.py", "\n\ndef _g():\n    from rinscal import units  # deferred\n")
    bad = _new(import_cycles, root)
    assert len(bad) == 1 and "rinscal.earth" in bad[0] and "rinscal.units" in bad[0]
    assert "units.py" in bad[0] and "earth.py" in bad[0]


def test_a_cycle_through_a_package_reexport_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    _append(root, "io/__init__.py", "\nfrom rinscal.io.tables import read_log  # noqa\n")
    bad = _new(import_cycles, root)
    assert len(bad) == 1 and "rinscal.io.tables" in bad[0] and "read_log" in bad[0]


def test_importing_the_lazy_api_from_inside_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    _append(root, "report/html.py", "\nfrom rinscal import read_log  # noqa\n")
    bad = _new(upward_imports, root)
    assert len(bad) == 1 and "report/html.py" in bad[0] and "top package" in bad[0]


def test_a_private_name_across_packages_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    _append(root, "report/html.py", "\nfrom rinscal.calibration import _domain  # noqa\n")
    bad = _new(private_imports, root)
    assert len(bad) == 1 and "report/html.py" in bad[0]
    assert "private to rinscal.calibration" in bad[0]


def test_a_long_module_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    _append(root, "units.py", "\n" + "\n".join(f"X{k} = {k}" for k in range(950)) + "\n")
    bad = _new(module_sizes, root)
    assert len(bad) == 1 and "units.py" in bad[0]


def test_the_simulator_imported_from_below_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    # production sits in the experiments' layer, above the simulator, and still may not
    _append(root, "production/fleet.py", "\nfrom rinscal.sim.config import load_imu  # noqa\n")
    bad = _new(sim_imports, root)
    assert len(bad) == 1 and "production/fleet.py" in bad[0] and "rinscal.sim.config" in bad[0]
    assert not _new(upward_imports, root)  # the layers alone let it through


_LOADED = """
import sys
from rinscal.calibration.workflow import compensate_file
from rinscal.nav.recording import navigate_log
compensate_file(sys.argv[1], sys.argv[2], sys.argv[3])
navigate_log(sys.argv[4], align_s=120.0, imu="paper")
print(" ".join(sorted(m for m in sys.modules if m.startswith("rinscal"))))
"""


def test_navigating_or_compensating_a_recording_loads_no_simulator(tmp_path: Path) -> None:
    """A fresh interpreter compensates a log and navigates a recording (told the ``paper``
    IMU's noise by name), then lists what it loaded: navigation, no simulator module."""
    from rinscal.sim.workflow import navigate_scenario  # deferred: the recording is simulated

    rec = tmp_path / "run.parquet"
    navigate_scenario(
        "quasi-static", hours=0.05, rate_hz=10.0, align_s=120.0, oracle=False, record=rec
    )
    cal = Path(__file__).parent / "data" / "modelfile_v2"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]),
    }
    args = [str(cal / "log.csv"), str(cal / "model_v2.json"), str(tmp_path / "c.csv"), str(rec)]
    done = subprocess.run(
        [sys.executable, "-c", _LOADED, *args], capture_output=True, text=True, env=env
    )
    assert done.returncode == 0, done.stderr
    loaded = done.stdout.split()
    assert "rinscal.nav.recorded.navigate" in loaded and "rinscal.calibration.compensate" in loaded
    assert "rinscal.imunoise" in loaded  # the preset's noise, read below the simulator
    assert not [m for m in loaded if _within(m, (SIM, "rinscal.thermal"))], loaded


# --------------------------------------------------------------------------- one compensator
#: The one compensator (issue 37): the class that computes a thermal model's bias in every
#: mode (batch, streaming, causal held between thermometer readings).
ONE_COMPENSATOR = ("rinscal.calibration.compensator", "Compensator")
#: The other classes whose name ends in "Compensator", and why each is not a second one.
OTHER_COMPENSATORS = {
    ("rinscal.nav.recorded.compensation", "PieceCompensator"): "protocol navigation calls",
    ("rinscal.sim.sensors", "ModelCompensator"): "adapter: the plant's thermometers fed to it",
}
#: The model's inference behind the bias: called by the model file and the one compensator.
BIAS_CALLS = ("predict_channel", "predict_bias_si", "apply_policy")
BIAS_HOMES = ("rinscal.calibration.modelfile", ONE_COMPENSATOR[0])
#: Who compensates with a model file, each importing the one class.
COMPENSATOR_CALLERS = {
    "compensate": "rinscal.calibration.compensate",
    "compensate (API, streamed)": "rinscal.calibration.workflow",
    "evaluate": "rinscal.calibration.evaluate",
    "nav scenario": "rinscal.sim.sensors",
    "nav recorded": "rinscal.nav.recording",
    "study": "rinscal.experiments.paper.navigation",
}


def one_compensator(root: Path = SRC) -> list[str]:
    """Second compensators: a class named ``*Compensator`` other than the one and those
    listed, the model's bias inference called outside the model file and the one class, or a
    caller that does not import the one class."""
    bad = []
    sources = _sources(root)
    for mod, (path, src) in sources.items():
        rel = path.relative_to(root)
        for node in ast.walk(src.tree):
            key = (mod, getattr(node, "name", ""))
            if (
                isinstance(node, ast.ClassDef)
                and node.name.endswith("Compensator")
                and key != ONE_COMPENSATOR
                and key not in OTHER_COMPENSATORS
            ):
                bad.append(f"{rel}:{node.lineno}: class {node.name} (a second compensator)")
            if isinstance(node, ast.Attribute) and node.attr in BIAS_CALLS:
                if mod not in BIAS_HOMES:
                    bad.append(f"{rel}:{node.lineno}: .{node.attr} (the bias outside Compensator)")
    for what, mod in COMPENSATOR_CALLERS.items():
        path, src = sources[mod]
        if not any(
            isinstance(st.node, ast.ImportFrom)
            and st.node.module == ONE_COMPENSATOR[0]
            and any(a.name == ONE_COMPENSATOR[1] for a in st.node.names)
            for st in src.statements
        ):
            bad.append(f"{path.relative_to(root)}: {what} does not use {'.'.join(ONE_COMPENSATOR)}")
    return bad


def test_one_compensator_class() -> None:
    bad = one_compensator(SRC)
    assert not bad, "one compensator:\n" + "\n".join(bad)


def test_a_second_compensator_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    _append(
        root,
        "nav/align.py",
        "\n\nclass HeldCompensator:\n    def __call__(self, m, x):\n"
        "        return m.predict_channel('gyro_x', x)\n",
    )
    p = root / "rinscal" / "calibration" / "evaluate.py"
    p.write_text(p.read_text().replace("import Compensator,", "import"))
    bad = _new(one_compensator, root)
    assert len(bad) == 3, bad
    assert "nav/align.py" in bad[0] and "HeldCompensator" in bad[0]
    assert "nav/align.py" in bad[1] and "predict_channel" in bad[1]
    assert "evaluate.py" in bad[2] and "evaluate does not use" in bad[2]


def test_a_recording_navigated_by_a_loop_of_its_own_is_named(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    p = root / "rinscal" / "nav" / "recorded" / "navigate.py"
    text = p.read_text()
    assert text.count("run = navigate_pieces(") == 1
    p.write_text(text.replace("run = navigate_pieces(", "run = _own_loop("))
    bad = _new(engine_feeders, root)
    assert len(bad) == 1 and "navigate_recording" in bad[0] and "navigate.py" in bad[0]

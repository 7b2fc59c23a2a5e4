"""The package's import graph: no cycles (top-level and function-level imports alike), data
flowing one way, and no private name imported from another module (issue 21, "imports").

The graph is read from the source with :mod:`ast` (every ``import vrelab...`` and ``from vrelab...
import`` at any depth, so an import hidden in a function counts; those under ``if
TYPE_CHECKING:`` are never executed and are left out), then checked for strongly connected
components (Tarjan). Each module is also imported alone in a fresh interpreter, which catches an
import that fails in some order.
"""

from __future__ import annotations

import ast
import functools
import subprocess
import sys
from pathlib import Path

import vrelab

SRC = Path(vrelab.__file__).parent
PACKAGE = "vrelab"


def _modules() -> dict[str, tuple[Path, bool]]:
    out = {}
    for p in sorted(SRC.rglob("*.py")):
        parts = list(p.relative_to(SRC.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        out[".".join(parts)] = (p, is_pkg)
    return out


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


@functools.cache
def _imports(tree: ast.AST) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement at any depth, except under ``if TYPE_CHECKING:`` (read only). Kept
    per tree (a node is hashed by identity; :func:`_tree` gives each module one tree): three
    graphs read each module's imports, and the walk was most of their ~6 s of CPU."""
    found: list[ast.Import | ast.ImportFrom] = []

    def walk(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for other in child.orelse:
                    walk(other)
                continue
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                found.append(child)
            walk(child)

    walk(tree)
    return found


@functools.cache
def _tree(path: Path) -> ast.Module:
    """The module's syntax tree, parsed once for the whole file's tests (read only)."""
    return ast.parse(path.read_text(encoding="utf-8"))


@functools.lru_cache(maxsize=1)
def _graph() -> tuple[dict[str, set[str]], list[tuple[str, str, str]]]:
    """(module -> modules it imports, [(importer, source module, private name)]); built once for
    the four tests that read it (~3 s of CPU each time), which only read it."""
    mods = _modules()
    edges: dict[str, set[str]] = {m: set() for m in mods}
    private: list[tuple[str, str, str]] = []
    for m, (path, is_pkg) in mods.items():
        pkg = m if is_pkg else m.rsplit(".", 1)[0]
        tree = _tree(path)
        for node in _imports(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.split(".")[0] == PACKAGE and a.name != m:
                        edges[m].add(a.name)
                continue
            if node.level:
                base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != PACKAGE:
                continue
            for a in node.names:
                full = f"{target}.{a.name}"
                dest = full if full in mods else target
                if dest != m:
                    edges[m].add(dest)
                if full not in mods and a.name.startswith("_") and not a.name.startswith("__"):
                    private.append((m, target, a.name))
        private += _private_attributes(m, tree, mods)
    return edges, private


def _private_attributes(m: str, tree: ast.AST, mods: dict[str, tuple[Path, bool]]) -> list[tuple[str, str, str]]:
    """``module._name`` in ``m`` where ``module`` is a vrelab module it imported whole
    (``from vrelab import shaker`` then ``shaker._conditions``): a private name read across
    modules as surely as by ``from ... import _conditions``."""
    bound: dict[str, str] = {}
    for node in _imports(tree):
        if isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").split(".")[0] == PACKAGE:
            for a in node.names:
                full = f"{node.module}.{a.name}"
                if full in mods:
                    bound[a.asname or a.name] = full
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.asname and a.name in mods:
                    bound[a.asname] = a.name
    found = []
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound
                and node.attr.startswith("_") and not node.attr.startswith("__") and bound[node.value.id] != m):
            found.append((m, bound[node.value.id], node.attr))
    return found


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for root in edges:
        if root in index:
            continue
        work = [(root, iter(sorted(edges.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def test_the_cycle_detector_finds_a_cycle_hidden_in_a_function() -> None:
    """The detector itself: a two-module cycle through a function-level import is found, a
    TYPE_CHECKING-only back edge is not."""
    tree_a = ast.parse("from vrelab.b import x\n")
    tree_b = ast.parse("def f():\n    from vrelab.a import y\n")
    tree_c = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from vrelab.a import y\n")
    assert len(_imports(tree_b)) == 1 and len(_imports(tree_c)) == 1  # only the typing import
    assert _cycles({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [["a", "b"]]
    assert _cycles({"a": {"b"}, "b": set(), "c": {"a"}}) == []
    assert len(_imports(tree_a)) == 1


def test_no_import_cycles_in_the_package() -> None:
    edges, _ = _graph()
    assert len(edges) > 50  # the walk saw the package
    assert _cycles(edges) == []


def test_nothing_imports_the_front_door() -> None:
    """``vrelab/__init__`` imports every verb lazily; a module importing it (``from vrelab import
    __version__``) would close a loop through it, so the version lives in ``vrelab._version``."""
    edges, _ = _graph()
    assert [m for m, deps in edges.items() if PACKAGE in deps] == []


def test_no_private_name_imported_across_modules() -> None:
    _, private = _graph()
    assert private == []


def test_each_module_imports_alone_in_a_fresh_interpreter() -> None:
    """One interpreter imports every module, each in a fresh ``sys.modules`` state for the
    package (removed before the next), so a module that needs another imported first fails.

    Each re-import runs the module's body afresh; only its compiled code is kept, in memory, as a
    ``.pyc`` would keep it: with PYTHONDONTWRITEBYTECODE set (as where the suite runs) each of
    the ~2800 imports of a package module compiled its source again, ~5 s of the ~17 s."""
    names = sorted(m for m in _modules() if not m.endswith("__main__"))
    code = (
        "import importlib, importlib.machinery, sys\n"
        "compiled = {}\n"
        "get_code = importlib.machinery.SourceFileLoader.get_code\n"
        "def cached(self, fullname):\n"
        "    if self.path not in compiled:\n"
        "        compiled[self.path] = get_code(self, fullname)\n"
        "    return compiled[self.path]\n"
        "importlib.machinery.SourceFileLoader.get_code = cached\n"
        f"names = {names!r}\n"
        "bad = []\n"
        "for n in names:\n"
        "    for k in [k for k in sys.modules if k == 'vrelab' or k.startswith('vrelab.')]:\n"
        "        del sys.modules[k]\n"
        "    try:\n"
        "        importlib.import_module(n)\n"
        "    except Exception as e:\n"
        "        bad.append(f'{n}: {type(e).__name__}: {e}')\n"
        "print('\\n'.join(bad))\n"
        "sys.exit(1 if bad else 0)\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr


def test_the_simulation_does_not_import_the_analysis() -> None:
    """Data flow one way: a simulated record goes to the analysis, never the reverse; the
    timing both need (settling, window) lives in the record module below both."""
    edges, _ = _graph()
    sim = {m: sorted(d for d in deps if d.startswith("vrelab.analysis"))
           for m, deps in edges.items() if m.startswith("vrelab.simulation")}
    assert sim and all(v == [] for v in sim.values()), sim


def _package_graph() -> dict[str, set[str]]:
    """Top-level package (or module) of ``vrelab`` -> those its modules import (``vrelab.simulation.plan``
    counts as ``vrelab.simulation``), at any depth as :func:`_graph` reads them: a function-level
    import is a dependency all the same, it only runs later. The front door ``vrelab/__init__``
    (which imports every verb lazily) is left out."""
    mods = _modules()

    def top(name: str) -> str:
        return ".".join(name.split(".")[:2])

    edges: dict[str, set[str]] = {}
    for m, (path, is_pkg) in mods.items():
        if m == PACKAGE:
            continue
        pkg = m if is_pkg else m.rsplit(".", 1)[0]
        deps = edges.setdefault(top(m), set())
        for node in _imports(_tree(path)):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                if node.level:
                    base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
                    targets = [".".join(base + ([node.module] if node.module else []))]
                else:
                    targets = [node.module or ""]
                if targets[0] == PACKAGE:  # from vrelab import shaker: the module named
                    targets = [f"{PACKAGE}.{a.name}" for a in node.names]
            deps.update(top(t) for t in targets if t.split(".")[0] == PACKAGE and top(t) != top(m))
    return edges


def test_no_package_cycles() -> None:
    """Issue 31: the simulator's package imported the shaker and the triaxial test (through the
    example-campaign generator, now ``vrelab.example_campaign``) while they imported it."""
    edges = _package_graph()
    assert {"vrelab.simulation", "vrelab.shaker", "vrelab.analysis"} <= set(edges)  # the walk saw the packages
    assert _cycles(edges) == []

"""Package layout: no import cycles, imports point down the layers, modules stay short.

The import graph is built statically with :mod:`ast` from every ``.py`` file under
``escfit/``: module-level and function-level imports, relative ones resolved, ``from X import
name`` counted as an edge to ``X.name`` when that is a module and to ``X`` otherwise.  Imports
guarded by ``if TYPE_CHECKING:`` never run, so the layering check ignores them; the cycle check
counts them (:data:`FULL_GRAPH`): a cycle hidden behind TYPE_CHECKING is still two modules that
each need the other, and a reader of either must hold both in mind.  Importing a module runs its
packages' ``__init__`` too, but that implicit step is not an edge: only what a file names is.
Dynamic imports (``importlib.import_module`` of the family registry's entry paths) are not seen.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "escfit"
PACKAGE = "escfit"

# Lowest first.  An import may go to the same or a lower layer; the model families share a layer
# but must not import each other.  The top-level escfit/__init__.py (the public facade) is exempt.
# results (the schema every layer may read or write) stands on core only
# The model families' layer is the packages of the registered built-in families (escfit.core.family).
def _family_packages() -> tuple[str, ...]:
    from escfit.core.family import BUILTIN_FAMILIES

    return tuple(sorted({entry.split(":")[0].split(".")[1] for entry in BUILTIN_FAMILIES.values()}))


LAYERS = [("core",), ("analysis",), ("results",), ("likelihood",), _family_packages(), ("inference",),
          ("report",), ("study",), ("cli",), ("__main__",)]
FACADE = PACKAGE

# Layering violations present when this test was written, (importer, imported) module names.  Remove
# an entry when the redesign removes the import; a violation not listed here fails the test.
KNOWN_VIOLATIONS: set[tuple[str, str]] = set()  # add (importer, imported) only with a reason beside it

# Modules longer than MAX_LINES when this test was written (the style guide's limit).
MAX_LINES = 600
KNOWN_LONG: set[str] = set()


# -- the graph ---------------------------------------------------------------------------------
def _modules() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the package (packages by their __init__)."""
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        if "__pycache__" in parts:
            continue
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or \
        (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST, type_checking: bool = False):
    """Import and ImportFrom nodes anywhere in ``tree``; under ``if TYPE_CHECKING:`` only when
    ``type_checking``."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
            continue
        if isinstance(node, ast.If) and _is_type_checking(node.test) and not type_checking:
            stack.extend(node.orelse)  # the else branch does run
            continue
        stack.extend(ast.iter_child_nodes(node))


def _known(name: str) -> str | None:
    """``name`` if it is a module of the package, else its longest prefix that is (None: external)."""
    parts = name.split(".")
    while parts:
        candidate = ".".join(parts)
        if candidate in MODULES:
            return candidate
        parts.pop()
    return None


def _edges_of(module: str, path: Path, type_checking: bool = False) -> set[str]:
    """Modules of the package that ``module`` imports (with ``type_checking``: also under
    ``if TYPE_CHECKING:``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    is_pkg = path.name == "__init__.py"
    here = module.split(".") if is_pkg else module.split(".")[:-1]  # the package relative imports start from
    out = set()
    for node in _imports(tree, type_checking):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        else:
            if node.level:
                base = here[: len(here) - (node.level - 1)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            targets = []
            for alias in node.names:
                sub = f"{source}.{alias.name}"
                targets.append(sub if sub in MODULES else source)
        for target in targets:
            known = _known(target)
            if known is not None and known != module:
                out.add(known)
    return out


def import_graph(type_checking: bool = False) -> dict[str, set[str]]:
    """Module -> the package's modules it imports (``type_checking``: also those imported only
    for type annotations)."""
    return {m: _edges_of(m, p, type_checking) for m, p in MODULES.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle as a path ``[a, b, ..., a]``, or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []
    for start in sorted(graph):
        if start in state:
            continue
        stack = [(start, iter(sorted(graph[start])))]
        state[start] = 1
        path.append(start)
        while stack:
            node, children = stack[-1]
            for child in children:
                if state.get(child) == 1:
                    return path[path.index(child):] + [child]
                if child not in state:
                    state[child] = 1
                    path.append(child)
                    stack.append((child, iter(sorted(graph.get(child, ())))))
                    break
            else:
                stack.pop()
                path.pop()
                state[node] = 2
    return None


def _layer_of(module: str) -> tuple[int, str] | None:
    """(layer index, top-level part) of a module; None for the facade."""
    parts = module.split(".")
    if len(parts) == 1:
        return None
    top = parts[1]
    for i, group in enumerate(LAYERS):
        if top in group:
            return i, top
    raise AssertionError(f"{module}: escfit.{top} is in no layer of LAYERS; add it")


def layering_violations(graph: dict[str, set[str]]) -> set[tuple[str, str]]:
    """Edges that go up a layer, across model families, or to the facade."""
    bad = set()
    for src, targets in graph.items():
        if src == FACADE:
            continue
        s_layer, s_top = _layer_of(src)
        for dst in targets:
            d = _layer_of(dst)
            if d is None:  # the facade sits above every layer
                bad.add((src, dst))
                continue
            d_layer, d_top = d
            if d_layer > s_layer or (d_layer == s_layer and len(LAYERS[s_layer]) > 1 and d_top != s_top):
                bad.add((src, dst))
    return bad


GRAPH = import_graph()
FULL_GRAPH = import_graph(type_checking=True)


# -- tests -------------------------------------------------------------------------------------
def test_graph_is_built():
    assert f"{PACKAGE}.core.errors" in MODULES
    assert any(GRAPH.values()), "no import edges found: the graph builder is broken"
    # a from-import of a module is an edge to that module
    assert f"{PACKAGE}.analysis.recordings.unit_curve" in GRAPH[f"{PACKAGE}.analysis.recordings"]


def test_cycle_finder_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_type_checking_imports_are_seen():
    tree = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import a\nelse:\n    import b\n")
    names = lambda nodes: sorted(n.names[0].name for n in nodes if isinstance(n, ast.Import))  # noqa: E731
    assert names(_imports(tree)) == ["b"]
    assert names(_imports(tree, type_checking=True)) == ["a", "b"]


def test_no_import_cycles():
    cycle = find_cycle(FULL_GRAPH)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_imports_point_down_the_layers():
    found = layering_violations(GRAPH)
    new = sorted(found - KNOWN_VIOLATIONS)
    assert not new, "imports against the layering (importer -> imported; fix them, do not list them):\n" + \
        "\n".join(f"  {a} -> {b}" for a, b in new)


def test_known_violations_are_still_current():
    gone = sorted(KNOWN_VIOLATIONS - layering_violations(GRAPH))
    assert not gone, "no longer violations, remove from KNOWN_VIOLATIONS:\n" + "\n".join(f"  {a} -> {b}" for a, b in gone)


def test_module_length():
    lengths = {m: len(p.read_text(encoding="utf-8").splitlines()) for m, p in MODULES.items()}
    long = {m for m, n in lengths.items() if n > MAX_LINES}
    new = sorted(long - KNOWN_LONG)
    assert not new, f"modules over the style guide's {MAX_LINES} lines: " + ", ".join(f"{m} ({lengths[m]})" for m in new)
    shorter = sorted((KNOWN_LONG & set(MODULES)) - long)
    assert not shorter, f"down to {MAX_LINES} lines or fewer, remove from KNOWN_LONG: {shorter}"


def _compares_family_name(tree: ast.AST, names: set[str]) -> list[int]:
    """Lines of comparisons with a family's name (``model == "balance"``, ``model in ("verge", ...)``)."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            for side in (node.left, *node.comparators):
                consts = side.elts if isinstance(side, (ast.Tuple, ast.List, ast.Set)) else [side]
                if any(isinstance(c, ast.Constant) and c.value in names for c in consts):
                    lines.append(node.lineno)
    return lines


def test_layers_above_the_families_never_branch_on_a_family_name():
    """The command line, reports, batch code and inference ask the family (escfit.core.family)."""
    from escfit.core.family import BUILTIN_FAMILIES

    names = set(BUILTIN_FAMILIES)
    above = {group for layer in LAYERS[LAYERS.index(_family_packages()) + 1:] for group in layer}
    found = [f"{m}:{line}" for m, p in MODULES.items() if len(m.split(".")) > 1 and m.split(".")[1] in above
             for line in _compares_family_name(ast.parse(p.read_text(encoding="utf-8")), names)]
    assert not found, "comparisons with a family's name (ask the family instead): " + ", ".join(found)
    assert _compares_family_name(ast.parse('if m == "balance": pass'), names), "the check finds nothing"


def test_every_long_test_named_exists():
    """Each key of the long tests' list (tests/conftest.py) names a test function of its file, so that
    a renamed test does not silently fall back into the default run."""
    import re

    from .conftest import LONG

    tests = ROOT.parent / "tests"
    for key in sorted(LONG):
        file, _, name = key.partition("::")
        function = name.split("[")[0]
        text = (tests / file).read_text()
        assert re.search(rf"^def {re.escape(function)}\(", text, re.M), f"{key}: no such test"

"""The import graph of the toolkit: no cycles, and dependencies that point one way.

Every ``import`` statement of ``onedim`` and ``thinfilm`` is read from the source (also those
inside functions, which run later but still tie two modules together), and:

* the graph of modules has no cycle;
* ``onedim`` imports nothing of ``thinfilm``;
* the shared core (``thinfilm.engine``, ``thinfilm.solvers`` and the generic modules at the
  top of ``thinfilm``) imports no model kind (``thinfilm.plate``, ``thinfilm.exact1d``): it
  finds them through :mod:`thinfilm.kinds` by name, so a new kind needs no change to it;
* the engine and the solvers import nothing of the generic layer above them (scenes,
  results, plots, the command line);
* the installed packages import nothing of ``examples`` or ``tests`` (neither is installed);
* no module of the tests imports a test module (``test_*.py``): what tests share lives in
  helper modules (``tests/helpers.py``, ``tests/fem3d/meshes.py``...), so a test file holds
  its own tests and what only they use.
"""

from __future__ import annotations

import ast

import pytest

from tests.helpers import ROOT

PACKAGES = ("onedim", "thinfilm", "fem3d")
KINDS = ("thinfilm.plate", "thinfilm.exact1d", "fem3d")


def module_name(path):
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules():
    """``{module name: path}`` of every module of the toolkit."""
    out = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            out[module_name(path)] = path
    return out


def absolute(node, name, is_package):
    """The absolute module an ``ast.ImportFrom`` of module ``name`` imports from (its relative
    form resolved against ``name``)."""
    base = node.module or ""
    if not node.level:
        return base
    anchor = name.split(".") if is_package else name.split(".")[:-1]
    anchor = anchor[: len(anchor) - (node.level - 1)]
    return ".".join(anchor + ([base] if base else []))


def imports(name, path, known):
    """The toolkit's modules that module ``name`` imports (anywhere in its source)."""
    is_package = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = absolute(node, name, is_package)
            # ``from package import module`` imports the module; ``from module import name``
            # the module itself.
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
        else:
            continue
        for target in targets:
            while target and target not in known:  # ``import a.b.c`` of a package's module
                target = target.rpartition(".")[0]
            if target and target != name:
                out.add(target)
    return out


@pytest.fixture(scope="module")
def graph():
    known = modules()
    return {name: imports(name, path, known) for name, path in known.items()}


def cycles(graph):
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_reader_finds_imports_and_a_cycle():
    # The checks below are only as good as the graph: a drawn cycle must be found.
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_the_graph_sees_the_known_edges(graph):
    assert "thinfilm.engine.options" in graph["thinfilm.engine.evolution"]
    assert "thinfilm.solvers.boxqp" in graph["thinfilm.engine.evolution"]
    assert "thinfilm.run" in graph["thinfilm.plate.kind"]
    assert "onedim.fragment" in graph["thinfilm.exact1d.scene"]


def test_no_import_cycles(graph):
    assert cycles(graph) == []


def test_onedim_stands_alone(graph):
    for name, targets in graph.items():
        if name.startswith("onedim"):
            assert not [t for t in targets if t.startswith("thinfilm")], name


def test_the_core_imports_no_model_kind(graph):
    for name, targets in graph.items():
        if name.startswith(("onedim",) + KINDS):
            continue
        assert not [t for t in targets if t.startswith(KINDS)], f"{name} imports a model kind"


def test_engine_and_solvers_sit_below_the_generic_layer(graph):
    for name, targets in graph.items():
        if name.startswith(("thinfilm.engine", "thinfilm.solvers")):
            above = [t for t in targets if not t.startswith(("thinfilm.engine", "thinfilm.solvers", "thinfilm.options"))
                     and t.startswith("thinfilm")]
            assert not above, f"{name} imports {above}"


def imported_names(source, name, is_package=False):
    """Every module name an ``import`` of ``source`` (the module ``name``) may load, absolute.

    ``import a.b`` gives ``a.b``; ``from a import b, c`` gives ``a``, ``a.b`` and ``a.c`` (``b``
    may be a module or a name of ``a``); relative imports are resolved against ``name``.
    """
    out = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = absolute(node, name, is_package)
            out.add(base)
            out.update(f"{base}.{alias.name}" for alias in node.names)
    return out


def test_the_import_reader_resolves_relative_and_from_imports():
    source = "import os.path\nfrom tests.fem3d import test_model\nfrom .checks import rel_diff\n"
    names = imported_names(source, "tests.fem3d.test_split")
    assert {"os.path", "tests.fem3d", "tests.fem3d.test_model", "tests.fem3d.checks.rel_diff"} <= names
    assert "tests.fem3d.checks" in names


def test_the_installed_packages_import_no_examples_and_no_tests():
    for name, path in modules().items():
        found = imported_names(path.read_text(encoding="utf-8"), name, path.name == "__init__.py")
        outside = sorted(t for t in found if t.split(".")[0] in ("examples", "tests"))
        assert not outside, f"{name} imports {outside}"


def test_no_test_module_imports_another():
    """Nor does a helper module or a conftest import a test module."""
    files = sorted((ROOT / "tests").rglob("*.py"))
    assert sum(path.name.startswith("test_") for path in files) > 20
    for path in files:
        name = module_name(path)
        found = imported_names(path.read_text(encoding="utf-8"), name, path.name == "__init__.py")
        others = sorted(t for t in found if t.startswith("tests.") and t.split(".")[-1].startswith("test_"))
        assert not others, f"{name} imports {others}: move what they share into a helper module"


#: Everything of the project's own whose private names no other module may use.
OWN = PACKAGES + ("examples", "tests", "benchmarks", "studies")


def is_module(dotted):
    """Whether ``dotted`` names a module or package of the repository."""
    path = ROOT.joinpath(*dotted.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def private_uses(source, name, is_package=False):
    """``(line, what)`` of each private name (``_x``, not dunder) that module ``name`` takes
    from another of the project's modules: ``from m import _x``, or ``m._x`` where ``m`` is a
    module it imported (``import a.b as m``, ``from a import m``)."""
    out, modules_ = [], {}
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in OWN:
                    modules_[alias.asname or alias.name.split(".")[0]] = alias.name
        elif isinstance(node, ast.ImportFrom):
            base = absolute(node, name, is_package)
            if base.split(".")[0] not in OWN or base == name:
                continue
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    out.append((node.lineno, f"from {base} import {alias.name}"))
                elif is_module(f"{base}.{alias.name}"):  # its attributes are checked below
                    modules_[alias.asname or alias.name] = f"{base}.{alias.name}"
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in modules_
                and node.attr.startswith("_") and not node.attr.startswith("__")):
            out.append((node.lineno, f"{modules_[node.value.id]}.{node.attr}"))
    return out


def test_the_private_name_reader_finds_both_forms():
    source = ("from fem3d.mesh import _x, y\nimport thinfilm.solvers.kernels as k\nfrom thinfilm.solvers import boxqp\n"
              "k._prepare()\nboxqp._ARMIJO\nself._z\nfrom os import _exit\n")
    assert sorted(what for _, what in private_uses(source, "fem3d.kind")) == [
        "from fem3d.mesh import _x", "thinfilm.solvers.boxqp._ARMIJO", "thinfilm.solvers.kernels._prepare"]


def test_no_module_uses_a_private_name_of_another():
    roots = [ROOT / part for part in OWN if (ROOT / part).is_dir()]
    files = sorted(path for root in roots for path in root.rglob("*.py"))
    assert len(files) > 100
    found = []
    for path in files:
        name = module_name(path)
        found += [f"{path.relative_to(ROOT)}:{line}: {what}"
                  for line, what in private_uses(path.read_text(encoding="utf-8"), name, path.name == "__init__.py")]
    assert not found, "\n".join(found)

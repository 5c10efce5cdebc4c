"""The package itself: lazy root, every public name loads, no import cycles, no leftovers of staged
development (feature flags, skips, broad excepts, issue-tracker wording), tests that never skip."""

import ast
import pathlib
import re
import subprocess
import sys

import pytest
import subsurf

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGE = pathlib.Path(subsurf.__file__).resolve().parent
SOURCES = sorted(PACKAGE.rglob("*.py"))
TESTS = sorted((ROOT / "tests").glob("*.py"))


def module_name(path: pathlib.Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def nodes(path):
    """(node, enclosing top-level function name) for every AST node of a file."""
    tree = ast.parse(path.read_text(), str(path))
    for top in tree.body:
        owner = top.name if isinstance(top, (ast.FunctionDef, ast.ClassDef)) else None
        for node in ast.walk(top):
            yield node, owner


def test_import_is_lazy_and_every_public_name_loads():
    code = "import sys, subsurf; print(sorted(m for m in ('numpy', 'subsurf._core', 'h5py') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    for name in subsurf.__all__ + list(subsurf._EXPORTS) + list(subsurf._SUBMODULES):
        assert getattr(subsurf, name) is not None, name
    assert subsurf.Layer is subsurf.medium.Layer and subsurf.save is subsurf.io.save
    assert set(subsurf.__all__) <= set(dir(subsurf))
    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        subsurf.simulat  # noqa: B018


def test_every_module_imports():
    """A broken module fails here, by name (nothing is imported conditionally)."""
    import importlib

    for path in SOURCES:
        importlib.import_module(module_name(path))


def imports_of(path, known) -> set[str]:
    """The subsurf modules a module imports (anywhere in it, functions included)."""
    me = module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out = set()
    for node, _ in nodes(path):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("subsurf")}
        elif isinstance(node, ast.ImportFrom):
            base = package
            for _ in range(node.level - 1):
                base = base.rpartition(".")[0]
            mod = (base + ("." + node.module if node.module else "")) if node.level else (node.module or "")
            if mod.startswith("subsurf"):
                # `from . import x` imports the submodule x; `from .m import f` imports m
                out |= {f"{mod}.{a.name}" if f"{mod}.{a.name}" in known else mod for a in node.names}
    return out


#: Lazy hooks into optional extras, left out of the cycle check: ``simulate(client=...)`` hands the run to
#: ``subsurf.cluster`` (Dask, imported only then), whose worker tasks call back ``simulate_range``.
# Function-level imports that would close a cycle at module level: mc -> cluster (the Dask hook);
# adaptive_table.profile -> bssrdf.Profile (bssrdf re-exports AdaptiveTable).
LAZY_HOOKS = {("subsurf.mc", "subsurf.cluster"), ("subsurf.adaptive_table", "subsurf.bssrdf")}


def test_no_import_cycles_and_no_imports_of_the_package_root():
    known = {module_name(p): p for p in SOURCES} | {"subsurf._core": PACKAGE / "_core.pyi"}  # the extension
    graph = {
        m: {d for d in imports_of(p, known) if d in known and d != m and (m, d) not in LAZY_HOOKS}
        for m, p in known.items()
        if m != "subsurf"
    }
    for m, deps in graph.items():
        assert "subsurf" not in deps, f"{m} imports the package root"
    # depth-first search for a cycle
    state = {}

    def visit(m, stack):
        state[m] = "open"
        for d in graph.get(m, ()):
            if state.get(d) == "open":
                pytest.fail("import cycle: " + " -> ".join(stack[stack.index(d) :] + [d]))
            if d not in state:
                visit(d, stack + [d])
        state[m] = "done"

    for m in graph:
        if m not in state:
            visit(m, [m])


def try_body(tree, handler):
    """The statements of the ``try`` a handler belongs to."""
    for t in ast.walk(tree):
        if isinstance(t, ast.Try) and handler in t.handlers:
            return [n for stmt in t.body for n in ast.walk(stmt)]
    return []


def _imports_subsurf(node) -> bool:
    if isinstance(node, ast.Import):
        return any(a.name.startswith("subsurf") for a in node.names)
    return isinstance(node, ast.ImportFrom) and (node.level > 0 or (node.module or "").startswith("subsurf"))


def test_no_package_root_imports_or_broad_excepts_in_the_package():
    """No ``import subsurf`` inside the package, no handler that swallows every error without a stated
    reason, no ``except ImportError`` around the package's own imports (optional third-party packages
    may be missing: saying how to install them is fine)."""
    bad = []
    for path in SOURCES:
        rel = path.relative_to(PACKAGE)
        lines = path.read_text().splitlines()
        tree = ast.parse(path.read_text())
        for node, _ in nodes(path):
            where = f"{rel}:{getattr(node, 'lineno', '?')}"
            if isinstance(node, ast.Import) and any(a.name == "subsurf" for a in node.names):
                bad.append(f"{where}: import subsurf")
            if isinstance(node, ast.ImportFrom) and (node.module == "subsurf" or (node.level and not node.module)):
                names = {a.name for a in node.names}
                if node.module == "subsurf" or "__version__" in names:
                    bad.append(f"{where}: from {'.' * node.level}{node.module or ''} import {sorted(names)}")
            if isinstance(node, ast.ExceptHandler):
                caught = ast.unparse(node.type) if node.type else "everything"
                raises = any(isinstance(n, ast.Raise) for n in ast.walk(node))
                justified = "noqa: BLE001 -" in lines[node.lineno - 1]  # a stated reason to swallow anything
                if caught in ("everything", "Exception", "BaseException") and not (raises or justified):
                    bad.append(f"{where}: except {caught} swallows every error")
                if "ImportError" in caught and any(_imports_subsurf(n) for n in try_body(tree, node)):
                    bad.append(f"{where}: except ImportError around a subsurf import (a runtime feature check)")
            if isinstance(node, ast.Name) and node.id.startswith("HAS_"):
                bad.append(f"{where}: feature flag {node.id}")
    assert bad == []


ISSUE_WORDING = re.compile(r"\b" + "iss" + r"ues? ?\d+\b|\(" + "iss" + "ue:", re.IGNORECASE)


def test_tests_never_skip_and_never_import_each_other():
    bad = []
    for path in TESTS:
        text = path.read_text()
        for word in ("importorskip", "pytest.skip", "skipif", "sys.path", "HAS_"):
            if word in text and path.name != "test_package.py":
                bad.append(f"{path.name}: {word}")
        for node, _ in nodes(path):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
                bad += [f"{path.name}: imports {n}" for n in names if n.startswith(("test_", "conftest"))]
    assert bad == []


def test_no_issue_tracker_wording():
    files = SOURCES + TESTS + sorted((ROOT / "benches").glob("*")) + sorted((ROOT / "docs").rglob("*.md"))
    files += [ROOT / "README.md", *sorted((ROOT / "docs" / "scripts").glob("*.py"))]
    bad = [
        f"{p.relative_to(ROOT)}:{i}: {line.strip()}"
        for p in files
        if p.is_file()
        for i, line in enumerate(p.read_text().splitlines(), 1)
        if ISSUE_WORDING.search(line)
    ]
    assert bad == []

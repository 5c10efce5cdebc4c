"""``subsurf/_core.pyi`` stays true to the extension: every public name of ``subsurf._core`` is in the
stub and every stub name is in the module, functions with the same parameters (names, order and
which have defaults). Whoever changes a binding without its stub gets a failing test naming it."""

import ast
import inspect
import pathlib

import subsurf
from subsurf import _core

STUB = pathlib.Path(subsurf.__file__).with_name("_core.pyi")


def stub_api(text: str) -> dict:
    """Public names of a stub → their parameters [(name, has default)] (functions) or None."""
    api = {}
    for node in ast.parse(text).body:
        if isinstance(node, ast.FunctionDef):
            a = node.args
            pos = a.posonlyargs + a.args
            defaults = [False] * (len(pos) - len(a.defaults)) + [True] * len(a.defaults)
            params = [(p.arg, d) for p, d in zip(pos, defaults)]
            params += [(p.arg, d is not None) for p, d in zip(a.kwonlyargs, a.kw_defaults)]
            api[node.name] = params
        elif isinstance(node, ast.ClassDef):
            api[node.name] = None
        elif isinstance(node, ast.AnnAssign):  # a module attribute (a plain assignment is a type alias)
            api[node.target.id] = None
    return {k: v for k, v in api.items() if not k.startswith("_") or k == "__version__"}


def module_api(module) -> dict:
    api = {}
    for name in dir(module):
        if name.startswith("_") and name != "__version__":
            continue
        obj = getattr(module, name)
        if callable(obj) and not isinstance(obj, type):
            sig = inspect.signature(obj)
            api[name] = [(p.name, p.default is not inspect.Parameter.empty) for p in sig.parameters.values()]
        else:
            api[name] = None
    return api


def differences(stub: dict, module: dict) -> list[str]:
    out = [f"{n}: in _core but not in _core.pyi" for n in sorted(set(module) - set(stub))]
    out += [f"{n}: in _core.pyi but not in _core" for n in sorted(set(stub) - set(module))]
    out += [
        f"{n}: parameters {module[n]} in _core, {stub[n]} in _core.pyi"
        for n in sorted(set(stub) & set(module))
        if stub[n] != module[n]
    ]
    return out


def test_stub_matches_the_extension():
    stub, module = stub_api(STUB.read_text()), module_api(_core)
    assert len(module) > 40 and "mc_run" in stub
    assert differences(stub, module) == []


def test_a_stale_stub_is_caught():
    text = STUB.read_text()
    module = module_api(_core)
    missing = text.replace("def gamma_q(", "def gamma_q_renamed(")
    assert "gamma_q: in _core but not in _core.pyi" in differences(stub_api(missing), module)
    renamed = text.replace("def beer_lambert_v(mu_t: F64,", "def beer_lambert_v(sigma_t: F64,")
    assert any(d.startswith("beer_lambert_v: parameters") for d in differences(stub_api(renamed), module))

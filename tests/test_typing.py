"""The typed API: the py.typed marker ships, and the _core.pyi stub matches the compiled module."""

import ast
import importlib.resources
import inspect
from pathlib import Path

import pytest

import dynval

STUB = Path(dynval.__file__).with_name("_core.pyi")


def test_py_typed_marker_is_installed():
    assert (importlib.resources.files("dynval") / "py.typed").is_file()
    assert (importlib.resources.files("dynval") / "_core.pyi").is_file()


def _stub_functions(body):
    return {node.name: node for node in body if isinstance(node, ast.FunctionDef)}


def _stub_tree():
    return ast.parse(STUB.read_text(encoding="utf-8"))


def _stub_public_names(tree):
    names = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.Assign):
            names.update(t.id for t in node.targets if isinstance(t, ast.Name))
    return {n for n in names if not n.startswith("_") or (n.startswith("__") and n.endswith("__"))}


def _argument_names(function_node):
    args = function_node.args
    return [a.arg for a in args.posonlyargs + args.args + args.kwonlyargs if a.arg != "self"]


def _runtime_argument_names(function):
    """Parameter names from pybind11's signature line, ``name(a: T, b: U) -> R``."""
    first_line = function.__doc__.strip().splitlines()[0]
    node = ast.parse(f"def {first_line}: ...").body[0]
    return _argument_names(node)


@pytest.fixture(scope="module")
def core():
    return pytest.importorskip("dynval._core", reason="the compiled backend dynval._core is not available")


MODULE_DUNDERS = {"__doc__", "__file__", "__loader__", "__name__", "__package__", "__spec__"}


def test_stub_declares_exactly_the_public_names_of_the_module(core):
    runtime = {n for n in dir(core) if not n.startswith("_") or n == "__version__"}
    stub = _stub_public_names(_stub_tree()) - MODULE_DUNDERS
    assert stub == runtime


def test_stub_argument_names_match_the_bindings(core):
    functions = _stub_functions(_stub_tree().body)
    public = [n for n in dir(core) if not n.startswith("_") and inspect.isbuiltin(getattr(core, n))]
    assert public
    for name in public:
        assert _argument_names(functions[name]) == _runtime_argument_names(getattr(core, name)), name


def test_stub_testing_protocol_matches_the_submodule(core):
    tree = _stub_tree()
    protocol = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "_TestingModule")
    declared = _stub_functions(protocol.body)
    runtime = [n for n in dir(core._testing) if not n.startswith("_")]
    assert set(declared) == set(runtime)
    for name in runtime:
        assert _argument_names(declared[name]) == _runtime_argument_names(getattr(core._testing, name)), name


def _public_callables():
    """Every public function and public method of the typed API (mypy checks them; this says none is left out)."""
    import dynval.cli
    import dynval.stream

    modules = [(dynval, dynval.__all__), (dynval.stream, dynval.stream.__all__)]
    try:
        import dynval.dask
    except ImportError:  # dask is an optional extra
        pass
    else:
        modules.append((dynval.dask, dynval.dask.__all__))
    out = [("dynval.cli.main", dynval.cli.main)]
    for module, names in modules:
        for name in names:
            obj = getattr(module, name)
            if inspect.isfunction(obj):
                out.append((f"{module.__name__}.{name}", obj))
            elif inspect.isclass(obj) and obj.__module__.startswith("dynval"):
                for attr, member in vars(obj).items():
                    if attr.startswith("_") and attr != "__init__":
                        continue
                    if isinstance(member, property):
                        member = member.fget
                    if inspect.isfunction(member):
                        out.append((f"{module.__name__}.{name}.{attr}", member))
    return out


@pytest.mark.parametrize(("name", "function"), _public_callables(), ids=lambda x: x if isinstance(x, str) else "")
def test_public_functions_are_annotated(name, function):
    signature = inspect.signature(function)
    missing = [p.name for p in signature.parameters.values()
               if p.name not in ("self", "cls") and p.annotation is inspect.Parameter.empty]
    assert not missing, f"{name}: parameters without a type annotation: {missing}"
    assert signature.return_annotation is not inspect.Signature.empty, f"{name}: no return annotation"

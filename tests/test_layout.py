"""The package's shape (docs/architecture.md): small functions, and no import circles."""

from __future__ import annotations

import ast
import pathlib

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "python" / "dynval"
MAX_LINES = 100


def _modules() -> dict[str, ast.Module]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = ast.parse(path.read_text(encoding="utf-8"))
    return out


def _code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines from the first statement after the docstring to the end of the function."""
    body = node.body
    first = body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
        if len(body) == 1:
            return 0
        first = body[1]
    return int(node.end_lineno or first.lineno) - first.lineno + 1


def test_no_function_is_over_a_hundred_lines():
    long = [(f"{name}.{node.name}", _code_lines(node))
            for name, tree in _modules().items() for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _code_lines(node) > MAX_LINES]
    assert long == []


def _imports(name: str, tree: ast.Module, known: set[str]) -> set[str]:
    """The package's modules that ``name`` imports, at its top or inside a function."""
    package = name if name in known and _is_package(name) else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package.split(".")
            base = base[:len(base) - (node.level - 1)]
            target = ".".join(base + ([node.module] if node.module else []))
            # ``from . import _x`` names submodules; ``from . import name`` (a name the package
            # defines) is the package itself
            subs = [f"{target}.{a.name}" for a in node.names if a.name != "_core"]  # the compiled core
            if (node.module or not all(c in known for c in subs)) and target in known:
                found.add(target)
            found.update(c for c in subs if c in known)
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("dynval"):
            found.update(c for c in [node.module] + [f"{node.module}.{a.name}" for a in node.names] if c in known)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name in known)
    found.discard(name)
    return found


def _is_package(name: str) -> bool:
    return (PACKAGE.parent / pathlib.Path(*name.split(".")) / "__init__.py").exists()


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every circle a depth-first walk of ``graph`` meets (each as the path that closes it)."""
    colour: dict[str, int] = {}
    circles: list[list[str]] = []

    def visit(n: str, path: list[str]) -> None:
        colour[n] = 1
        for d in sorted(graph.get(n, ())):
            if colour.get(d) == 1:
                circles.append(path[path.index(d):] + [d] if d in path else [n, d])
            elif d not in colour:
                visit(d, path + [d])
        colour[n] = 2

    for n in sorted(graph):
        if n not in colour:
            visit(n, [n])
    return circles


def test_no_import_circles():
    """Following every import inside the package (lazy ones too) never leads back to the start;
    the package root is imported by nobody inside it but the entry points of the apps layer."""
    modules = _modules()
    known = set(modules)
    graph = {name: _imports(name, tree, known) for name, tree in modules.items()}
    # the calibration scenarios and the corpus drivers call the public API as a user does, by design
    roots_allowed = {"dynval.scenarios", "dynval.golden._ops"}
    importing_root = sorted(n for n, deps in graph.items() if "dynval" in deps and n not in roots_allowed)
    assert importing_root == []
    graph = {n: deps - {"dynval"} for n, deps in graph.items() if n != "dynval"}
    assert _circles(graph) == []


# The layers of docs/architecture.md, bottom first: a package (or a top-level module) imports only
# from its own layer and the layers below it, lazy imports included. The apps and robotics modules
# at the top may import one another (no circles: test_no_import_circles).
LAYERS = (
    ("_version", "_lazy", "_environ", "_startup", "checks"),
    ("kernels",),
    ("statistics",),
    ("metrics",),
    ("report",),
    ("comparison",),
)


def _package_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "dynval"


def _layer(package: str) -> int:
    """The package's layer: its index in LAYERS, or one above them all (the public modules)."""
    return next((i for i, names in enumerate(LAYERS) if package in names), len(LAYERS))


def test_packages_import_only_their_own_layer_and_those_below():
    """Kills: the settings' checker back in checks/ (it imports kernels, metrics, report and
    statistics), a statistic that reads report/'s column algebra or JSON converter, a record's
    notebook view importing dynval.html: each an arrow up a layer, a package-level circle."""
    modules = _modules()
    known = set(modules)
    up = sorted({(_package_of(n), _package_of(d)) for n, tree in modules.items() for d in _imports(n, tree, known)
                 if _layer(_package_of(d)) > _layer(_package_of(n))})
    assert up == []


def test_no_package_level_circles():
    """The packages' graph (every import, lazy ones too, folded onto its package) has no circle
    among the internal layers and the public modules below the package root."""
    modules = _modules()
    known = set(modules)
    graph: dict[str, set[str]] = {}
    for n, tree in modules.items():
        for d in _imports(n, tree, known):
            a, b = _package_of(n), _package_of(d)
            if a != b and "dynval" not in (a, b):
                graph.setdefault(a, set()).add(b)
    assert _circles(graph) == []


def _cross_package_private_names() -> list[tuple[str, str, str]]:
    """(module, imported from, name) for every underscore name (not a module: the private modules
    are each package's internal API) a module imports from another package."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        own = rel.parts[0] if len(rel.parts) > 1 else None
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.level):
                continue
            base = list(rel.parts[:-1])
            base = base[:len(base) - (node.level - 1)]
            target = base + (node.module.split(".") if node.module else [])
            theirs = target[0] if target and (PACKAGE / target[0]).is_dir() else None
            if theirs == own:
                continue
            for alias in node.names:
                module = PACKAGE.joinpath(*target, alias.name)
                if alias.name.startswith("_") and alias.name not in ("__version__", "_core") \
                        and not module.is_dir() and not module.with_suffix(".py").exists():
                    out.append((str(rel), ".".join(target), alias.name))
    return out


def test_no_private_name_is_imported_across_packages():
    """Kills: a helper of another package's private module reached by its underscore name (the
    column norms, a file opener, a stream's snapshot) instead of a name that says it is shared."""
    assert _cross_package_private_names() == []


def test_no_module_of_report_or_comparison_is_in_the_lenient_typing_tier():
    # report/ and comparison/ are mypy strict (issue 35): a module named in pyproject's lenient tier
    # would be checked without strict None checks and with untyped functions allowed
    import tomllib

    config = tomllib.loads((PACKAGE.parents[1] / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["mypy"]
    lenient = [o for o in config["overrides"] if o.get("disallow_untyped_defs") is False]
    assert lenient, "the lenient tier is where this test looks"
    named = [m for o in lenient for m in o["module"]
             if m.startswith(("dynval.report", "dynval.comparison"))]
    assert named == []
    assert not [m for m in config["untyped_calls_exclude"] if m.startswith(("dynval.report", "dynval.comparison"))]

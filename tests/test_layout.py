"""The package keeps the shape docs/architecture.md draws.

Read from the source text (no import): every ``from .x import`` and ``from ..x import``
is an edge of the import graph. The layering holds for every import, deferred ones
inside functions included; cycles are looked for among the imports that run when a
module is loaded (a deferred import is how the discrete and continuous models reach
each other without a cycle at import time).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import moli

PACKAGE = Path(moli.__file__).resolve().parent
REPO = PACKAGE.parents[1]
# Pipeline order: a module may import its own layer and the layers before it.
LAYERS = ("errors", "numerics", "data", "models", "validation", "method", "streaming", "fleets", "systems", "control",
          "app")
# The method's stages in the order docs/method.md takes them: a stage may import its own
# package and the stages before it. options/ comes after the stages whose choices it lists
# and before those that read it; pipeline/ holds identify()'s steps, which call them all;
# the modules at method/'s root (identification, result) sit above every stage.
METHOD_STAGES = ("structure", "least_squares", "tuning", "options", "search", "refinement", "closed_loop",
                 "uncertainty", "selection", "kernel", "continuous", "frequency", "pipeline")
# method/'s root holds only the entry point, its result and the package's names.
METHOD_ROOT = {"__init__", "identification", "result"}
# About a screen or two per module.
MAX_LINES = 400


def _modules() -> dict[str, Path]:
    return {
        ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts): path
        for path in PACKAGE.rglob("*.py")
    }


def _load_time(tree: ast.Module) -> list[ast.AST]:
    """The statements that run when the module is imported (not inside functions or TYPE_CHECKING)."""
    out, todo = [], list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            continue
        out.append(node)
        todo.extend(ast.iter_child_nodes(node))
    return out


def _imports(name: str, path: Path, load_time: bool = False) -> set[str]:
    """The moli modules ``name`` imports (package ``__init__`` imports resolve to the package)."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()
    tree = ast.parse(path.read_text())
    for node in (_load_time(tree) if load_time else ast.walk(tree)):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package[: len(package) - node.level + 1]
            target = ".".join(base + ([node.module] if node.module else []))
            found |= {f"{target}.{alias.name}" for alias in node.names} | {target}
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("moli"):
            found.add(node.module)
    return found


def _graph(load_time: bool = False) -> dict[str, set[str]]:
    modules = _modules()
    known = {name.removesuffix(".__init__") for name in modules}
    return {
        name.removesuffix(".__init__"): {t for t in _imports(name, path, load_time) if t in known}
        for name, path in modules.items()
    }


def _layer(module: str) -> int | None:
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else None


def test_no_import_cycle():
    graph = _graph(load_time=True)
    state: dict[str, int] = {}

    def visit(node: str, trail: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if nxt == node or nxt == "moli":
                continue
            if state.get(nxt) == 1:
                pytest.fail("import cycle: " + " -> ".join(trail[trail.index(nxt):] + [nxt]))
            if nxt not in state:
                visit(nxt, trail + [nxt])
        state[node] = 2

    for start in sorted(graph):
        if start not in state:
            visit(start, [start])


def test_no_module_imports_up_the_pipeline():
    wrong = [
        f"{src} imports {dst}"
        for src, targets in _graph().items()
        for dst in targets
        if _layer(src) is not None and _layer(dst) is not None and _layer(dst) > _layer(src)
    ]
    assert not wrong, "\n".join(wrong)


def _stage(module: str) -> int | None:
    """The position of a module's stage inside method/ (the root modules above every stage)."""
    parts = module.split(".")
    if len(parts) < 3 or parts[1] != "method":
        return None
    return METHOD_STAGES.index(parts[2]) if parts[2] in METHOD_STAGES else len(METHOD_STAGES)


def test_method_is_stage_packages_in_pipeline_order():
    method = PACKAGE / "method"
    root = {path.stem for path in method.glob("*.py")}
    assert root == METHOD_ROOT, "method/ holds stage packages; a new module goes into the stage it belongs to"
    packages = {path.name for path in method.iterdir() if (path / "__init__.py").exists()}
    assert packages == set(METHOD_STAGES)
    wrong = [f"{src} imports {dst}" for src, targets in _graph().items() for dst in targets
             if _stage(src) is not None and _stage(dst) is not None and _stage(dst) > _stage(src)]
    assert not wrong, "\n".join(wrong)


def _private_imports() -> list[str]:
    """Imports of a private name (``_x``) of another moli module, in the package's source."""
    found = []
    for name, path in _modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").startswith("moli")):
                found += [f"{name}: {alias.name} from {'.' * node.level}{node.module or ''}" for alias in node.names
                          if alias.name.startswith("_") and not alias.name.startswith("__")]
    return found


def test_no_module_imports_another_modules_private_names():
    assert _private_imports() == []


def test_identify_is_a_short_chain_of_stage_calls():
    # the entry point stays a screen of calls, each step's work in the stage that owns it
    path = PACKAGE / "method" / "identification.py"
    identify = next(node for node in ast.parse(path.read_text()).body
                    if isinstance(node, ast.FunctionDef) and node.name == "identify")
    assert identify.end_lineno - identify.lineno + 1 <= 150
    assert len(_graph()["moli.method.identification"]) <= 10


def test_the_stage_checks_can_fail():
    # the checks above would pass on a graph without method's stages: make sure they read them
    graph = _graph()
    assert "moli.method.least_squares.estimation" in graph["moli.method.tuning.criterion"]
    assert _stage("moli.method.tuning.criterion") > _stage("moli.method.least_squares.estimation")
    assert _stage("moli.method.identification") > _stage("moli.method.pipeline.preparation")
    assert _stage("moli.validation.comparison") is None


def test_the_cycle_check_can_fail():
    # the checks above would pass on an empty graph: make sure they read real edges
    graph = _graph(load_time=True)
    assert "moli.data.iodata" in graph["moli.method.least_squares.estimation"]
    assert "moli.models.continuous" not in graph["moli.models.statespace"]  # deferred
    assert "moli.models.continuous" in _graph()["moli.models.statespace"]
    assert _layer("moli.app.cli") > _layer("moli.method.identification")


def test_modules_stay_small():
    sizes = {name: len(path.read_text().splitlines()) for name, path in _modules().items()}
    assert {n: s for n, s in sizes.items() if s > MAX_LINES} == {}


# More positional parameters than this are a call nobody can read: the rest are keyword-only.
MAX_POSITIONAL = 6


def test_no_function_takes_more_than_six_positional_parameters():
    crowded = []
    for name, path in _modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                positional = [a.arg for a in node.args.posonlyargs + node.args.args if a.arg not in ("self", "cls")]
                if len(positional) > MAX_POSITIONAL:
                    crowded.append(f"{name}.{node.name}: {len(positional)}")
    assert crowded == []


def test_public_modules_declare_all():
    lacking = [
        name for name, path in _modules().items()
        if not any(part.startswith("_") and part != "__init__" for part in name.split("."))
        and "__all__" not in path.read_text()
    ]
    assert lacking == []


def _documented() -> set[str]:
    text = (REPO / "docs" / "api.md").read_text()
    return set(re.findall(r"^\| `(?:moli\.)?([\w.]+)` \|", text, flags=re.M))


def _public() -> set[str]:
    names = {n for n in moli.__all__ if n != "__version__"}
    for sub in moli._SUBPACKAGES:
        module = getattr(moli, sub)
        names |= {f"{sub}.{n}" for n in module.__all__}
    return names


def test_api_page_lists_exactly_the_public_api():
    documented, public = _documented(), _public()
    assert sorted(public - documented) == [], "public names missing from docs/api.md"
    assert sorted(documented - public) == [], "docs/api.md lists names that are not public"


def test_every_public_name_resolves():
    for name in _public():
        obj = moli
        for part in name.split("."):
            obj = getattr(obj, part)
        assert obj is not None

"""The extension's layers import one way: operators and the root registration -> blender -> pipeline ->
techniques -> gpu -> core. Read from the source (no import is run): every import statement of every module,
those inside functions too. Pure: no Blender needed.

Rules (issue "One home per technique"):
1. an import never points up a layer, and the modules' imports form no cycle;
2. ``bpy`` (and ``bmesh``, ``mathutils``, ``blf``) only under ``blender/``, ``operators/`` and the root
   ``__init__``; ``gpu`` only in ``gpu/``, ``pipeline.py`` and ``techniques/*/passes.py``;
3. techniques do not import each other (what two share moves down);
4. no project import inside a function (a cycle is not dodged by importing late).
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("core", "gpu", "techniques", "pipeline", "blender", "registration")  # bottom to top
BLENDER_APIS = {"bpy", "bmesh", "mathutils", "blf", "bpy_extras"}
GPU_APIS = {"gpu", "gpu_extras"}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def layer_of(module: str) -> str:
    parts = module.split(".")
    if parts[0] != "translucent_addon":
        return "registration"  # the root __init__ and operators/
    if len(parts) == 1:
        return "core"  # the package's docstring-only __init__
    return parts[1] if parts[1] in LAYERS else "core" if parts[1] == "data" else parts[1]


def technique_of(module: str) -> str | None:
    parts = module.split(".")
    return parts[2] if len(parts) > 3 and parts[1] == "techniques" else None  # a module inside a technique


def imports_of(path: Path) -> list[tuple[str, bool]]:
    """(imported module, inside a function) for each import statement of a source file; project modules
    are named from the repository root (``translucent_addon.core.physics.dipole``, ``operators.bake``)."""
    tree = ast.parse(path.read_text())
    own = module_name(path)
    package = own.split(".") if path.name == "__init__.py" else own.split(".")[:-1]
    found = []

    def visit(node, in_function):
        for child in ast.iter_child_nodes(node):
            nested = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if isinstance(child, ast.Import):
                found.extend((a.name, in_function) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package[: len(package) - child.level + 1] + ([child.module] if child.module else [])
                    base = ".".join(base)
                else:
                    base = child.module or ""
                for a in child.names:  # ``from pkg import module`` names the module itself
                    candidate = f"{base}.{a.name}"
                    found.append((candidate if is_project_module(candidate) else base, in_function))
            visit(child, nested)

    visit(tree, False)
    return found


def is_project_module(name: str) -> bool:
    path = ROOT.joinpath(*name.split("."))
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def project_sources() -> list[Path]:
    return [ROOT / "__init__.py", *sorted((ROOT / "operators").rglob("*.py")),
            *sorted((ROOT / "translucent_addon").rglob("*.py"))]


def violations(graph: dict[str, list[tuple[str, bool]]]) -> list[str]:
    """Every broken rule of an import graph {module: [(imported, inside a function)]}, one line each."""
    out = []
    project = set(graph)
    rank = {name: k for k, name in enumerate(LAYERS)}
    for module, imports in graph.items():
        layer = layer_of(module)
        for target, late in imports:
            top = target.split(".")[0]
            if top in BLENDER_APIS and layer not in ("blender", "registration"):
                out.append(f"{module} imports {target}: Blender's API only under blender/")
            if top in GPU_APIS and not (layer in ("gpu", "pipeline")
                                         or (technique_of(module) and module.endswith(".passes"))):
                out.append(f"{module} imports {target}: gpu only in gpu/, pipeline and techniques/*/passes")
            if target not in project:
                continue
            if late:
                out.append(f"{module} imports {target} inside a function")
            if rank.get(layer_of(target), 0) > rank.get(layer, 0):
                out.append(f"{module} ({layer}) imports {target} ({layer_of(target)}): upward")
            mine, theirs = technique_of(module), technique_of(target)
            if mine and theirs and mine != theirs:
                out.append(f"{module} imports {target}: techniques do not import each other")
    out.extend(f"import cycle: {' -> '.join(c)}" for c in cycles(graph))
    return out


def cycles(graph) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []
    edges = {m: sorted({t for t, _ in imps if t in graph and t != m}) for m, imps in graph.items()}

    def strong(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
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

    for v in sorted(edges):
        if v not in index:
            strong(v)
    return out


def project_graph() -> dict[str, list[tuple[str, bool]]]:
    return {module_name(p): imports_of(p) for p in project_sources()}


def test_the_layers_import_one_way_with_no_cycle_and_no_late_project_import():
    found = violations(project_graph())
    assert not found, "\n".join(found)


@pytest.mark.parametrize("planted, message", [
    (("translucent_addon.core.physics.dipole", "translucent_addon.gpu.shaders", False), "upward"),
    (("translucent_addon.core.metrics", "bpy", False), "Blender's API only under blender/"),
    (("translucent_addon.techniques.quadgraph.model", "gpu", False), "gpu only in gpu/"),
    (("translucent_addon.techniques.quadgraph.passes", "translucent_addon.techniques.texture_space.passes",
      False), "techniques do not import each other"),
    (("translucent_addon.blender.engine", "translucent_addon.pipeline", True), "inside a function"),
    (("translucent_addon.gpu.shaders", "translucent_addon.gpu.targets", False), "import cycle"),
])
def test_a_planted_bad_import_is_caught(planted, message):
    """The checker itself: each kind of bad import, planted into the real graph, is reported."""
    graph = project_graph()
    module, target, late = planted
    graph[module] = [*graph[module], (target, late)]
    if message == "import cycle":
        graph[target] = [*graph[target], (module, False)]
    assert any(message in line for line in violations(graph)), message


def test_every_public_function_of_core_is_annotated():
    """core/ is what everything else builds on: each public function and method says what it takes and
    returns (``self``/``cls`` aside; ``__init__`` needs no return type)."""
    missing = []
    for path in sorted((ROOT / "translucent_addon" / "core").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) or node.name.startswith("_") \
                    and node.name != "__init__":
                continue
            args = [a for a in (*node.args.posonlyargs, *node.args.args, *node.args.kwonlyargs,
                                node.args.vararg, node.args.kwarg) if a is not None and a.arg not in ("self", "cls")]
            if any(a.annotation is None for a in args) or (node.returns is None and node.name != "__init__"):
                missing.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}")
    assert not missing, "\n".join(missing)

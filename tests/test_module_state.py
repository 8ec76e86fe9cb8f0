"""The frame's state has one owner per layer (issue 54): what a Blender session caches and remembers lives on
``blender.session.Session``, the GPU layer's caches on ``gpu.resources.GpuResources``, the techniques on the
registry; not in module globals. Read from the source (nothing is run): every module-level name of the extension.

A module-level name is mutable module state when something anywhere in the extension changes what it holds (an
item assigned or deleted, a mutating method called on it), when a ``global`` statement rebinds it, or when it
holds a container made at import and is not named as an upper-case constant. Mutable module state is allowed
only in ``ALLOWED``: at most 3, each documented where it is made. Pure: no Blender needed.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MUTATORS = {"append", "extend", "update", "clear", "pop", "popitem", "setdefault", "add", "discard", "remove",
            "insert", "sort", "appendleft"}
CONTAINER_CALLS = {"dict", "list", "set", "defaultdict", "OrderedDict", "deque", "count", "Counter",
                   "WeakValueDictionary", "WeakKeyDictionary"}
CONSTANT_NAME = re.compile(r"^_?[A-Z][A-Z0-9_]*$")

ALLOWED = {  # each documented where it is made
    "translucent_addon/blender/session.py:_current",  # the extension's Session: the Blender layer's caches, results
    "translucent_addon/gpu/resources.py:_current",  # the process's GPU resources: programs, bake data, GPU caches
    "translucent_addon/techniques/__init__.py:REGISTRY",  # the registered techniques (register / unregister)
}


def sources() -> list[Path]:
    return [ROOT / "__init__.py", *sorted((ROOT / "operators").rglob("*.py")),
            *sorted((ROOT / "translucent_addon").rglob("*.py"))]


def _is_container(value: ast.AST) -> bool:
    if isinstance(value, (ast.Dict, ast.List, ast.Set, ast.DictComp, ast.ListComp, ast.SetComp)):
        return True
    return isinstance(value, ast.Call) and (getattr(value.func, "id", None) or getattr(value.func, "attr", None)) \
        in CONTAINER_CALLS


def mutated_names(trees) -> set[str]:
    """Names whose object is changed somewhere: an item assigned or deleted, a mutating method called."""
    names = set()
    for tree in trees:
        for node in ast.walk(tree):
            targets = []
            if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign, ast.Delete)):
                targets = node.targets if isinstance(node, (ast.Assign, ast.Delete)) else [node.target]
            for t in targets:
                if isinstance(t, ast.Subscript) and isinstance(t.value, (ast.Name, ast.Attribute)):
                    names.add(getattr(t.value, "id", None) or t.value.attr)
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in MUTATORS:
                owner = node.func.value
                if isinstance(owner, (ast.Name, ast.Attribute)):
                    names.add(getattr(owner, "id", None) or owner.attr)
    return names


def module_state(files: dict[str, str]) -> set[str]:
    """'path:name' of every piece of mutable module state in ``files`` (path -> source)."""
    trees = {path: ast.parse(text) for path, text in files.items()}
    mutated = mutated_names(trees.values())
    found = set()
    for path, tree in trees.items():
        for node in tree.body:
            if isinstance(node, ast.Assign):
                targets, value = node.targets, node.value
            elif isinstance(node, ast.AnnAssign) and node.value is not None:
                targets, value = [node.target], node.value
            else:
                continue
            for t in targets:
                if not isinstance(t, ast.Name):
                    continue
                if t.id in mutated or (_is_container(value) and not CONSTANT_NAME.match(t.id)):
                    found.add(f"{path}:{t.id}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Global):
                found |= {f"{path}:{name}" for name in node.names}
    return found


def test_the_scanner_finds_planted_state_and_passes_constants():
    planted = {"a.py": "TABLE = {'x': 1}\nLOOKUP = ('a', 'b')\n_cache = {}\nCOUNTS = {}\nn = 0\n"
                       "REG = Registry([])\nTECHNIQUE = Technique()\n"
                       "def f():\n    global n\n    n += 1\n",
               "b.py": "from a import COUNTS, REG\nCOUNTS['k'] = 2\nREG.append(3)\n"}
    assert module_state(planted) == {"a.py:_cache", "a.py:COUNTS", "a.py:n", "a.py:REG"}


def test_mutable_module_state_has_one_owner_per_layer():
    files = {str(p.relative_to(ROOT)): p.read_text() for p in sources()}
    state = module_state(files)
    assert len(ALLOWED) <= 3
    assert state == ALLOWED, ("mutable module state outside its owners (move it onto blender.session.Session, "
                              "gpu.resources.GpuResources or a technique's cache there):\n"
                              + "\n".join(sorted(state - ALLOWED)))

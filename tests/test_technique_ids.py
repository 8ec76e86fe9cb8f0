"""A technique owns all of itself: no technique's id is spelled out in code outside ``techniques/`` (issue 54).

Read from the source (nothing is imported but the registry, for its ids): every string constant of every module
of the extension outside ``techniques/`` that is not a docstring, f-string pieces included. A layer that needs
something of a technique asks it through the protocol (``techniques/protocol.py``), by the id it was handed.
Comments and docstrings may name a method; code may not. Pure: no Blender needed.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

from translucent_addon import techniques

ROOT = Path(__file__).resolve().parents[1]
IDS = tuple(t.id for t in techniques.REGISTRY)


def extension_sources() -> list[Path]:
    """The extension's modules outside ``techniques/``: the root registration, operators and translucent_addon."""
    package = ROOT / "translucent_addon"
    files = [ROOT / "__init__.py", *sorted((ROOT / "operators").rglob("*.py")), *sorted(package.rglob("*.py"))]
    return [f for f in files if "techniques" not in f.relative_to(ROOT).parts]


def docstrings(tree: ast.AST) -> set[int]:
    """ids of the string nodes that are docstrings (of the module, a class or a function)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                found.add(id(first.value))
    return found


def ids_spelled_out(source: str, ids=IDS) -> list[tuple[int, str]]:
    """(line, id) of every technique id that a string constant of ``source`` holds as a word, docstrings apart."""
    tree = ast.parse(source)
    skip = docstrings(tree)
    word = re.compile(r"\b(" + "|".join(map(re.escape, ids)) + r")\b")
    hits = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            hits += [(node.lineno, m.group(1)) for m in word.finditer(node.value)]
    return hits


def test_the_scanner_finds_a_planted_id_and_passes_prose():
    planted = '''"""Docstrings may say IMAGE_SPACE."""
# so may comments: QUADGRAPH
def f(ob):
    """And here: GEOCUBE."""
    if ob.method == "TEXTURE_SPACE":
        return f"drawn by {ob.name} with QUADGRAPH"
    return "IMAGE_SPACES is another word"
'''
    assert ids_spelled_out(planted) == [(5, "TEXTURE_SPACE"), (6, "QUADGRAPH")]


def test_no_technique_id_outside_techniques():
    assert len(IDS) >= 7 and "IMAGE_SPACE" in IDS
    hits = [f"{path.relative_to(ROOT)}:{line}: {tid}" for path in extension_sources()
            for line, tid in ids_spelled_out(path.read_text())]
    assert not hits, "technique ids spelled out outside techniques/ (ask the technique instead):\n" + "\n".join(hits)

"""The techniques and their registry: the ids, labels and order the pipeline, the ``method`` property,
``unregister`` and the shader table loop over.

Each technique is a folder with the same file names: ``model.py`` (the pure twin), ``bake.py``, ``passes.py``
(its GPU passes and its ``Technique``, see ``protocol.py``), ``quality.py``; the paper's name is in each
docstring, not in file names. Adding one is a folder and one line in ``REGISTRY`` (or ``register`` at run
time, as the tests' constant-colour technique does).
"""
from __future__ import annotations

from ..core import quality
from ..gpu import shaders
from .caustics import passes as _caustics
from .geocube import passes as _geocube
from .grass import passes as _grass
from .image_space import passes as _image_space
from .protocol import Technique
from .quadgraph import passes as _quadgraph
from .relief import passes as _relief
from .texture_space import passes as _texture_space

OFF = ("OFF", "Off", "Opaque: base colour with Lambert shading and shadows", 0)

class Registry(list):
    """The registered techniques, in the order their hooks run, and who is told when it changes (``listeners``:
    the Blender layer rebuilds the method property and joins the technique's properties)."""

    def __init__(self, techniques):
        super().__init__(techniques)
        self.listeners: list = []


# Every technique the pipeline draws, in the order its hooks run within each pass: height fields and grass
# replace or follow the base; maps lit in texture space before the caustics of the same emitter; IMAGE_SPACE,
# TEXTURE_SPACE, QUADGRAPH, then GEOCUBE drawn over the base. The one piece of mutable module state of this layer
# (``register``, ``unregister``).
REGISTRY = Registry([_image_space.TECHNIQUE, _relief.TECHNIQUE, _grass.TECHNIQUE, _texture_space.TECHNIQUE,
                     _quadgraph.TECHNIQUE, _caustics.TECHNIQUE, _geocube.TECHNIQUE])


def method_items() -> list[tuple[str, str, str, int]]:
    """(id, label, description, stable number) of every method an object can choose, OFF first: the numbers
    are what .blend files store, so a technique keeps its number for good."""
    methods = sorted((t for t in REGISTRY if t.method_number is not None), key=lambda t: t.method_number)
    return [OFF] + [(t.id, t.label, t.description, t.method_number) for t in methods]


def method_ids() -> tuple[str, ...]:
    return tuple(i[0] for i in method_items())


def method_label(method: str) -> str:
    return next((i[1] for i in method_items() if i[0] == method), method)


def method_description(method: str) -> str:
    return next((i[2] for i in method_items() if i[0] == method), "")


for _t in REGISTRY:
    shaders.add_specs(_t.shader_specs)


def get(technique_id: str) -> Technique | None:
    return next((t for t in REGISTRY if t.id == technique_id), None)


def tier_table(kind: str) -> dict:
    """Tier -> the values of every registered technique at it, for ``"object"`` (Object.translucent) or
    ``"scene"`` (Scene.translucent, with the scene-wide ones of ``core.quality``)."""
    table = {tier: dict(quality.SCENE[tier]) if kind == "scene" else {} for tier in quality.TIERS}
    for t in REGISTRY:
        for tier, values in (t.scene_tiers if kind == "scene" else t.object_tiers).items():
            table[tier].update(values)
    return table


def default_method() -> str:
    """The method a translucent object starts with where the user has not chosen one (a demo scene, a painted
    layer on an Off object): the first that needs no bake and draws the painted layers."""
    methods = sorted((t for t in REGISTRY if t.method_number is not None), key=lambda t: t.method_number)
    return next((t.id for t in methods if not t.bake_stages and t.draws_paint), OFF[0])


def register(technique: Technique) -> None:
    """Add a technique after the others (its shaders join the table; a method appears in the property)."""
    if get(technique.id) is not None:
        raise ValueError(f"a technique {technique.id!r} is already registered")
    numbers = {t.method_number for t in REGISTRY} | {OFF[3]}
    if technique.method_number is not None and technique.method_number in numbers:
        raise ValueError(f"method number {technique.method_number} is taken")
    shaders.add_specs(technique.shader_specs)
    REGISTRY.append(technique)
    for listener in REGISTRY.listeners:
        listener()


def unregister(technique: Technique) -> None:
    """Remove a technique registered at run time, its shaders and its caches."""
    REGISTRY.remove(technique)
    shaders.remove_specs(technique.shader_specs)
    technique.clear_caches()
    for listener in REGISTRY.listeners:
        listener()


def clear_caches() -> None:
    """Every technique's caches (when the extension is disabled)."""
    for t in REGISTRY:
        t.clear_caches()

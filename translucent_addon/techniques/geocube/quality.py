"""GEOCUBE's Auto quality: cube texels from the object's pixels (pure)."""
from __future__ import annotations

from ...core.quality_model import Choice, ObjectView
from .bake import resolution_for


def auto(view: ObjectView, target: float, curves: str) -> Choice:
    res = resolution_for(view.screen_pixels)
    return Choice("GEOCUBE", {"geocube_resolution": res}, {}, None, {"cube_texels": 6 * res * res},
                  ["one cube texel per two pixels of the object"])

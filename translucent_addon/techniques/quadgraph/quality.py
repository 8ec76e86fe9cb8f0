"""QUADGRAPH's Auto quality: the density K (its error against exact transport is the model's, flat in K),
coarser only where even K = 2's surface nodes are finer than a pixel (pure)."""
from __future__ import annotations

import math

from ...core.quality_model import Choice, ObjectView, load_curves
from .bake import proxy_triangles

QUADGRAPH_K_CHOICES = (2.0, 1.0)


def quadgraph_surface_spacing_mm(view: ObjectView, K: float, mesh_triangles: int | None = None) -> float:
    """Mean edge of QUADGRAPH's finest proxy at density K (its triangle count, bake.quadgraph_bake)."""
    n = proxy_triangles(K, 1, mesh_triangles)[-1]
    return math.sqrt(view.area_mm2 / (math.sqrt(3.0) / 4.0 * n))


def auto(view: ObjectView, target: float, curves: str) -> Choice:
    rows = load_curves(curves)["quadgraph"]
    by_K = {}
    for r in rows:
        by_K.setdefault(r["K"], []).append(r["rel_rmse"])
    model = {K: max(v) for K, v in by_K.items()}
    K = 1.0
    notes = ["measured against exact transport: "
             f"{', '.join(f'K {k:g} {100 * e:.1f} %' for k, e in sorted(model.items(), reverse=True))}"
             " (the model's error, which finer K does not reduce)"]
    if view.pixel_mm > 0 and quadgraph_surface_spacing_mm(view, 2.0, view.triangles) < view.pixel_mm:
        K = 2.0
        notes.append("K = 2: its surface nodes are already finer than a pixel of the object")
    if model.get(1.0, 0.0) > target:
        notes.append(f"the target {100 * target:g} % is below this model's measured error")
    spacing = quadgraph_surface_spacing_mm(view, K, view.triangles)
    return Choice("QUADGRAPH", {"quadgraph_K": K}, {}, None, {"proxy_triangles_spacing_mm": round(spacing, 2)}, notes)

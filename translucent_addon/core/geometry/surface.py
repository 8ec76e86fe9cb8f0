"""The surface stage: per-vertex samples of the object's surface, in mm.

Shared first stage of the baked methods. It gives each vertex its position,
area-weighted normal and area A_v (one third of the adjacent triangle areas,
the vertex area of Lensch Sec. 5.2), which the dipole model reference
integrates over and the texture-space vertex gather weights by.
"""
from __future__ import annotations

import numpy as np

from .mesh_measures import vertex_areas, vertex_normals


def surface_samples(vertices: np.ndarray, triangles: np.ndarray, mm_per_unit: float) -> dict[str, np.ndarray]:
    """positions_mm (V,3), normals (V,3), areas_mm2 (V,), triangles (T,3) int32."""
    v = np.asarray(vertices, dtype=np.float64) * float(mm_per_unit)
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    return {
        "positions_mm": v.astype(np.float32),
        "normals": vertex_normals(v, t).astype(np.float32),
        "areas_mm2": (vertex_areas(v, t) / 3.0).astype(np.float32),
        "triangles": t.astype(np.int32),
    }

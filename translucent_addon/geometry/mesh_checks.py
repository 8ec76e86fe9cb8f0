"""Topology and size checks that every bake runs first (DESIGN.md section 6)."""
from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class MeshReport:
    vertices: int
    triangles: int
    zero_area_triangles: int
    boundary_edges: int  # edges with one face: the mesh is open
    non_manifold_edges: int  # edges with three or more faces

    @property
    def closed_manifold(self) -> bool:
        return self.boundary_edges == 0 and self.non_manifold_edges == 0


def triangle_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    v = vertices[triangles]
    return 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)


def check_mesh(vertices: np.ndarray, triangles: np.ndarray, area_epsilon: float = 1e-12) -> MeshReport:
    """Count degenerate triangles and open or non-manifold edges (vectorised)."""
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    areas = triangle_areas(np.asarray(vertices, dtype=np.float64), tris) if len(tris) else np.zeros(0)
    scale = float(np.ptp(vertices, axis=0).max()) ** 2 if len(vertices) else 1.0
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    if len(edges):
        _, counts = np.unique(edges, axis=0, return_counts=True)
    else:
        counts = np.zeros(0, dtype=np.int64)
    return MeshReport(
        vertices=len(vertices),
        triangles=len(tris),
        zero_area_triangles=int(np.count_nonzero(areas <= area_epsilon * max(scale, 1e-30))),
        boundary_edges=int(np.count_nonzero(counts == 1)),
        non_manifold_edges=int(np.count_nonzero(counts > 2)),
    )

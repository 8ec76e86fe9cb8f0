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


def self_intersections(vertices: np.ndarray, triangles: np.ndarray, max_pairs: int = 4_000_000) -> int | None:
    """Pairs of triangles that share no vertex and cut each other (a self-intersecting surface has no
    well-defined inside). Candidates: triangles whose bounding spheres overlap (k-d tree of centres);
    test: an edge of one crossing the other (Moller-Trumbore, both ways). None when there are more than
    ``max_pairs`` candidates (the check would take too long; nothing is claimed)."""
    from scipy.spatial import cKDTree

    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    if len(t) < 2:
        return 0
    p = v[t]
    centre = p.mean(axis=1)
    radius = np.linalg.norm(p - centre[:, None], axis=2).max(axis=1)
    tree = cKDTree(centre)
    # Most triangles are small: pairs among them within twice the 95th-percentile radius; the few larger
    # ones look for neighbours within their own radius plus the largest.
    r_small = float(np.percentile(radius, 95))
    pairs = [tree.query_pairs(2.0 * r_small, output_type="ndarray")]
    big = np.nonzero(radius > r_small)[0]
    for k, near in zip(big, tree.query_ball_point(centre[big], radius[big] + float(radius.max()))):
        near = np.asarray(near, np.int64)
        near = near[near != k]
        pairs.append(np.stack([np.minimum(near, k), np.maximum(near, k)], axis=1))
    pairs = np.unique(np.concatenate([q.reshape(-1, 2) for q in pairs]), axis=0)
    if len(pairs) > max_pairs:
        return None
    if len(pairs) == 0:
        return 0
    i, j = pairs[:, 0], pairs[:, 1]
    near = np.linalg.norm(centre[i] - centre[j], axis=1) <= radius[i] + radius[j]
    i, j = i[near], j[near]
    shares = (t[i][:, :, None] == t[j][:, None, :]).any(axis=(1, 2))
    i, j = i[~shares], j[~shares]
    hit = _edges_cross(p[i], p[j]) | _edges_cross(p[j], p[i])
    return int(np.count_nonzero(hit))


def _edges_cross(a: np.ndarray, b: np.ndarray, eps: float = 1e-12) -> np.ndarray:
    """Per pair, whether an edge of triangle a (N, 3, 3) passes through triangle b (N, 3, 3)."""
    out = np.zeros(len(a), bool)
    e1, e2 = b[:, 1] - b[:, 0], b[:, 2] - b[:, 0]
    for k in range(3):
        o = a[:, k]
        d = a[:, (k + 1) % 3] - o
        h = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, h)
        ok = np.abs(det) > eps
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - b[:, 0]
        u = np.einsum("ij,ij->i", s, h) * inv
        q = np.cross(s, e1)
        w = np.einsum("ij,ij->i", d, q) * inv
        tt = np.einsum("ij,ij->i", e2, q) * inv
        # Strictly inside, by a margin: faces that only touch (a T-junction, a shared edge's end) do not count.
        m = 1e-6
        out |= ok & (u > m) & (w > m) & (u + w < 1 - m) & (tt > m) & (tt < 1 - m)
    return out

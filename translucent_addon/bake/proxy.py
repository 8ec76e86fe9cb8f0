"""The proxy mesh of TEXTURE_SPACE and its mapping back to the displayed mesh.

Pure. The scattering is computed on a proxy whose vertex spacing follows the atlas: Lensch's
blending works when a vertex hat is about as wide as the 7x7 kernel (his models: 10k vertices,
512^2 atlas, about 4 texels between vertices; measured here on a plate, the error of a uniform
irradiance grows from +2..5 % at 3.6 texels to +8..15 % at 14). So a coarse mesh is subdivided
and a dense one decimated (by Blender, ``inputs.py``) to about ``SPACING_TEXELS`` texels per edge,
at most ``MAX_TRIANGLES`` (the paper: under 20k). The displayed mesh keeps its own triangles:
each display triangle takes the proxy triangle nearest its centroid and its corners are
projected onto that triangle's plane, so its atlas coordinates stay inside one chart (the chart's
border texels carry the radiosity across the seam). A subdivided proxy needs no mapping: it is
drawn in place of the display, its triangles the display's own cut in four (``subdivide_corners``).
"""
from __future__ import annotations

import numpy as np

from ..geometry.mesh_checks import triangle_areas

SPACING_TEXELS = 3.5
MAX_TRIANGLES = 20_000
# Charts fill about this fraction of the atlas once the 8-texel gutters are counted.
ATLAS_FILL = 0.37


def surface_area(vertices: np.ndarray, triangles: np.ndarray) -> float:
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    return float(triangle_areas(v, t).sum())


def target_triangles(area_mm2: float, resolution: int, max_triangles: int = MAX_TRIANGLES) -> int:
    """Triangles of the proxy for an atlas of ``resolution`` texels a side (equilateral, SPACING_TEXELS edges)."""
    texel_mm2 = area_mm2 / (ATLAS_FILL * resolution**2)
    edge = SPACING_TEXELS * np.sqrt(texel_mm2)
    return int(min(max_triangles, max(64, round(area_mm2 / (np.sqrt(3.0) / 4.0 * edge**2)))))


def subdivide(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint 1-to-4 subdivision (shared edges split once)."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(triangles, np.int64)
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mid = len(v) + inverse.reshape(3, -1).T  # (T, 3): midpoints of edges 01, 12, 20
    v2 = np.concatenate([v, 0.5 * (v[unique[:, 0]] + v[unique[:, 1]])])
    a, b, c = f.T
    m01, m12, m20 = mid.T
    f2 = np.concatenate([np.stack(x, axis=1) for x in
                         ((a, m01, m20), (m01, b, m12), (m20, m12, c), (m01, m12, m20))])
    return v2, f2


def refine(vertices: np.ndarray, triangles: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Subdivide while that brings the triangle count nearer the target: (vertices, triangles, levels)."""
    v, f = np.asarray(vertices, np.float64), np.asarray(triangles, np.int64)
    levels = 0
    while abs(np.log(4 * len(f) / target)) < abs(np.log(len(f) / target)):
        v, f = subdivide(v, f)
        levels += 1
    return v, f, levels


def subdivide_corners(corners: np.ndarray, levels: int) -> np.ndarray:
    """Per-corner attributes (3T, c) of a triangle list subdivided like ``subdivide`` (same order).

    A subdivided proxy is drawn as the display: its triangles are the display's cut in four,
    each display corner attribute (position, split normal, colour) interpolated linearly.
    """
    a = np.asarray(corners)
    for _ in range(levels):
        t = a.reshape(-1, 3, a.shape[-1])
        p0, p1, p2 = t[:, 0], t[:, 1], t[:, 2]
        m01, m12, m20 = 0.5 * (p0 + p1), 0.5 * (p1 + p2), 0.5 * (p2 + p0)
        groups = [(p0, m01, m20), (m01, p1, m12), (m20, m12, p2), (m01, m12, m20)]
        a = np.concatenate([np.stack(g, axis=1) for g in groups]).reshape(-1, a.shape[-1]).astype(a.dtype)
    return a


def display_mapping(display_vertices: np.ndarray, display_triangles: np.ndarray, proxy_vertices: np.ndarray,
                    proxy_triangles: np.ndarray):
    """For each display triangle corner: (proxy triangle (3T,), barycentrics (3T, 3)) on its plane.

    The proxy triangle is the one nearest the display triangle's centroid (among the 8 nearest
    proxy centroids, by distance to the triangle); the barycentrics are those of the corner
    projected onto its plane, clamped to [-1, 2] so a sliver cannot throw a corner far out.
    """
    from scipy.spatial import cKDTree

    dv = np.asarray(display_vertices, np.float64)
    dt = np.asarray(display_triangles, np.int64)
    P = np.asarray(proxy_vertices, np.float64)[np.asarray(proxy_triangles, np.int64)]  # (Tp, 3, 3)
    centroid = dv[dt].mean(axis=1)
    k = min(8, len(P))
    _, cand = cKDTree(P.mean(axis=1)).query(centroid, k=k)
    cand = cand.reshape(len(dt), k)
    dist = _point_triangle_distance(np.repeat(centroid, k, axis=0), P[cand.ravel()]).reshape(len(dt), k)
    best = cand[np.arange(len(dt)), np.argmin(dist, axis=1)]
    tri = np.repeat(best, 3)
    corners = dv[dt].reshape(-1, 3)
    bary = _plane_barycentrics(corners, P[tri])
    return tri.astype(np.int32), np.clip(bary, -1.0, 2.0).astype(np.float32)


def _plane_barycentrics(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Barycentrics of p projected onto the planes of triangles tri (n, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) > 1e-30, den, 1e-30)
    l1 = (d11 * d20 - d01 * d21) / den
    l2 = (d00 * d21 - d01 * d20) / den
    return np.stack([1.0 - l1 - l2, l1, l2], axis=1)


def _point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance from points to triangles (clamped barycentric projection; exact enough to rank)."""
    bary = np.clip(_plane_barycentrics(p, tri), 0.0, None)
    bary /= np.maximum(bary.sum(1, keepdims=True), 1e-30)
    return np.linalg.norm(np.einsum("nk,nkd->nd", bary, tri) - p, axis=1)

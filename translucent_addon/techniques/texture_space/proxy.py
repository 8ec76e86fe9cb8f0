"""The proxy mesh of TEXTURE_SPACE and its mapping back to the displayed mesh.

Pure. The scattering is computed on a proxy whose vertex spacing follows the atlas: Lensch's
blending works when a vertex hat is about as wide as the 7x7 kernel (his models: 10k vertices,
512^2 atlas, about 4 texels between vertices; measured here on a plate, the error of a uniform
irradiance grows from +2..5 % at 3.6 texels to +8..15 % at 14). So a coarse mesh is refined
where its edges are long (``refine_to_edge``) and a dense one decimated (by Blender, ``inputs.py``)
to about ``SPACING_TEXELS`` texels per edge (the object's *proxy spacing*), at most
``MAX_TRIANGLES``. Finer spacing follows the short channels of R_d across a shadow edge (back-lit
bunny against the dipole model: 6.9 % at 3.5 texels, 4.7 % at 2.4) at a longer bake.
A decimated proxy's display keeps its own triangles: each display triangle takes the proxy
triangle nearest its centroid and its corners are projected onto that triangle's plane, so its
atlas coordinates stay inside one chart (the chart's border texels carry the radiosity across the
seam). A refined proxy needs no mapping: it is drawn in place of the display, each of its corners
carrying the display's attributes by its barycentrics in the display triangle (``Refinement``).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.geometry.mesh_checks import triangle_areas
from ...core.geometry.mesh_measures import vertex_normals
from .atlas import texel_mm

SPACING_TEXELS = 3.5  # the default proxy spacing
# Longest-edge bisection leaves edges between half its bound and the bound, 0.7 of it on average:
# refining to a spacing s bounds the edges by s * MAX_EDGE_RATIO (5 texels at the default).
MAX_EDGE_RATIO = 5.0 / 3.5
MAX_TRIANGLES = 60_000  # the paper stayed under 20k; the bunny at spacing 2.4 and atlas 512 takes 39k
# Charts fill about this fraction of the atlas once the 8-texel gutters are counted.
ATLAS_FILL = 0.37


def atlas_setting(item) -> tuple[int, float]:
    """(atlas texels, proxy spacing in texels) from an atlas resolution or such a pair."""
    res, spacing = (item, SPACING_TEXELS) if np.ndim(item) == 0 else item
    return int(res), float(spacing)


def atlas_label(res: int, spacing: float) -> str:
    return f"{res} texels" + ("" if spacing == SPACING_TEXELS else f", spacing {spacing:g}")


def surface_area(vertices: np.ndarray, triangles: np.ndarray) -> float:
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    return float(triangle_areas(v, t).sum())


def target_triangles(area_mm2: float, resolution: int, spacing: float = SPACING_TEXELS,
                     max_triangles: int = MAX_TRIANGLES) -> int:
    """Triangles of the proxy for an atlas of ``resolution`` texels a side (equilateral, ``spacing`` texel edges)."""
    texel_mm2 = area_mm2 / (ATLAS_FILL * resolution**2)
    edge = spacing * np.sqrt(texel_mm2)
    return int(min(max_triangles, max(64, round(area_mm2 / (np.sqrt(3.0) / 4.0 * edge**2)))))


TRANSFER_CANDIDATES = 8


def transfer_normals(display_vertices, display_triangles, display_normals, proxy_vertices,
                     proxy_triangles) -> np.ndarray:
    """Unit normals (V', 3) at a decimated proxy's vertices: the display's (the mean of a vertex's
    corner normals ``display_normals`` (T, 3, 3)) at the nearest display vertex on the same side,
    i.e. whose normal is within 90 degrees of the proxy's own (a thin part's far side can be
    nearer); the proxy's own normal where there is none."""
    from scipy.spatial import cKDTree

    t = np.asarray(display_triangles, np.int64).reshape(-1)
    n = np.zeros((len(display_vertices), 3))
    np.add.at(n, t, np.asarray(display_normals, np.float64).reshape(-1, 3))
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    own = vertex_normals(proxy_vertices, proxy_triangles, by_angle=True)
    k = min(TRANSFER_CANDIDATES, len(n))
    _, near = cKDTree(np.asarray(display_vertices, np.float64)).query(np.asarray(proxy_vertices, np.float64), k=k)
    near = near.reshape(len(own), k)
    same_side = np.einsum("pkd,pd->pk", n[near], own) > 0.0
    first = np.argmax(same_side, axis=1)
    out = n[near[np.arange(len(own)), first]]
    return np.where(same_side.any(axis=1)[:, None], out, own)


@dataclasses.dataclass
class Refinement:
    """A proxy refined from the display: its mesh and, per proxy triangle, the display triangle it
    lies in and its corners' barycentrics there (so display attributes carry over exactly)."""

    vertices: np.ndarray  # (V', 3)
    triangles: np.ndarray  # (T', 3)
    parent: np.ndarray  # (T',) display triangle
    bary: np.ndarray  # (T', 3 corners, 3) barycentrics of each corner in its parent

    def corners(self, display_corners: np.ndarray) -> np.ndarray:
        """Per-corner display attributes (3T, c) at the proxy's corners, (3T', c)."""
        return carry_corners(display_corners, self.parent, self.bary)


def carry_corners(display_corners: np.ndarray, parent: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Per-corner attributes (3T, c) of the display at the corners of triangles lying in display
    triangles ``parent`` (T',) with corner barycentrics ``bary`` (T', 3, 3): (3T', c)."""
    a = np.asarray(display_corners)
    a = a.reshape(-1, 3, a.shape[-1])[parent]
    return np.einsum("tkm,tmc->tkc", bary, a).reshape(-1, a.shape[-1]).astype(a.dtype)


def refine_for_atlas(vertices_mm: np.ndarray, triangles: np.ndarray, resolution: int,
                     spacing: float = SPACING_TEXELS) -> Refinement:
    """The display refined until no edge is longer than ``spacing`` x MAX_EDGE_RATIO texels of the
    atlas (about ``spacing`` on average), coarser if that would pass MAX_TRIANGLES."""

    max_edge = spacing * MAX_EDGE_RATIO * texel_mm(surface_area(vertices_mm, triangles), resolution)
    while True:
        refinement = refine_to_edge(vertices_mm, triangles, max_edge)
        if len(refinement.triangles) <= MAX_TRIANGLES or len(refinement.triangles) == len(triangles):
            return refinement
        max_edge *= 1.02 * np.sqrt(len(refinement.triangles) / MAX_TRIANGLES)


def refine_to_edge(vertices: np.ndarray, triangles: np.ndarray, max_edge: float, max_passes: int = 12) -> Refinement:
    """Split every edge longer than ``max_edge`` (longest-edge bisection with conforming closure).

    A triangle with any edge to split also splits its longest, then becomes two, three or four
    triangles (Rivara's refinement: angles stay bounded). Unlike 1-to-4 subdivision of every
    triangle, a mesh of uneven triangles comes out with even vertex spacing, which Lensch's blending
    needs (a vertex hat about as wide as the local kernel). Midpoints stay on the flat triangles.
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(triangles, np.int64).reshape(-1, 3)
    parent = np.arange(len(f))
    bary = np.broadcast_to(np.eye(3), (len(f), 3, 3)).copy()
    for _ in range(max_passes):
        length = np.stack([np.linalg.norm(v[f[:, (k + 1) % 3]] - v[f[:, k]], axis=1) for k in range(3)], axis=1)
        if length.max() <= max_edge:
            break
        # Rotate each triangle so that its longest edge is (0, 1).
        r = np.argmax(length, axis=1)
        idx = (r[:, None] + np.arange(3)[None, :]) % 3
        f = np.take_along_axis(f, idx, axis=1)
        bary = np.take_along_axis(bary, idx[:, :, None], axis=1)
        length = np.take_along_axis(length, idx, axis=1)
        edges = np.sort(np.stack([f, np.roll(f, -1, axis=1)], axis=2), axis=2)  # (T, 3, 2): 01, 12, 20
        keys = edges[..., 0] * len(v) + edges[..., 1]
        unique, inverse = np.unique(keys.ravel(), return_inverse=True)
        inverse = inverse.reshape(-1, 3)
        split = np.zeros(len(unique), bool)
        split[inverse[length > max_edge]] = True
        while True:  # closure: a triangle with a split edge splits its longest (edge 0) too
            need = split[inverse].any(axis=1) & ~split[inverse[:, 0]]
            if not need.any():
                break
            split[inverse[need, 0]] = True
        mid = np.full(len(unique), -1, np.int64)
        mid[split] = len(v) + np.arange(split.sum())
        a_, b_ = unique[split] // len(v), unique[split] % len(v)
        v = np.concatenate([v, 0.5 * (v[a_] + v[b_])])
        m = mid[inverse]  # (T, 3): midpoint of edges 01, 12, 20 or -1
        s01, s12, s20 = m[:, 0] >= 0, m[:, 1] >= 0, m[:, 2] >= 0
        a, b, c = f.T
        ba, bb, bc = bary[:, 0], bary[:, 1], bary[:, 2]
        m01, m12, m20 = m.T
        b01, b12, b20 = 0.5 * (ba + bb), 0.5 * (bb + bc), 0.5 * (bc + ba)
        out_f, out_b, out_p = [f[~s01]], [bary[~s01]], [parent[~s01]]

        def emit(sel, corners):
            out_f.append(np.stack([x[0][sel] for x in corners], axis=1))
            out_b.append(np.stack([x[1][sel] for x in corners], axis=1))
            out_p.append(parent[sel])

        A, B, C = (a, ba), (b, bb), (c, bc)
        M01, M12, M20 = (m01, b01), (m12, b12), (m20, b20)
        one = s01 & ~s12 & ~s20
        emit(one, (A, M01, C))
        emit(one, (M01, B, C))
        right = s01 & s12 & ~s20
        emit(right, (A, M01, C))
        emit(right, (M01, B, M12))
        emit(right, (M01, M12, C))
        left = s01 & ~s12 & s20
        emit(left, (A, M01, M20))
        emit(left, (M20, M01, C))
        emit(left, (M01, B, C))
        full = s01 & s12 & s20
        emit(full, (A, M01, M20))
        emit(full, (M01, B, M12))
        emit(full, (M20, M12, C))
        emit(full, (M01, M12, M20))
        f, bary, parent = np.concatenate(out_f), np.concatenate(out_b), np.concatenate(out_p)
    return Refinement(v, f, parent, bary)


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

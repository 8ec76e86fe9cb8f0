"""Carry a baked volume along with its surface: poses (armature, lattice, shape keys) and painted maps. Pure.

Points on or near the surface are embedded in their nearest triangle of the rest surface: the closest
point's barycentrics, plus the offset from it in an orthonormal frame there (the interpolated vertex
normal and a median of the triangle), in units of the triangle's mean edge. Placing them on the
deformed surface is then exact for rotations, translations and uniform scales, and steady on needle
triangles (as Blender's Surface Deform modifier does it).

Points inside follow by harmonic interpolation: their displacement solves Laplace's equation on the
tetrahedra (linear finite elements, the cotangent stiffness matrix), with the boundary points fixed
where their embedding puts them. Painted values reach the inside the same way: the smoothest field
that equals the paint on the surface. A linear field is harmonic and lies in the element space, so any
affine motion is reproduced exactly; any other stays smooth inside (Joshi et al. 2007, harmonic
coordinates). The stiffness matrix is factorised once per rest shape; each pose is one solve.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.geometry.mesh_measures import vertex_normals
from .tetra import TET_FACES, signed_volumes

CANDIDATES = 8  # nearest triangles (by centroid) searched for a point's closest point


class DeformationError(ValueError):
    """The deformation folds the volume over (a tetrahedron turns inside out): the message says where."""


def point_frames(vertices: np.ndarray, triangles: np.ndarray, triangle: np.ndarray, bary: np.ndarray,
                 normals: np.ndarray | None = None):
    """An orthonormal frame (n, 3, 3) and a length (n,) at points given by triangle and barycentrics.

    Rows: the triangle's median from its first corner made orthogonal to the normal (no choice among
    edges that a rotation's rounding could flip), the normal cross it, and the normal,
    which is the barycentric mix of the mesh's area-weighted vertex normals (steady where a triangle is
    a needle or collapses, unlike the triangle's own). The length is the triangle's mean edge. Both
    move with the mesh exactly under rotations and uniform scales. ``normals``: the mesh's
    ``vertex_normals``, when the caller already has them.
    """

    v = np.asarray(vertices, np.float64)
    tri = np.asarray(triangles, np.int64)
    t = tri[triangle]
    p = v[t]  # (n, 3, 3)
    n = np.einsum("nc,ncd->nd", bary, (vertex_normals(v, tri) if normals is None else normals)[t])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    edges = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]], axis=1)
    lengths = np.linalg.norm(edges, axis=2)
    e1 = p.mean(axis=1) - p[:, 0]  # along the median from the first corner: never short, even on a needle
    e1 = e1 - np.einsum("nd,nd->n", e1, n)[:, None] * n
    e1 /= np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), 1e-300)
    return np.stack([e1, np.cross(n, e1), n], axis=1), lengths.mean(axis=1)


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Closest point of each triangle (a, b, c) to p, all (..., 3), as barycentrics (..., 3)
    (Ericson, Real-Time Collision Detection 5.1.5, by Voronoi regions)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("...d,...d->...", ab, ap), np.einsum("...d,...d->...", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("...d,...d->...", ab, bp), np.einsum("...d,...d->...", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("...d,...d->...", ab, cp), np.einsum("...d,...d->...", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    denom = va + vb + vc
    safe = np.where(np.abs(denom) > 1e-300, denom, 1.0)
    v, w = vb / safe, vc / safe  # interior
    bary = np.stack([1.0 - v - w, v, w], axis=-1)

    def put(mask, u0, u1, u2):
        bary[mask] = np.stack([u0, u1, u2], axis=-1)[mask]

    def ratio(num, den):
        return num / np.where(np.abs(den) > 1e-300, den, 1.0)

    zero, one = np.zeros_like(d1), np.ones_like(d1)
    # Ericson's tests in reverse order (A, B, AB, C, AC, BC, interior), so that the first to hold wins.
    t_bc = ratio(d4 - d3, (d4 - d3) + (d5 - d6))
    put((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), zero, 1 - t_bc, t_bc)
    t_ac = ratio(d2, d2 - d6)
    put((vb <= 0) & (d2 >= 0) & (d6 <= 0), 1 - t_ac, zero, t_ac)
    put((d6 >= 0) & (d5 <= d6), zero, zero, one)
    t_ab = ratio(d1, d1 - d3)
    put((vc <= 0) & (d1 >= 0) & (d3 <= 0), 1 - t_ab, t_ab, zero)
    put((d3 >= 0) & (d4 <= d3), zero, one, zero)
    put((d1 <= 0) & (d2 <= 0), one, zero, zero)
    return bary


@dataclasses.dataclass
class SurfaceEmbedding:
    """Where points sit relative to a surface: triangle, barycentrics of the closest point, and the
    offset to the point in the frame there (``point_frames``) over the triangle's mean edge."""

    triangle: np.ndarray  # (n,)
    bary: np.ndarray  # (n, 3)
    offset: np.ndarray  # (n, 3)


def embed(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray) -> SurfaceEmbedding:
    """Embed points in their nearest triangle (among the CANDIDATES nearest by centroid)."""
    from scipy.spatial import cKDTree

    points = np.asarray(points, np.float64)
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    tri = v[t]
    k = min(CANDIDATES, len(t))
    _, cand = cKDTree(tri.mean(axis=1)).query(points, k=k)
    cand = cand.reshape(len(points), k)
    c = tri[cand]  # (n, k, 3, 3)
    bary = closest_on_triangles(points[:, None, :], c[:, :, 0], c[:, :, 1], c[:, :, 2])
    q = np.einsum("nkc,nkcd->nkd", bary, c)
    best = np.argmin(np.linalg.norm(q - points[:, None, :], axis=2), axis=1)
    rows = np.arange(len(points))
    triangle, bary = cand[rows, best], bary[rows, best]
    frames, size = point_frames(v, t, triangle, bary)
    local = np.einsum("nij,nj->ni", frames, points - q[rows, best])
    return SurfaceEmbedding(triangle, bary, local / np.maximum(size, 1e-300)[:, None])


def place(embedding: SurfaceEmbedding, vertices: np.ndarray, triangles: np.ndarray,
          normals: np.ndarray | None = None) -> np.ndarray:
    """Positions of embedded points on a (deformed) surface with the rest surface's triangles
    (``normals``: its vertex normals, if known)."""
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)[embedding.triangle]
    frames, size = point_frames(v, triangles, embedding.triangle, embedding.bary, normals)
    on_surface = np.einsum("nc,ncd->nd", embedding.bary, v[t])
    return on_surface + np.einsum("nij,ni->nj", frames, embedding.offset * size[:, None])


def rotate_with_surface(directions: np.ndarray, rest_frames: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """Unit directions carried from the rest surface to the deformed one by the frames at their embedding
    (``point_frames`` of each); where the deformed frame is degenerate (a patch collapsed to a point) they
    keep their rest value."""
    d = np.einsum("nji,nj->ni", frames, np.einsum("nij,nj->ni", rest_frames, directions))
    length = np.linalg.norm(d, axis=1, keepdims=True)
    return np.where(length > 1e-9, d / np.maximum(length, 1e-300), directions)


def stiffness(points: np.ndarray, tets: np.ndarray):
    """The linear finite-element Laplacian (P, P): K_ij = sum over tetrahedra of V grad(l_i) . grad(l_j)
    = N_i . N_j / (9 V), N_i the area vector of the face opposite vertex i (no inversion, so a sliver
    of nearly no volume stays finite: its volume is floored at 1e-9 of the median)."""
    from scipy.sparse import coo_matrix

    points = np.asarray(points, np.float64)
    tets = np.asarray(tets, np.int64)
    f = points[tets[:, TET_FACES]]  # (T, 4, 3, 3): face k opposite vertex k
    N = 0.5 * np.cross(f[:, :, 1] - f[:, :, 0], f[:, :, 2] - f[:, :, 0])  # (T, 4, 3)
    volume = np.abs(signed_volumes(points, tets))
    volume = np.maximum(volume, 1e-9 * np.median(volume))
    k = np.einsum("tid,tjd->tij", N, N) / (9.0 * volume[:, None, None])
    rows = np.repeat(tets, 4, axis=1).reshape(-1)
    cols = np.tile(tets, (1, 4)).reshape(-1)
    n = len(points)
    return coo_matrix((k.reshape(-1), (rows, cols)), shape=(n, n)).tocsr()


class HarmonicInterpolation:
    """Values at a tetrahedral mesh's points from those at its fixed points (Laplace's equation):
    displacements for a pose, painted values for the volume behind a painted surface."""

    def __init__(self, points: np.ndarray, tets: np.ndarray, fixed: np.ndarray):
        from scipy.sparse.linalg import splu

        self.fixed = np.asarray(fixed, bool)
        self.free = np.flatnonzero(~self.fixed)
        K = stiffness(points, tets)
        self.K_fb = K[self.free][:, np.flatnonzero(self.fixed)]
        self.solver = splu(K[self.free][:, self.free].tocsc()) if len(self.free) else None

    def __call__(self, u_fixed: np.ndarray) -> np.ndarray:
        """(P, C) values from (fixed count, C) values at the fixed points."""
        u_fixed = np.asarray(u_fixed, np.float64).reshape(int(self.fixed.sum()), -1)
        u = np.zeros((len(self.fixed), u_fixed.shape[1]))
        u[self.fixed] = u_fixed
        if self.solver is not None:
            u[self.free] = self.solver.solve(-(self.K_fb @ u_fixed))
        return u


def boundary_points(tets: np.ndarray, adjacency: np.ndarray, count: int) -> np.ndarray:
    """(count,) bool: the points on a boundary face (one with no tetrahedron across)."""

    t, f = np.nonzero(adjacency < 0)
    mask = np.zeros(count, bool)
    mask[np.asarray(tets)[t[:, None], TET_FACES[f]].reshape(-1)] = True
    return mask


FOLD_LIMIT = 0.01  # a pose is refused when tetrahedra holding this fraction of the volume turn over


def inverted(rest_volumes: np.ndarray, volumes: np.ndarray, floor: float = 1e-3) -> np.ndarray:
    """Tetrahedra turned inside out or squashed flat (below ``floor`` of their rest volume)."""
    return volumes <= floor * rest_volumes


def check_folds(rest_volumes: np.ndarray, volumes: np.ndarray, label: str = "") -> np.ndarray:
    """Raise DeformationError when the inverted tetrahedra hold more than FOLD_LIMIT of the rest
    volume; return the inverted ones otherwise.

    Slivers (tetrahedra of almost no volume, flat against the surface) turn over under poses that
    fold nothing: twisting the cow 180 degrees about its long axis turns 10 of 10.7k, holding 1.5e-4 of
    the volume (without fTetWild's optimisation, 5 degrees turned 94 of 27k). They carry no volume to
    speak of and keep positive link weights, so they are not a fold; a real fold (a mirror, a limb bent
    through itself) turns over a part of the volume.
    """
    bad = inverted(rest_volumes, volumes)
    share = float(rest_volumes[bad].sum() / max(float(rest_volumes.sum()), 1e-300))
    if share > FOLD_LIMIT:
        raise DeformationError(f"{label}the deformation turns {int(bad.sum()):,} of {len(bad):,} tetrahedra "
                               f"({share:.0%} of the volume) inside out; press Bake in this pose")
    return bad

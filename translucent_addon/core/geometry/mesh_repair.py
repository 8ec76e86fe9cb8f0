"""Closing the holes of a scanned mesh (pure NumPy): what a volume needs to have an inside.

The Stanford bunny's base keeps the scanner's holes (223 boundary edges in five loops). Every method here
closes a volume its own way (fTetWild fills them, the dipole methods ignore them), but Cycles' volume
brute force decides inside and outside by counting crossings, so through an open base it renders a
different object. The bundled meshes are therefore closed when they are packed.
"""
from __future__ import annotations

import numpy as np


def boundary_loops(triangles: np.ndarray) -> list[np.ndarray]:
    """The open boundary as closed loops of vertex indices, each in the direction of its triangles' edges.

    A boundary half-edge a -> b is one whose twin b -> a belongs to no triangle. Raises ValueError where a
    vertex starts two boundary half-edges (two holes touching at a vertex): the loops are then ambiguous.
    """
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    half = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    n = int(t.max()) + 1 if len(t) else 0
    key = half[:, 0] * n + half[:, 1]
    twin = half[:, 1] * n + half[:, 0]
    open_edges = half[~np.isin(twin, key)]
    if len(open_edges) == 0:
        return []
    starts, counts = np.unique(open_edges[:, 0], return_counts=True)
    if np.any(counts > 1):
        raise ValueError(f"{int(np.count_nonzero(counts > 1))} vertices start two boundary edges: holes touch")
    following = dict(zip(open_edges[:, 0].tolist(), open_edges[:, 1].tolist()))
    loops = []
    while following:
        first = next(iter(following))
        loop = [first]
        nxt = following.pop(first)
        while nxt != first:
            if nxt not in following:
                raise ValueError("a boundary does not close into a loop")
            loop.append(nxt)
            nxt = following.pop(nxt)
        loops.append(np.array(loop, np.int64))
    return loops


def _clip_ears(v: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Triangulate one boundary loop by clipping its sharpest convex ear first (no new vertex).

    For a loop a_0 -> a_1 -> ... the ear at a_i is (a_{i+1}, a_i, a_{i-1}): it holds the twins of the two
    boundary edges and leaves a_{i-1} -> a_{i+1} as the loop's new edge, so the cap is wound like the mesh.
    Convex means facing the cap's normal (the area vector of the loop); the sharpest ear first follows a
    curved, elongated hole instead of cutting across it as a flat fan would."""
    p = v[loop].astype(np.float64)
    normal = np.cross(np.roll(p, -1, axis=0), p).sum(axis=0)  # twice the area vector, cap-outward
    idx = list(range(len(loop)))
    tris = []
    while len(idx) > 3:
        q = p[idx]
        prev, nxt = np.roll(q, 1, axis=0), np.roll(q, -1, axis=0)
        e1, e2 = prev - q, nxt - q
        cos = (e1 * e2).sum(1) / np.maximum(np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-30)
        convex = np.cross(q - nxt, prev - nxt) @ normal > 0
        score = np.where(convex, cos, -np.inf)  # the largest cosine is the sharpest ear
        k = int(np.argmax(score)) if np.isfinite(score).any() else int(np.argmax(cos))
        n = len(idx)
        tris.append((idx[(k + 1) % n], idx[k], idx[k - 1]))
        del idx[k]
    tris.append((idx[2], idx[1], idx[0]))
    return loop[np.array(tris, np.int64)]


def close_holes(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Close every boundary loop by ear clipping (``_clip_ears``): no new vertices, the caps wound like the
    mesh. Suits the small holes of a scan; returns (vertices, triangles), unchanged when the mesh is closed."""
    v = np.asarray(vertices)
    t = np.asarray(triangles).reshape(-1, 3)
    loops = boundary_loops(t)
    if not loops:
        return v, t
    return v, np.concatenate([t, *(_clip_ears(v, loop) for loop in loops)]).astype(t.dtype)

"""Midpoint subdivision of a triangle mesh: each triangle into four, the surface unchanged. Pure NumPy.

QUADGRAPH's density K asks for a proxy with more triangles than a low-poly mesh has (the cow's 5,804
at K = 0.5); subdividing and decimating back to the target gives it, where keeping the mesh left the
surface nodes, and so the accuracy, the same at every K.
"""
from __future__ import annotations

import numpy as np


def midpoint_subdivision(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, triangles): every edge split at its midpoint (one new vertex per edge, shared by its
    triangles, so a closed mesh stays closed), every triangle (a, b, c) into (a, ab, ca), (ab, b, bc),
    (ca, bc, c), (ab, bc, ca), which keep its orientation."""
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    if t.size == 0:
        return v.copy(), t.reshape(0, 3).copy()
    edges = np.stack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1).reshape(-1, 2)
    unique, edge_of = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
    mid = len(v) + edge_of.reshape(-1, 3)  # (T, 3): the vertex on ab, bc, ca
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    ab, bc, ca = mid[:, 0], mid[:, 1], mid[:, 2]
    out_t = np.concatenate([np.stack([a, ab, ca], 1), np.stack([ab, b, bc], 1),
                            np.stack([ca, bc, c], 1), np.stack([ab, bc, ca], 1)])
    out_v = np.concatenate([v, 0.5 * (v[unique[:, 0]] + v[unique[:, 1]])])
    return out_v, out_t

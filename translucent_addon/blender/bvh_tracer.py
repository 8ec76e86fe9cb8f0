"""Ray queries through Blender's BVH (mathutils), for the CPU references on production meshes.

Same interface as ``geometry.raycast.BruteForceTracer``; one C call per ray, so a few hundred
thousand rays take about a second, where brute force over 69k triangles would take hours.
"""
from __future__ import annotations

import numpy as np


class BVHTracer:
    def __init__(self, tris: np.ndarray):
        from mathutils.bvhtree import BVHTree

        self.tris = np.asarray(tris, dtype=np.float64).reshape(-1, 3, 3)
        verts = self.tris.reshape(-1, 3).tolist()
        polys = np.arange(len(verts)).reshape(-1, 3).tolist()
        self._tree = BVHTree.FromPolygons(verts, polys, all_triangles=True)

    def closest_hit(self, origins, dirs):
        n = len(origins)
        t = np.full(n, np.inf)
        idx = np.full(n, -1, dtype=np.int64)
        cast = self._tree.ray_cast
        for k, (o, d) in enumerate(zip(origins.tolist(), dirs.tolist())):
            loc, _, index, dist = cast(o, d)
            if index is not None:
                t[k], idx[k] = dist, index
        u = np.zeros(n)
        v = np.zeros(n)
        hit = idx >= 0
        if hit.any():
            tri = self.tris[idx[hit]]
            p = origins[hit] + t[hit, None] * dirs[hit]
            e1, e2, ep = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], p - tri[:, 0]
            d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
            dp1, dp2 = (ep * e1).sum(1), (ep * e2).sum(1)
            den = np.where(np.abs(d11 * d22 - d12 * d12) > 0, d11 * d22 - d12 * d12, 1.0)
            u[hit] = (d22 * dp1 - d12 * dp2) / den
            v[hit] = (d11 * dp2 - d12 * dp1) / den
        return t, idx, u, v

    def occluded(self, origins, dirs, t_max):
        out = np.zeros(len(origins), dtype=bool)
        cast = self._tree.ray_cast
        for k, (o, d, tm) in enumerate(zip(origins.tolist(), dirs.tolist(), np.asarray(t_max).tolist())):
            hit = cast(o, d, tm if np.isfinite(tm) else 1.0e30)
            out[k] = hit[2] is not None
        return out

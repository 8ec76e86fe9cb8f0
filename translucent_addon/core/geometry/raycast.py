"""Vectorised ray-triangle intersection (Moller-Trumbore) for CPU references.

Brute force over rays x triangles in chunks: exact and simple, meant for test
scenes of up to a few thousand triangles, not for production meshes.
"""
from __future__ import annotations

import numpy as np

_EPS = 1e-12


def _chunk_size(n_tris: int, budget: int = 4_000_000) -> int:
    return max(1, budget // max(n_tris, 1))


def closest_hit(origins: np.ndarray, dirs: np.ndarray, tris: np.ndarray,
                t_min: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Nearest hit of each ray.

    origins, dirs: (R, 3); tris: (T, 3, 3) world-space corners.
    Returns t (R,) with inf for a miss, triangle index (R,) with -1 for a miss,
    and barycentrics u, v (R,) of corners 1 and 2.
    """
    R = len(origins)
    t_best = np.full(R, np.inf)
    idx = np.full(R, -1, dtype=np.int64)
    u_best = np.zeros(R)
    v_best = np.zeros(R)
    if len(tris) == 0 or R == 0:
        return t_best, idx, u_best, v_best
    v0 = tris[:, 0]
    e1 = tris[:, 1] - v0
    e2 = tris[:, 2] - v0
    step = _chunk_size(len(tris))
    for s in range(0, R, step):
        o = origins[s : s + step, None, :]
        d = dirs[s : s + step, None, :]
        p = np.cross(d, e2[None])
        det = np.einsum("rtk,tk->rt", p, e1)
        ok = np.abs(det) > _EPS
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        tv = o - v0[None]
        u = np.einsum("rtk,rtk->rt", tv, p) * inv
        q = np.cross(tv, e1[None])
        v = np.einsum("rk,rtk->rt", d[:, 0], q) * inv
        t = np.einsum("tk,rtk->rt", e2, q) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > t_min)
        t = np.where(hit, t, np.inf)
        j = np.argmin(t, axis=1)
        rows = np.arange(len(j))
        tj = t[rows, j]
        better = tj < t_best[s : s + step]
        sl = slice(s, s + len(j))
        t_best[sl] = np.where(better, tj, t_best[sl])
        idx[sl] = np.where(better & np.isfinite(tj), j, idx[sl])
        u_best[sl] = np.where(better, u[rows, j], u_best[sl])
        v_best[sl] = np.where(better, v[rows, j], v_best[sl])
    return t_best, idx, u_best, v_best


def occluded(origins: np.ndarray, dirs: np.ndarray, t_max: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """True where a triangle lies on the ray between t = 0 and t_max (exclusive)."""
    t, _, _, _ = closest_hit(origins, dirs, tris, t_min=0.0)
    return t < t_max


class BruteForceTracer:
    """Ray queries against a fixed triangle set, by brute force (small scenes)."""

    def __init__(self, tris: np.ndarray):
        self.tris = np.asarray(tris, dtype=np.float64).reshape(-1, 3, 3)

    def closest_hit(self, origins: np.ndarray,
                    dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return closest_hit(origins, dirs, self.tris)

    def occluded(self, origins: np.ndarray, dirs: np.ndarray, t_max: np.ndarray) -> np.ndarray:
        return occluded(origins, dirs, t_max, self.tris)

"""TEXTURE_SPACE's far field: the throughput of distant sources gathered through a cluster hierarchy (pure).

Lensch 2002 keeps F_ij = A_i / 3 R_d(|v_i - v_j|) C(h_ij) for every pair above a threshold and drops the rest
(Sec. 6.2). Each dropped pair is small, but a receiver on the dark side of a back-lit part gathers its light
from thousands of them: on a 10 cm marble figure the kept pairs carried a median 29-55 % of the red light that
reaches the unlit side (1 % at the tenth percentile), and a finer proxy (smaller A_i) dropped more.

Here the sources are grouped instead (a tree code, Barnes & Hut 1986): level l clusters the vertices by a
voxel grid of side ``s_1 2^l`` and by the axis their normal points along (six classes, so that a cluster is one
side of a part: lit and unlit faces are not pooled). A receiver j takes cluster P whole once P is far enough,
|v_j - x_P| >= rho_P (1 + 1 / THETA) (x_P the area-weighted centroid, rho_P the largest member distance from it),
and opens it otherwise; the vertices of level-0 clusters it still opens are its near pairs, kept one by one
as Lensch's F. A far entry is

    G_jP = sum_(c in P's children) W_c R_d(|x_c - v_j|) C((v_j - x_c) . n_j) / W_P,      W = sum A_i / 3,

(level 0's children are its vertices, so there it is exact) and multiplies the cluster's power
E_P = sum_(i in P) A_i / 3 E^g_i, which each frame gathers from the vertices (one point per vertex and level).
Every source reaches every receiver exactly once: near, or in one cluster.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.physics import slab_through

THETA = 0.35  # opening ratio: a cluster is taken whole beyond rho (1 + 1 / THETA) of its centroid
TOP_CLUSTERS = 48  # levels are added until a level has at most this many clusters
# Level 0's voxel side in sqrt(median A_v) (about 2.6 edges): on the 10 cm marble figure (18k vertices) 1.9M near
# pairs and 8.9M far entries against 31M thresholded pairs, the dark side's light within 1-9 % of all pairs'
# (median 0.5-5 %) where the thresholded pairs kept 29-55 %.
S1_AREAS = 1.6
_CHUNK = 500_000


@dataclasses.dataclass(frozen=True)
class Hierarchy:
    """Nested vertex clusters: ``of[l]`` (V,) the cluster of each vertex at level l (0 .. C_l - 1), numbered
    per level; ``offset[l]`` the first slot of level l in the run's cluster image; per cluster its power weight W
    (sum of A_i / 3), centroid x (mm) and radius rho (mm)."""

    of: tuple
    offset: tuple
    W: tuple
    x: tuple
    rho: tuple
    near: tuple  # per cluster: within this distance of x it is always opened (``build``'s ``near_mm``)

    @property
    def levels(self) -> int:
        return len(self.of)

    @property
    def count(self) -> int:
        return int(self.offset[-1] + len(self.W[-1])) if self.of else 0

    def children(self, level: int):
        """CSR of each level-``level`` cluster's children, (start, ids): level - 1 clusters, or at level 0 its
        vertices."""
        if level == 0:
            return _children(self.of[0], len(self.W[0]))
        parent = np.zeros(len(self.W[level - 1]), np.int64)
        parent[self.of[level - 1]] = self.of[level]  # through any member vertex (levels nest)
        return _children(parent, len(self.W[level]))

    def slots(self) -> np.ndarray:
        """(V, L) int32: each vertex's cluster slot at every level (what the bake stores)."""
        return np.stack([self.of[l] + self.offset[l] for l in range(self.levels)], axis=1).astype(np.int32)


def normal_class(n: np.ndarray) -> np.ndarray:
    """0..5: the axis (x, y, z) a normal points along most, and its sign."""
    axis = np.argmax(np.abs(n), axis=1)
    sign = np.take_along_axis(n, axis[:, None], axis=1)[:, 0] < 0.0
    return 2 * axis + sign


def build(v_mm: np.ndarray, normals: np.ndarray, A_v: np.ndarray, near_mm: np.ndarray,
          s_1: float | None = None) -> Hierarchy:
    """Level 0 of side ``s_1`` (default S1_AREAS sqrt(median A_v)), each next level twice as coarse (nested: the
    same grid origin), until a level has at most TOP_CLUSTERS clusters or stops merging. ``near_mm`` (V,): a
    source vertex i is never in a cluster taken whole closer than this to the receiver (the pairs that Lensch's
    near-field machinery treats one by one: hats across thin parts, the blending ring)."""
    v = np.asarray(v_mm, np.float64)
    if s_1 is None:
        s_1 = S1_AREAS * float(np.sqrt(np.median(A_v)))
    w = np.asarray(A_v, np.float64) / 3.0
    klass = normal_class(np.asarray(normals, np.float64)).astype(np.int64)
    origin = v.min(axis=0)
    of, offset, W, x, rho, near = [], [], [], [], [], []
    side, slot = float(s_1), 0
    while True:
        cell = np.floor((v - origin) / side).astype(np.int64)
        key = ((cell[:, 0] * 1_000_003 + cell[:, 1]) * 1_000_003 + cell[:, 2]) * 6 + klass
        _, ids = np.unique(key, return_inverse=True)
        C = int(ids.max()) + 1
        W_l = np.bincount(ids, w, C)
        # the area-weighted centroid; a cluster of vertices without area (loose ones) its plain mean
        massless = W_l <= 0.0
        weight = np.where(massless[ids], 1.0, w)
        x_l = (np.stack([np.bincount(ids, weight * v[:, k], C) for k in range(3)], axis=1)
               / np.bincount(ids, weight, C)[:, None])
        rho_l = np.zeros(C)
        np.maximum.at(rho_l, ids, np.linalg.norm(v - x_l[ids], axis=1))
        near_l = np.zeros(C)
        np.maximum.at(near_l, ids, np.asarray(near_mm, np.float64))
        if of and C == len(W[-1]):  # no longer merging (fewer than six sides and voxels left)
            break
        of.append(ids.astype(np.int64))
        offset.append(slot)
        W.append(W_l)
        x.append(x_l)
        rho.append(rho_l)
        near.append(near_l + rho_l)
        slot += C
        if C <= TOP_CLUSTERS:
            break
        side *= 2.0
    return Hierarchy(tuple(of), tuple(offset), tuple(W), tuple(x), tuple(rho), tuple(near))


def _children(parent_of_child: np.ndarray, parents: int):
    """CSR of the children of each parent: (start (P+1,), child ids sorted by parent)."""
    order = np.argsort(parent_of_child, kind="stable")
    counts = np.bincount(parent_of_child, minlength=parents)
    return np.concatenate([[0], np.cumsum(counts)]), order


def _expand(j: np.ndarray, P: np.ndarray, start: np.ndarray, members: np.ndarray):
    """Pairs (j, child) for every child of each P."""
    counts = start[P + 1] - start[P]
    jj = np.repeat(j, counts)
    first = np.repeat(start[P], counts)
    within = np.arange(len(jj)) - np.repeat(np.cumsum(counts) - counts, counts)
    return jj, members[first + within]


def interactions(h: Hierarchy, v_mm: np.ndarray):
    """The receiver's partition of the sources: (near (dst, src) vertex pairs, far (dst, level, cluster) triples),
    src != dst. Walks the hierarchy from the top, taking a cluster whole where it is far and opening it
    otherwise."""
    v = np.asarray(v_mm, np.float64)
    V = len(v)
    top = h.levels - 1  # ``build`` makes at least one level
    C = len(h.W[top])
    j = np.repeat(np.arange(V, dtype=np.int64), C)
    P = np.tile(np.arange(C, dtype=np.int64), V)
    far_dst, far_level, far_cluster = [], [], []
    for level in range(top, -1, -1):
        d = np.linalg.norm(v[j] - h.x[level][P], axis=1)
        # strict: a cluster holding j (d <= rho) is never taken, a single vertex (rho = 0) beyond its near reach is
        take = (d > h.rho[level][P] * (1.0 + 1.0 / THETA)) & (d > h.near[level][P])
        far_dst.append(j[take])
        far_level.append(np.full(int(take.sum()), level, np.int64))
        far_cluster.append(P[take])
        j, P = _expand(j[~take], P[~take], *h.children(level))
    keep = j != P
    return (j[keep], P[keep]), (np.concatenate(far_dst), np.concatenate(far_level), np.concatenate(far_cluster))


def far_weights(h: Hierarchy, v_mm: np.ndarray, normals: np.ndarray, A_v: np.ndarray, material,
                dst: np.ndarray, level: np.ndarray, cluster: np.ndarray):
    """(G_jP (n, 3) per unit of the cluster's power: its children's R_d C at the receiver, weighed by their W;
    the depth of the cluster below the receiver's tangent plane (n,), its children's mean weighed by their light
    in green, which says how much of it crossed the part)."""
    v = np.asarray(v_mm, np.float64)
    n = np.asarray(normals, np.float64)
    w_v = np.asarray(A_v, np.float64) / 3.0
    slab = slab_through.constants(material.sigma_a, material.sigma_s_prime, material.eta)
    out = np.zeros((len(dst), 3))
    out_depth = np.zeros(len(dst))
    for l in range(h.levels):
        at = np.flatnonzero(level == l)
        if len(at) == 0:
            continue
        start, members = h.children(l)
        cx, cw = (v, w_v) if l == 0 else (h.x[l - 1], h.W[l - 1])
        for a in range(0, len(at), _CHUNK // 8):
            rows = at[a:a + _CHUNK // 8]
            pair, child = _expand(np.arange(len(rows)), cluster[rows], start, members)
            jv = dst[rows][pair]
            r = np.linalg.norm(cx[child] - v[jv], axis=1)
            depth = np.einsum("ij,ij->i", v[jv] - cx[child], n[jv])
            f = cw[child, None] * material.R_d(r) * slab_through.factor(depth, *slab)
            sums = np.stack([np.bincount(pair, f[:, c], len(rows)) for c in range(3)], axis=1)
            W_P = h.W[l][cluster[rows], None]
            out[rows] = np.divide(sums, W_P, out=np.zeros_like(sums), where=W_P > 0.0)  # no area: no power either
            deep = np.bincount(pair, f[:, 1] * np.maximum(depth, 0.0), len(rows))
            out_depth[rows] = np.divide(deep, sums[:, 1], out=np.zeros(len(rows)), where=sums[:, 1] > 0.0)
    return out, out_depth

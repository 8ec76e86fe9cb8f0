"""How much of the sky a surface point sees past its own object: cosine-weighted visibility. Pure NumPy.

The world's light reaches a surface point over its hemisphere, less what the object itself hides (the
inside of a bent leg, the chest under a head, the gap between two ears). The irradiance passes take the
world from spherical harmonics of the unoccluded sky; the visibility V = (1 / pi) int_H v(w) cos dw
scales it (ambient occlusion: exact for a uniform sky, the usual approximation for a smooth one).

The object is voxelised once (``occupancy``: z-column parity against the closed surface) and rays are
marched through the voxels (``cosine_visibility``), so the cost does not grow with the triangle count.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Occupancy:
    inside: np.ndarray  # (nx, ny, nz) bool: voxel centres inside the surface
    origin: np.ndarray  # (3,) corner of voxel (0, 0, 0)
    cell: float  # voxel edge

    def lookup(self, points: np.ndarray) -> np.ndarray:
        """Inside (nearest voxel) for points (..., 3); False outside the grid."""
        ijk = np.floor((points - self.origin) / self.cell).astype(np.int64)
        shape = np.array(self.inside.shape)
        ok = ((ijk >= 0) & (ijk < shape)).all(axis=-1)
        ijk = np.clip(ijk, 0, shape - 1)
        return ok & self.inside[ijk[..., 0], ijk[..., 1], ijk[..., 2]]


def occupancy(vertices: np.ndarray, triangles: np.ndarray, resolution: int = 96) -> Occupancy:
    """Voxels of a closed triangle surface: the longest side of its bounds in ``resolution`` cells (one
    cell of margin around), a voxel inside where a vertical line through its centre has crossed the
    surface an odd number of times below it."""
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    cell = float((hi - lo).max()) / resolution
    origin = lo - cell
    n = np.ceil((hi - lo) / cell).astype(int) + 2
    # Column centres, nudged off the grid's rational points so that no line runs through an edge.
    cx = origin[0] + (np.arange(n[0]) + 0.5 + 1.3e-4) * cell
    cy = origin[1] + (np.arange(n[1]) + 0.5 + 2.9e-4) * cell
    p = v[t]  # (T, 3, 3)
    i0 = np.clip(np.ceil((p[:, :, 0].min(1) - cx[0]) / cell), 0, n[0] - 1).astype(int)
    i1 = np.clip(np.floor((p[:, :, 0].max(1) - cx[0]) / cell), -1, n[0] - 1).astype(int)
    j0 = np.clip(np.ceil((p[:, :, 1].min(1) - cy[0]) / cell), 0, n[1] - 1).astype(int)
    j1 = np.clip(np.floor((p[:, :, 1].max(1) - cy[0]) / cell), -1, n[1] - 1).astype(int)
    ni, nj = np.maximum(i1 - i0 + 1, 0), np.maximum(j1 - j0 + 1, 0)
    count = ni * nj
    tri = np.repeat(np.arange(len(t)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    ii = i0[tri] + k % np.maximum(ni[tri], 1)
    jj = j0[tri] + k // np.maximum(ni[tri], 1)
    a, b, c = p[tri, 0], p[tri, 1], p[tri, 2]
    x, y = cx[ii], cy[jj]
    # 2-D barycentrics of the column in the triangle's projection.
    den = (b[:, 1] - c[:, 1]) * (a[:, 0] - c[:, 0]) + (c[:, 0] - b[:, 0]) * (a[:, 1] - c[:, 1])
    safe = np.where(np.abs(den) > 1e-300, den, 1.0)
    l1 = ((b[:, 1] - c[:, 1]) * (x - c[:, 0]) + (c[:, 0] - b[:, 0]) * (y - c[:, 1])) / safe
    l2 = ((c[:, 1] - a[:, 1]) * (x - c[:, 0]) + (a[:, 0] - c[:, 0]) * (y - c[:, 1])) / safe
    l3 = 1.0 - l1 - l2
    hit = (np.abs(den) > 1e-300) & (l1 >= 0) & (l2 >= 0) & (l3 >= 0)
    z = l1 * a[:, 2] + l2 * b[:, 2] + l3 * c[:, 2]
    # A crossing at height z toggles the voxels whose centres lie above it.
    kz = np.clip(np.ceil((z - origin[2]) / cell - 0.5), 0, n[2]).astype(int)
    toggles = np.zeros((n[0], n[1], n[2] + 1), np.int32)
    np.add.at(toggles, (ii[hit], jj[hit], kz[hit]), 1)
    inside = (np.cumsum(toggles, axis=2)[:, :, :n[2]] % 2) == 1
    return Occupancy(inside, origin, cell)


def hemisphere_directions(count: int) -> np.ndarray:
    """(count, 3) cosine-weighted directions about +z, stratified (Hammersley points, z = sqrt(1 - u))."""
    k = np.arange(count)
    u = (k + 0.5) / count
    bits = k.copy()
    v = np.zeros(count)
    f = 0.5
    while bits.any():
        v += f * (bits & 1)
        bits >>= 1
        f *= 0.5
    r, phi = np.sqrt(u), 2.0 * np.pi * v
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1.0 - u)], axis=1)


def cosine_visibility(points: np.ndarray, normals: np.ndarray, occ: Occupancy, directions: int = 32,
                      chunk: int = 4096) -> np.ndarray:
    """V per point, (N,): the fraction of ``directions`` cosine-weighted rays about its normal that leave
    the grid without entering a voxel inside. Rays start two voxels out along the normal (the point's
    own voxels are the surface) and step half a voxel."""
    points = np.asarray(points, np.float64)
    normals = np.asarray(normals, np.float64)
    normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    local = hemisphere_directions(directions)
    # An orthonormal frame about each normal (Duff et al. 2017).
    s = np.where(normals[:, 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (s + normals[:, 2])
    b = normals[:, 0] * normals[:, 1] * a
    tangent = np.stack([1.0 + s * normals[:, 0] ** 2 * a, s * b, -s * normals[:, 0]], axis=1)
    bitangent = np.stack([b, s + normals[:, 1] ** 2 * a, -normals[:, 1]], axis=1)
    extent = np.array(occ.inside.shape) * occ.cell
    steps = np.arange(0.0, float(np.linalg.norm(extent)), 0.5 * occ.cell)
    V = np.empty(len(points))
    for start in range(0, len(points), chunk):
        sl = slice(start, start + chunk)
        d = (local[None, :, 0:1] * tangent[sl, None] + local[None, :, 1:2] * bitangent[sl, None]
             + local[None, :, 2:3] * normals[sl, None])  # (n, D, 3)
        o = np.broadcast_to(points[sl, None] + 2.0 * occ.cell * normals[sl, None], d.shape)
        blocked = np.zeros(d.shape[:2], bool)
        active = np.ones(d.shape[:2], bool)  # neither blocked nor out of the grid (convex: no way back)
        lo, hi = occ.origin, occ.origin + extent
        for t in steps:
            if not active.any():
                break
            x = o[active] + t * d[active]
            out = ((x < lo) | (x > hi)).any(axis=1)
            hit = occ.lookup(x)
            idx = np.nonzero(active)
            blocked[idx[0][hit], idx[1][hit]] = True
            active[idx[0][hit | out], idx[1][hit | out]] = False
        V[sl] = 1.0 - blocked.mean(axis=1)
    return V

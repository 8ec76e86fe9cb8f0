"""TEXTURE_SPACE precomputation (Lensch et al. 2002, Sec. 5): local kernels, global throughput, blending.

Pure (NumPy, SciPy). Inputs: the proxy mesh in mm, its texel atlas (``atlas.py``) and the medium.
The radiosity leaving a surface point is B(x_o) = int_S E(x_i) R_d(x_i, x_o) dx_i (Lensch Eq. 2),
discretised twice (Sec. 4):

* global, on the proxy's vertices (Sec. 5.2): hat functions psi_v, their duals
  psi~_v = 3 / A_v (4 beta_v - 1) (A_v the area of the triangles around v), the vertex irradiance
  E^g_v = sum_texels psi~_v A E (Eq. 10) and throughput F_ij = A_i / 3 R_d(v_i, v_j) C(h_ij) (C: light
  through thin parts, ``physics.slab_through``, h_ij the depth of v_i below v_j's tangent plane; entries below
  ``THRESHOLD`` dropped); the diagonal is set to zero (F^0, Sec. 5.4);
* local, on texels (Sec. 5.3): a 7x7 kernel per surface texel, K_o(i) = A_i R_d(x_o, x_i). R_d
  peaks within one texel, so the centre tap takes the closed-form integral of R_d over a disk of
  the texel's area instead of the centre value.

Blending (Sec. 5.4, Eq. 9): B = B^l + B^d + B^g0. Per surface texel i, three weights w_v(i) per
colour channel distribute its irradiance to the direct radiosity B^d of its triangle's vertices,
chosen by least squares so that the global response of a unit impulse at i matches the 9x9
kernel on the ring Gamma around the 7x7 one. Then the interpolated global response
(B^g0 + B^d of the impulse) is subtracted from the 7x7 kernel, so that inside it the sum is the
kernel itself. Kernels are stored gathered: row o holds the weights of the 49 texels around o.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from ...core.geometry.mesh_checks import triangle_areas
from ...core.geometry.mesh_measures import subtriangle_centroids, vertex_areas, vertex_normals
from ...core.physics import slab_through
from ...core.physics.lut import profile_model
from . import far_field
from .atlas import TexelAtlas

THRESHOLD = 1e-5  # throughput factors below this are dropped (Lensch 6.2)
# A far cluster's entry is dropped below THRESHOLD times this (its light under unit irradiance): a receiver on the
# dark side of a part gathers 1e-3 of the lit side's light from hundreds of such entries (``far_field``).
FAR_THRESHOLD = 1e-4
LOCAL = 3  # 7x7 kernels: offsets -3..3
RING = 4  # the 9x9 kernel's boundary Gamma: offsets with max(|dx|, |dy|) = 4
FIT_OUTER = None  # outermost ring of the blending fit; None: from the vertex spacing
# Tikhonov weight of the blending least squares, relative to the mean diagonal of the normal
# matrix with a floor: where Gamma barely touches a vertex's hat, its weight is not determined.
RIDGE = 1e-3
RIDGE_FLOOR = 1e-2
_CHUNK = 250_000  # texel pairs per vectorised block


def _offsets(half: int, ring_only: bool = False) -> np.ndarray:
    d = np.arange(-half, half + 1)
    dx, dy = np.meshgrid(d, d, indexing="xy")
    off = np.stack([dx.ravel(), dy.ravel()], axis=1)
    if ring_only:
        off = off[np.max(np.abs(off), axis=1) == half]
    return off.astype(np.int32)


LOCAL_OFFSETS = _offsets(LOCAL)  # (49, 2), row-major from (-3, -3); index 24 is the centre
RING_OFFSETS = _offsets(RING, ring_only=True)  # (32, 2)


@dataclasses.dataclass(frozen=True)
class Material:
    """The medium of a bake, with R_d read from a table: the bake evaluates it some 10^8 times."""

    sigma_a: tuple
    sigma_s_prime: tuple
    eta: float
    profile: str = "EXACT"  # the radial profile (``physics.lut.PROFILES``)

    def R_d_exact(self, r_mm):
        """The profile itself, not the table's interpolation."""
        return profile_model(self.profile).R_d(np.asarray(r_mm, np.float64)[:, None],
                                               np.asarray(self.sigma_a, np.float64),
                                               np.asarray(self.sigma_s_prime, np.float64), self.eta)

    def R_d(self, r_mm):
        """(n, 3) profile at distances r (n,) in mm: linear in sqrt(r) between 2^14 table samples out
        out to 40 / sigma_tr of the slowest channel; exact beyond."""
        r = np.asarray(r_mm, np.float64)
        root, table, slope = _profile_table(self)
        u = np.sqrt(r) * ((len(table) - 1) / root)
        inside = u <= len(table) - 1
        if inside.all():
            i = u.astype(np.int64)
            return table[i] + (u - i)[:, None] * slope[i]
        out = np.empty((len(r), 3))
        i = u[inside].astype(np.int64)
        out[inside] = table[i] + (u[inside] - i)[:, None] * slope[i]
        out[~inside] = self.R_d_exact(r[~inside])
        return out

    def R_d_disk(self, radius_mm):
        return profile_model(self.profile).R_d_disk(np.asarray(radius_mm, np.float64)[:, None],
                                                    np.asarray(self.sigma_a, np.float64),
                                                    np.asarray(self.sigma_s_prime, np.float64), self.eta)


TABLE_SAMPLES = 1 << 14
TABLE_REACH_MAX_MM = 1000.0  # beyond the 40 / sigma_tr of every measured material (marble: 330 mm)


@functools.lru_cache(maxsize=8)
def _profile_table(material: Material):
    """(sqrt of the table's reach, R_d at r = (k / (n-1) * sqrt(reach))^2, the slope to the next
    sample (zero after the last)): interpolation error < 1e-4."""
    sigma_t = np.asarray(material.sigma_a) + np.asarray(material.sigma_s_prime)
    sigma_tr = np.sqrt(3.0 * np.asarray(material.sigma_a) * sigma_t)
    # R_d is e^-40 of its peak scale at 40 / sigma_tr; a medium that does not absorb (sigma_tr = 0) has
    # no such reach, and past TABLE_REACH_MAX_MM R_d is evaluated exactly.
    with np.errstate(divide="ignore"):
        reach = float(min(np.max(40.0 / sigma_tr), TABLE_REACH_MAX_MM))
    root = math.sqrt(reach)
    r = (np.linspace(0.0, root, TABLE_SAMPLES)) ** 2
    table = material.R_d_exact(r)
    return root, table, np.diff(table, axis=0, append=table[-1:])


def dual_weights(atlas: TexelAtlas, triangles: np.ndarray, A_v: np.ndarray):
    """Per surface texel: its triangle's vertices (n, 3) and psi~_v A(u, v) (n, 3) (Lensch Eq. 10)."""
    n = atlas.surface_count
    verts = np.asarray(triangles, np.int64)[atlas.triangle[:n]]
    beta = atlas.bary[:n].astype(np.float64)
    weights = 3.0 / A_v[verts] * (4.0 * beta - 1.0) * atlas.area_mm2[:n, None]
    return verts.astype(np.int32), weights


def throughput_radius(material: Material, area_mm2: float, threshold: float = THRESHOLD) -> float:
    """Distance beyond which A / 3 R_d(r) < threshold in every channel (Auto's estimate of a bake's entries)."""
    return float(_reaches(material, np.array([float(area_mm2)]), threshold)[0])


def _reaches(material: Material, areas_mm2: np.ndarray, threshold: float) -> np.ndarray:
    """``throughput_radius`` for each area: the largest r on a fine geometric grid where the bound holds."""
    r = np.geomspace(1e-3, 1e5, 4097)
    peak = material.R_d(r).max(axis=1)  # (n,): largest channel
    level = threshold / (np.asarray(areas_mm2, np.float64) / 3.0)  # (m,): the bound on the profile
    above = peak[None, :] >= level[:, None]
    last = np.where(above.any(axis=1), len(r) - 1 - np.argmax(above[:, ::-1], axis=1), 0)
    nxt = np.minimum(last + 1, len(r) - 1)
    # the crossing between the last grid point above and the next, log-linear in both
    with np.errstate(divide="ignore", invalid="ignore"):
        lo, hi = np.log(peak[last]), np.log(np.maximum(peak[nxt], 1e-300))
        t = np.clip(np.where(hi < lo, (lo - np.log(level)) / (lo - hi), 1.0), 0.0, 1.0)
    return np.exp(np.log(r[last]) + t * (np.log(r[nxt]) - np.log(r[last])))


HAT_QUADRATURE = 3  # sub-triangles per edge when integrating a hat against R_d
# Across a thin part (normals at more than 90 degrees) within this many sqrt(A_i) the hat is
# integrated: no local kernel covers that light, and R_d changes across one hat there.
ACROSS_REACH = 3.0


def hat_integrals(vertices, triangles, src, dst, material, quadrature: int = HAT_QUADRATURE):
    """int psi_i(x) R_d(|x - v_j|) dx over the triangles around i (sub-triangle centroids), (n, 3)."""
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    inc_vertex = t.ravel()
    order = np.argsort(inc_vertex, kind="stable")
    inc_tri, inc_k = order // 3, order % 3
    degree = np.bincount(inc_vertex, minlength=len(v))
    start = np.concatenate([[0], np.cumsum(degree)])
    uv = subtriangle_centroids(quadrature)
    bary = np.stack([1.0 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]], axis=1)
    area = triangle_areas(v, t)
    tri_points = np.einsum("qc,tcd->tqd", bary, v[t])  # (T, q, 3): the quadrature points of every triangle
    out = np.zeros((len(src), 3))
    step = max(1, _CHUNK // (8 * len(bary)))
    for a in range(0, len(src), step):
        i, j = src[a:a + step], dst[a:a + step]
        pair = np.repeat(np.arange(len(i)), degree[i])
        local = np.arange(len(pair)) - np.repeat(np.cumsum(degree[i]) - degree[i], degree[i])
        inc = start[i][pair] + local
        tri, k = inc_tri[inc], inc_k[inc]
        # Neighbouring sources share triangles: R_d at a triangle's points from v_j is evaluated once.
        seen, item = np.unique(tri * len(v) + j[pair], return_inverse=True)
        r = np.linalg.norm(tri_points[seen // len(v)] - v[seen % len(v)][:, None, :], axis=2)
        R = material.R_d(r.ravel()).reshape(len(seen), len(bary), 3)
        weight = (area[tri] / len(bary))[:, None] * bary[:, k].T  # beta_i at each point
        sums = np.einsum("pqc,pq->pc", R[item], weight)
        for c in range(3):
            out[a:a + step, c] = np.bincount(pair, weights=sums[:, c], minlength=len(i))
    return out


def _across(n_src, n_dst, r, A_src) -> np.ndarray:
    """Pairs across a thin part: vertex normals more than 90 degrees apart, closer than
    ACROSS_REACH sqrt(A_i) (broadcasting over leading axes; normals on the last)."""
    return (np.sum(n_src * n_dst, axis=-1) < 0.0) & (r < ACROSS_REACH * np.sqrt(A_src))


def throughput(vertices_mm: np.ndarray, A_v: np.ndarray, material: Material, threshold: float = THRESHOLD,
               triangles: np.ndarray | None = None):
    """F^0 gathered by receiver as CSR, near pairs one by one (Lensch 5.2) and far sources by cluster
    (``far_field``): returns ((indptr (V+1,) int32, indices (nnz,) int32, data (nnz, 3) float32), depth (nnz,)
    float32 of each source below its receiver's tangent plane (how much of its light crossed a part), FarField).

    F_ij = A_i / 3 R_d(|v_i - v_j|) C(h_ij), Lensch's one-point rule for int int psi_i R_d psi~_j. Integrating
    the hat exactly looks more accurate but is not: it spreads the response of light entering
    near v_i over the whole hat, into the 7x7 neighbourhood of v_j that the local kernels
    already cover (measured on a plate: +14 to +32 % instead of +2 to +5 %). Across a thin part
    (given ``triangles``: vertex normals more than 90 degrees apart, closer than ``ACROSS_REACH``
    sqrt(A_i)) no kernel covers the light, and there the hat is integrated. The diagonal is absent (F^0 of
    Sec. 5.4); near entries whose largest channel is below ``threshold`` are dropped, far ones (their light
    under unit irradiance) below ``threshold`` FAR_THRESHOLD. C (``physics.slab_through``) is light through
    thin parts, h_ij the depth of v_i below v_j's tangent plane; without ``triangles`` there are no normals
    and C = 1.
    """
    v = np.asarray(vertices_mm, np.float64)
    A_v = np.asarray(A_v, np.float64)
    V = len(v)
    n = vertex_normals(v, np.asarray(triangles, np.int64)) if triangles is not None else np.zeros((V, 3))
    # Pairs across a thin part are hat-integrated and the blending ring reads F one pair at a time: those stay near.
    hierarchy = far_field.build(v, n, A_v, near_mm=ACROSS_REACH * np.sqrt(A_v))
    (dst, src), (far_dst, far_level, far_cluster) = far_field.interactions(hierarchy, v)
    data = np.empty((len(src), 3), np.float32)
    depth = np.zeros(len(src), np.float32)  # of v_i below v_j's tangent plane, mm (0 above it)
    slab = slab_through.constants(material.sigma_a, material.sigma_s_prime, material.eta)
    across = []
    for a in range(0, len(src), _CHUNK):
        b = min(a + _CHUNK, len(src))
        r = np.linalg.norm(v[src[a:b]] - v[dst[a:b]], axis=1)
        data[a:b] = A_v[src[a:b], None] / 3.0 * material.R_d(r)
        if triangles is not None:
            across.append(a + np.flatnonzero(_across(n[src[a:b]], n[dst[a:b]], r, A_v[src[a:b]])))
            # Light through thin parts: v_i lies h below v_j's tangent plane (physics.slab_through).
            depth[a:b] = np.maximum(np.einsum("ij,ij->i", v[dst[a:b]] - v[src[a:b]], n[dst[a:b]]), 0.0)
            data[a:b] *= slab_through.factor(depth[a:b], *slab)
    if across:
        across = np.concatenate(across)
        data[across] = (hat_integrals(v, triangles, src[across], dst[across], material)
                        * slab_through.factor(depth[across], *slab))
    *near, near_depth = _csr(V, dst, src, data, threshold, depth)
    G, G_depth = far_field.far_weights(hierarchy, v, n, A_v, material, far_dst, far_level, far_cluster)
    slots = np.asarray(hierarchy.offset)[far_level] + far_cluster
    power = np.concatenate(hierarchy.W)[slots]
    keep = (G * power[:, None]).max(axis=1) >= threshold * FAR_THRESHOLD
    far = FarField(*_csr(V, far_dst[keep], slots[keep], G[keep].astype(np.float32), 0.0,
                         G_depth[keep].astype(np.float32)), hierarchy.slots())
    return tuple(near), near_depth, far


def _csr(V: int, dst: np.ndarray, src: np.ndarray, data: np.ndarray, threshold: float, *extra: np.ndarray):
    """(indptr, indices, data, *extra) by receiver, columns ascending; entries whose largest channel is below
    ``threshold`` dropped."""
    keep = data.max(axis=1) >= threshold
    dst, src, data = dst[keep], src[keep], data[keep]
    order = np.lexsort((src, dst))
    indptr = np.zeros(V + 1, np.int64)
    np.add.at(indptr, dst + 1, 1)
    return (np.cumsum(indptr).astype(np.int32), src[order].astype(np.int32), np.ascontiguousarray(data[order]),
            *(np.ascontiguousarray(e[keep][order]) for e in extra))


@dataclasses.dataclass(frozen=True)
class FarField:
    """The far sources of each receiver (``far_field``): G as CSR over cluster slots, and each vertex's slot at
    every level (the run gathers the clusters' power E_P = sum A_i / 3 E^g_i through it)."""

    indptr: np.ndarray  # (V+1,) int32
    indices: np.ndarray  # (m,) int32: cluster slots
    data: np.ndarray  # (m, 3) float32: per unit of the cluster's power
    depth: np.ndarray  # (m,) float32: below the receiver's tangent plane, mm (``far_field.far_weights``)
    clusters: np.ndarray  # (V, L) int32


def _taps(atlas: TexelAtlas, centres: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(len(centres), len(offsets)) texel list indices of the texels at centre + offset, -1 if none."""
    image = atlas.index_image()
    xy = atlas.texel_xy[centres][:, None, :] + offsets[None, :, :]
    inside = (xy[..., 0] >= 0) & (xy[..., 0] < atlas.width) & (xy[..., 1] >= 0) & (xy[..., 1] < atlas.height)
    out = np.full(xy.shape[:2], -1, np.int32)
    out[inside] = image[xy[..., 1][inside], xy[..., 0][inside]]
    return out


def _profile_pairs(atlas: TexelAtlas, material: Material, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """R_d between the geometry of texels a and b, (n, 3)."""
    r = np.linalg.norm(atlas.position_mm[a].astype(np.float64) - atlas.position_mm[b], axis=1)
    return material.R_d(r)


class _GlobalResponse:
    """Interpolated global response at texel o of a unit irradiance on surface texel s (Eq. 9-12).

    B^g0(o) = sum_j beta_j(o) sum_k d_k(s) F^0_kj and phi_k(o) = sum_j beta_j(o) [v_j(o) = v_k(s)],
    the hat of s's vertex k seen at o (what B^d of weight w_k adds there). F^0 between the six
    vertices of a triangle pair is evaluated once per distinct pair, as ``throughput`` stores it
    (the point rule, entries under the threshold dropped, the hat integral across thin parts, looked
    up), so that the correction removes exactly what the run adds.
    """

    def __init__(self, atlas, triangles, vertices_mm, A_v, dual, material, throughput_csr,
                 threshold: float = THRESHOLD, gain=None):
        self.atlas, self.material, self.threshold = atlas, material, threshold
        self.t = np.asarray(triangles, np.int64)
        self.v = np.asarray(vertices_mm, np.float64)
        self.V = len(self.v)
        self.A_v = A_v
        self.normals = vertex_normals(self.v, self.t)
        self.slab = slab_through.constants(material.sigma_a, material.sigma_s_prime, material.eta)
        indptr, F_indices, self.F_data = throughput_csr
        rows = np.repeat(np.arange(self.V, dtype=np.int64), np.diff(indptr))
        # Sorted keys receiver * V + source of the stored entries (rows by receiver, columns ascending).
        self.F_keys = rows * self.V + F_indices
        r = np.linalg.norm(self.v[F_indices] - self.v[rows], axis=1)
        self.has_across = bool(_across(self.normals[F_indices], self.normals[rows], r, self.A_v[F_indices]).any())
        self.gain = gain  # (V, 3): the uniform-light calibration of each receiving vertex, or None
        self.dual = dual  # (n_surface, 3)
        self._edges = None

    def shares_vertex(self, s: np.ndarray, o: np.ndarray) -> np.ndarray:
        """(n,) bool: the triangles of texels s and o share a vertex (else phi of the pair is zero)."""
        out = np.empty(len(s), bool)
        for a in range(0, len(s), 4 * _CHUNK):
            Vs = self.t[self.atlas.triangle[s[a:a + 4 * _CHUNK]]]
            Vo = self.t[self.atlas.triangle[o[a:a + 4 * _CHUNK]]]
            out[a:a + 4 * _CHUNK] = (Vs[:, :, None] == Vo[:, None, :]).any(axis=(1, 2))
        return out

    def __call__(self, s: np.ndarray, o: np.ndarray):
        """(B^g0 (n, 3 channels), phi (n, 3 vertices)) for pairs (surface texel s, texel o)."""
        at = self.atlas
        tri_s, tri_o = at.triangle[s].astype(np.int64), at.triangle[o].astype(np.int64)
        key = tri_s * len(self.t) + tri_o
        unique, inverse = np.unique(key, return_inverse=True)
        us, uo = unique // len(self.t), unique % len(self.t)
        Vs, Vo = self.t[us], self.t[uo]  # (U, 3)
        r = np.linalg.norm(self.v[Vs][:, :, None, :] - self.v[Vo][:, None, :, :], axis=3)  # (U, 3, 3)
        F = (self.A_v[Vs][:, :, None, None] / 3.0) * self.material.R_d(r.ravel()).reshape(len(unique), 3, 3, 3)
        depth = np.einsum("uabk,ubk->uab", self.v[Vo][:, None, :, :] - self.v[Vs][:, :, None, :], self.normals[Vo])
        F *= slab_through.factor(depth, *self.slab)  # as ``throughput`` stores it
        F[F.max(axis=3) < self.threshold] = 0.0
        same = Vs[:, :, None] == Vo[:, None, :]  # F^0 has no diagonal: no vertex sends to itself
        F[same] = 0.0
        if self.has_across:  # pairs hat-integrated in the stored F: looked up
            across = _across(self.normals[Vs][:, :, None, :], self.normals[Vo][:, None, :, :], r,
                             self.A_v[Vs][:, :, None]) & ~same
            keys = (Vo[:, None, :] * self.V + Vs[:, :, None])[across]
            pos = np.minimum(np.searchsorted(self.F_keys, keys), len(self.F_keys) - 1)
            F[across] = np.where((self.F_keys[pos] == keys)[:, None], self.F_data[pos], 0.0)
        beta_o = at.bary[o].astype(np.float64)
        # d_k(s) beta_j(o) for the 9 (source vertex, receiver vertex) pairs: one contraction with F.
        weight = (self.dual[s][:, :, None] * beta_o[:, None, :]).reshape(len(s), 9)
        phi = np.einsum("pkj,pj->pk", same[inverse].astype(np.float64), beta_o)
        if self.gain is None:
            return np.einsum("pq,pqc->pc", weight, F.reshape(-1, 9, 3)[inverse]), phi
        g = self.gain[Vo]  # (U, 3 receivers, 3 channels)
        if self._edges is None:
            self._edges = _edge_keys(self.t, self.V)
        edge = _in_sorted(Vs[:, :, None] * self.V + Vo[:, None, :], self._edges)  # (U, 3 sources, 3 receivers)
        F *= np.where(edge[..., None], g[:, None, :, :], 1.0)
        B_g0 = np.einsum("pq,pqc->pc", weight, F.reshape(-1, 9, 3)[inverse])
        # A source vertex k is at most one receiver vertex j: its phi_k scaled by that j's gain.
        g_k = np.einsum("ukj,ujc->ukc", same.astype(np.float64), g)
        return B_g0, phi[:, :, None] * g_k[inverse]


# Sub-samples per texel side for the taps next to the centre, where R_d changes within a texel.
SUBTEXELS = {1: 4, 2: 2}


def texel_jacobians(atlas: TexelAtlas, vertices_mm: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(T, 3, 2): the surface's change in mm per texel along the atlas axes, per triangle."""
    P = np.asarray(vertices_mm, np.float64)[np.asarray(triangles, np.int64)]
    uv = atlas.uv.astype(np.float64)
    dP = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)
    dUV = np.stack([uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]], axis=2)
    det = dUV[:, 0, 0] * dUV[:, 1, 1] - dUV[:, 0, 1] * dUV[:, 1, 0]
    ok = np.abs(det) > 1e-12
    inv = np.zeros_like(dUV)
    inv[ok] = np.linalg.inv(dUV[ok])
    return dP @ inv


def _profile_texel(atlas, material, J, o, i, n: int) -> np.ndarray:
    """Mean of R_d from x_o over an n x n grid on texel i's footprint (its source's tangent plane)."""
    if n <= 1:
        return _profile_pairs(atlas, material, o, i)
    s = (np.arange(n) + 0.5) / n - 0.5
    grid = np.stack(np.meshgrid(s, s, indexing="xy"), axis=-1).reshape(-1, 2)
    points = atlas.position_mm[i].astype(np.float64)[:, None, :] + np.einsum("pdk,qk->pqd", J[atlas.triangle[i]], grid)
    r = np.linalg.norm(points - atlas.position_mm[o].astype(np.float64)[:, None, :], axis=2)
    return material.R_d(r.ravel()).reshape(len(o), len(grid), 3).mean(axis=1)


def local_kernels(atlas: TexelAtlas, material: Material, J: np.ndarray):
    """Raw 7x7 kernels K_o(i) = A_i R_d(x_o, x_i) (Lensch 5.3), gathered: (taps (n, 49), K (n, 49, 3)).

    The centre tap is the closed-form integral of R_d over a disk of the texel's area, its
    neighbours average R_d over a grid on the texel (``SUBTEXELS``): the texel-centre value of the
    paper misses the peak of R_d when a texel is not much smaller than 1 / sigma_t'.
    """
    n = atlas.surface_count
    taps = _taps(atlas, np.arange(n), LOCAL_OFFSETS)
    K = np.zeros((n, len(LOCAL_OFFSETS), 3))
    ring = np.max(np.abs(LOCAL_OFFSETS), axis=1)
    o_all, k_all = np.nonzero(taps >= 0)
    for a in range(0, len(o_all), _CHUNK):
        o_idx, k_idx = o_all[a:a + _CHUNK], k_all[a:a + _CHUNK]
        i_idx = taps[o_idx, k_idx]
        for c in np.unique(ring[k_idx]):
            sel = ring[k_idx] == c
            K[o_idx[sel], k_idx[sel]] = atlas.area_mm2[atlas.source[i_idx[sel]], None] * _profile_texel(
                atlas, material, J, o_idx[sel], i_idx[sel], SUBTEXELS.get(int(c), 1))
    K[repeated_sources(atlas, taps)] = 0.0
    centre = len(LOCAL_OFFSETS) // 2
    K[:, centre] = material.R_d_disk(np.sqrt(atlas.area_mm2[:n] / math.pi))  # int over the texel's own disk
    return taps, K


def repeated_sources(atlas: TexelAtlas, taps: np.ndarray) -> np.ndarray:
    """(n, 49) bool: taps whose source an earlier tap of the row already holds.

    A gutter tap stands for its source across the seam (its position, area and light). Beyond a
    sharp ridge several gutter texels find the same source; counting it once per tap multiplied that
    light (and its kernel correction) in the local response. Each source enters a kernel once, at
    its nearest tap in the row order (the centre ring first)."""
    src = np.where(taps >= 0, atlas.source[np.maximum(taps, 0)], -1).astype(np.int64)
    order = np.argsort(np.max(np.abs(LOCAL_OFFSETS), axis=1), kind="stable")
    ranked = src[:, order]
    sort = np.argsort(ranked, axis=1, kind="stable")  # equal sources stay in ring order
    sorted_src = np.take_along_axis(ranked, sort, axis=1)
    dup_sorted = np.zeros_like(sorted_src, dtype=bool)
    dup_sorted[:, 1:] = (sorted_src[:, 1:] == sorted_src[:, :-1]) & (sorted_src[:, 1:] >= 0)
    dup_ranked = np.zeros_like(dup_sorted)
    np.put_along_axis(dup_ranked, sort, dup_sorted, axis=1)
    repeated = np.zeros_like(dup_ranked)
    repeated[:, order] = dup_ranked
    return repeated


def fit_offsets(outer: int) -> tuple[np.ndarray, np.ndarray]:
    """Offsets of the blending fit and their weights: the ring Gamma (offset 4) out to ``outer``.

    Lensch fits B^d on Gamma alone. When a vertex hat is wider than the 7x7 kernel, B^d acts well
    beyond Gamma too, so the fit covers every ring out to the hats' reach; rings from 6 on take
    every other texel, weighted 2.
    """
    offsets, weights = [], []
    for ring in range(RING, max(RING, outer) + 1):
        off = _offsets(ring, ring_only=True)
        weight = np.ones(len(off))
        if ring >= 6:
            keep = (off[:, 0] + off[:, 1]) % 2 == 0
            off, weight = off[keep], 2.0 * weight[keep]
        offsets.append(off)
        weights.append(weight)
    return np.concatenate(offsets), np.concatenate(weights)


def blending_weights(atlas: TexelAtlas, material: Material, response: _GlobalResponse, outer: int = RING) -> np.ndarray:
    """w (n, 3 vertices, 3 channels): least squares of the global impulse response against the
    kernel on the rings from Gamma to ``outer`` (Lensch 5.4, Gamma only for outer = 4)."""
    n = atlas.surface_count
    offsets, weights = fit_offsets(outer)
    ring = _taps(atlas, np.arange(n), offsets)
    s_idx, k_idx = np.nonzero(ring >= 0)
    o_idx = ring[s_idx, k_idx]
    # A tap outside the hats of s's vertices has phi = 0: it adds nothing to either sum.
    keep = response.shares_vertex(s_idx, o_idx)
    s_idx, k_idx, o_idx = s_idx[keep], k_idx[keep], o_idx[keep]
    normal = np.zeros((n, 3, 3))
    rhs = np.zeros((n, 3, 3))
    for a in range(0, len(s_idx), _CHUNK):
        s, o, wt = s_idx[a:a + _CHUNK], o_idx[a:a + _CHUNK], weights[k_idx[a:a + _CHUNK]]
        # The correct radiosity there for unit irradiance on texel s: the wider kernel.
        target = atlas.area_mm2[s, None] * _profile_pairs(atlas, material, s, o)
        B_g0, phi = response(s, o)
        residual = (target - B_g0) * wt[:, None]
        # Sums per texel s: the pairs come in rows of s (np.nonzero is row-major).
        first = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
        rows = s[first]
        rhs[rows] += np.add.reduceat(phi[:, :, None] * residual[:, None, :], first, axis=0)
        normal[rows] += np.add.reduceat((wt[:, None] * phi)[:, :, None] * phi[:, None, :], first, axis=0)
    scale = np.trace(normal, axis1=1, axis2=2) / 3.0
    ridge = RIDGE * scale + RIDGE_FLOOR
    return np.linalg.solve(normal + ridge[:, None, None] * np.eye(3), rhs)


def corrected_kernels(atlas: TexelAtlas, taps: np.ndarray, K: np.ndarray, w: np.ndarray,
                      response: _GlobalResponse, repeated: np.ndarray | None = None) -> np.ndarray:
    """K'_o(i) = K_o(i) - (B^g0 + B^d)(i -> o): the kernel minus the global response inside it (Lensch 5.4).
    ``repeated``: ``repeated_sources(atlas, taps)`` if already known."""
    K = K.copy()
    repeated = repeated_sources(atlas, taps) if repeated is None else repeated
    o_idx, k_idx = np.nonzero((taps >= 0) & ~repeated)
    s_idx = atlas.source[taps[o_idx, k_idx]]  # a gutter texel's light enters at its source
    for a in range(0, len(o_idx), _CHUNK):
        sl = slice(a, a + _CHUNK)
        B_g0, phi = response(s_idx[sl], o_idx[sl])
        B_d = np.einsum("pk,pkc->pc" if phi.ndim == 2 else "pkc,pkc->pc", phi, w[s_idx[sl]])
        K[o_idx[sl], k_idx[sl]] -= B_g0 + B_d
    return K


@dataclasses.dataclass
class LenschBake:
    """Everything TEXTURE_SPACE draws with, besides the atlas."""

    A_v: np.ndarray  # (V,) float32
    dual_vertices: np.ndarray  # (n, 3) int32: triangle vertices of each surface texel
    dual_weights: np.ndarray  # (n, 3) float32: psi~_v A (Eq. 10)
    blend_weights: np.ndarray  # (n, 3, 3) float32: w_v per channel (Sec. 5.4)
    kernel_taps: np.ndarray  # (n, 49) int32: texel list index of each tap, -1 none
    kernels: np.ndarray  # (n, 49, 3) float32: corrected K'
    F_indptr: np.ndarray  # (V+1,) int32
    F_indices: np.ndarray  # (nnz,) int32
    F_data: np.ndarray  # (nnz, 3) float32
    # The far field (``far_field``, ``FarField``); bakes from before it have none (their F kept every pair above the
    # threshold instead).
    G_indptr: np.ndarray | None = None  # (V+1,) int32
    G_indices: np.ndarray | None = None  # (m,) int32: cluster slots
    G_data: np.ndarray | None = None  # (m, 3) float32
    clusters: np.ndarray | None = None  # (V, L) int32: each vertex's slot at every level
    # Light through thin parts leaves by the diffusion mode's law (``through_share``): each entry's depth below its
    # receiver's tangent plane (mm) and the medium's mean free paths z_r (3,), the ramp's scale.
    F_depth: np.ndarray | None = None  # (nnz,) float32
    G_depth: np.ndarray | None = None  # (m,) float32
    z_r: np.ndarray | None = None  # (3,) float32

    def to_arrays(self, prefix: str = "lensch_") -> dict[str, np.ndarray]:
        return {f"{prefix}{f.name}": getattr(self, f.name) for f in dataclasses.fields(self)
                if getattr(self, f.name) is not None}

    @classmethod
    def from_arrays(cls, arrays: dict, prefix: str = "lensch_") -> "LenschBake":
        return cls(**{f.name: arrays.get(f"{prefix}{f.name}") for f in dataclasses.fields(cls)})

    @property
    def has_far_field(self) -> bool:
        return self.G_indptr is not None and self.clusters is not None and self.clusters.size > 0

    @property
    def cluster_count(self) -> int:
        return int(self.clusters.max()) + 1 if self.has_far_field else 0

    def cluster_power(self, E_g: np.ndarray) -> np.ndarray:
        """E_P = sum_(i in P) A_i / 3 E^g_i (C, 3) for every cluster slot, every level (``far_field``)."""
        C = self.cluster_count
        w = self.A_v.astype(np.float64) / 3.0
        E_g = np.asarray(E_g, np.float64)
        out = np.zeros((C, 3))
        for level in range(self.clusters.shape[1]):
            for c in range(3):
                out[:, c] += np.bincount(self.clusters[:, level], w * E_g[:, c], C)
        return out

    def far_matrices(self) -> list:
        """G per colour channel as scipy CSR (rows: receivers, columns: cluster slots)."""
        from scipy.sparse import csr_matrix

        V, C = len(self.A_v), self.cluster_count
        return [csr_matrix((self.G_data[:, c], self.G_indices, self.G_indptr), shape=(V, C)) for c in range(3)]


def precompute(atlas: TexelAtlas, vertices_mm: np.ndarray, triangles: np.ndarray, material: Material,
               blend: bool = True, threshold: float = THRESHOLD, calibrate: bool = True):
    """Generator of the Lensch stages: yields (fraction, text), returns a LenschBake.

    ``blend=False`` keeps the raw kernels and full F with no B^d (the paper's Fig. 6, middle): the
    local and global responses then overlap near the light.
    """
    A_v = vertex_areas(vertices_mm, triangles)
    dual_v, dual_w = dual_weights(atlas, triangles, A_v)
    yield 0.05, "throughput factors F (Lensch 5.2), far sources by cluster"
    (indptr, indices, data), depth, far = throughput(vertices_mm, A_v, material, threshold, triangles)
    far_arrays = dict(G_indptr=far.indptr, G_indices=far.indices, G_data=far.data, clusters=far.clusters,
                      G_depth=far.depth, F_depth=depth,
                      z_r=slab_through.constants(material.sigma_a, material.sigma_s_prime,
                                                 material.eta)[1].astype(np.float32))
    yield 0.3, "7x7 kernels (Lensch 5.3)"
    J = texel_jacobians(atlas, vertices_mm, triangles)
    taps, K = local_kernels(atlas, material, J)
    n = atlas.surface_count
    if blend:
        response = _GlobalResponse(atlas, triangles, vertices_mm, A_v, dual_w, material, (indptr, indices, data),
                                   threshold)
        yield 0.45, "blending weights on the 9x9 ring (Lensch 5.4)"
        # Reach of B^d: one edge (A_v is six triangles of sqrt(3)/4 h^2) beyond the 7x7 kernel, in texels.
        texel = float(np.sqrt(np.median(atlas.area_mm2[:n])))
        edge = float(np.sqrt(np.median(A_v) / (1.5 * np.sqrt(3.0))))
        outer = int(np.ceil(LOCAL + edge / texel))
        outer = FIT_OUTER if FIT_OUTER is not None else outer
        w = blending_weights(atlas, material, response, outer)
        yield 0.7, "kernel correction (Lensch 5.4)"
        repeated = repeated_sources(atlas, taps)
        K_corrected = corrected_kernels(atlas, taps, K, w, response, repeated)
        if calibrate:
            yield 0.8, "uniform-light calibration of the global response"
            first = LenschBake(A_v=A_v.astype(np.float32), dual_vertices=dual_v, dual_weights=dual_w, blend_weights=w,
                               kernel_taps=taps, kernels=K_corrected, F_indptr=indptr, F_indices=indices, F_data=data,
                               **far_arrays)
            one_ring = edge_entries(triangles, indptr, indices)
            gain = uniform_gain(atlas, first, vertices_mm, triangles, material, one_ring)
            response.gain = gain
            K_corrected = corrected_kernels(atlas, taps, K, w, response, repeated)
            scaled = apply_gain(first, gain, one_ring)
            w, data = scaled.blend_weights, scaled.F_data
        K = K_corrected
    else:
        w = np.zeros((n, 3, 3))
        # Without blending the diagonal of F stays (Sec. 5.2): the vertex's own irradiance scatters back.
        V = len(A_v)
        diag = (A_v / 3.0)[:, None] * material.R_d(np.zeros(V))
        indptr, indices, data, far_arrays["F_depth"] = _with_diagonal(indptr, indices, data, diag, depth)
    return LenschBake(
        A_v=A_v.astype(np.float32), dual_vertices=dual_v, dual_weights=dual_w.astype(np.float32),
        blend_weights=w.astype(np.float32), kernel_taps=taps, kernels=K.astype(np.float32),
        F_indptr=indptr, F_indices=indices, F_data=data, **far_arrays,
    )


GAIN_LIMITS = (0.5, 2.0)


def uniform_gain(atlas: TexelAtlas, bake: "LenschBake", vertices_mm, triangles, material: Material,
                 one_ring: np.ndarray) -> np.ndarray:
    """Per-vertex calibration of the global response (V, 3), so that uniform light is exact.

    Under a uniform irradiance the exact radiosity at v_j is int_S R_d(|x - v_j|) dx = sum_i int psi_i
    R_d(x, v_j) dx: the hat integrals (near pairs and the vertex's own hat) plus the point-rule
    throughput beyond. Ours is the local plus the interpolated global response, averaged over the
    texels of v_j's hat with weights beta_j^2. The hats make the global part overshoot a convex
    R_d (+2..10 % measured); the gain scales vertex j's global response to remove that.
    """
    v = np.asarray(vertices_mm, np.float64)
    t = np.asarray(triangles, np.int64)
    V, n = len(v), atlas.surface_count
    A_v = bake.A_v.astype(np.float64)
    rows = np.repeat(np.arange(V), np.diff(bake.F_indptr))
    exact = np.zeros((V, 3))
    for c in range(3):
        exact[:, c] = np.bincount(rows, weights=bake.F_data[:, c], minlength=V)
    if bake.has_far_field:  # the far sources under E = 1, each cluster's power its W
        exact += far_product(bake.far_matrices(), bake.cluster_power(np.ones((V, 3))))
    # Near pairs on the same side: the hat integral instead of the point rule.
    r = np.linalg.norm(v[bake.F_indices] - v[rows], axis=1)
    near = np.flatnonzero(r < ACROSS_REACH * np.sqrt(A_v[bake.F_indices]))
    normals = vertex_normals(v, t)
    depth = np.einsum("ij,ij->i", v[rows[near]] - v[bake.F_indices[near]], normals[rows[near]])
    through = slab_through.factor(depth, *slab_through.constants(material.sigma_a, material.sigma_s_prime,
                                                                   material.eta))
    delta = hat_integrals(v, t, bake.F_indices[near], rows[near], material) * through - bake.F_data[near]
    for c in range(3):
        exact[:, c] += np.bincount(rows[near], weights=delta[:, c], minlength=V)
    own = np.arange(V)
    exact += hat_integrals(v, t, own, own, material, quadrature=12)
    E1 = np.ones((atlas.count, 3))
    B_local, B_global = radiosity_parts(atlas, bake, E1)
    # The gain scales the near global response only (B^d and F^0 from the one-ring): the light
    # from farther away (across a ridge, through a thin part) is the point rule's, kept as it is.
    # ``one_ring``: edge_entries of the bake's F.
    far_only = dataclasses.replace(bake, blend_weights=np.zeros_like(bake.blend_weights),
                                   F_data=np.where(one_ring[:, None], 0.0, bake.F_data).astype(np.float32))
    B_far = radiosity_parts(atlas, far_only, E1)[1]
    weight = atlas.bary[:n].astype(np.float64) ** 2
    verts = bake.dual_vertices.astype(np.int64)
    W = np.bincount(verts.ravel(), weights=weight.ravel(), minlength=V)
    mean_l, mean_g, mean_f = np.zeros((V, 3)), np.zeros((V, 3)), np.zeros((V, 3))
    for c in range(3):
        mean_l[:, c] = np.bincount(verts.ravel(), weights=(weight * B_local[:, c, None]).ravel(), minlength=V)
        mean_g[:, c] = np.bincount(verts.ravel(), weights=(weight * B_global[:, c, None]).ravel(), minlength=V)
        mean_f[:, c] = np.bincount(verts.ravel(), weights=(weight * B_far[:, c, None]).ravel(), minlength=V)
    ok = W > 0
    mean_l[ok] /= W[ok, None]
    mean_g[ok] /= W[ok, None]
    mean_f[ok] /= W[ok, None]
    mean_n = mean_g - mean_f
    gain = np.ones((V, 3))
    good = ok[:, None] & (mean_n > 1e-6 * np.maximum(exact, 1e-30))
    gain[good] = ((exact - mean_l - mean_f) / np.where(good, mean_n, 1.0))[good]
    return np.clip(gain, *GAIN_LIMITS)


def edge_entries(triangles: np.ndarray, F_indptr: np.ndarray, F_indices: np.ndarray) -> np.ndarray:
    """(nnz,) bool: entries of F (row j, column i) whose vertices share an edge (the one-ring)."""
    V = len(F_indptr) - 1
    rows = np.repeat(np.arange(V, dtype=np.int64), np.diff(F_indptr))
    return _in_sorted(rows * V + F_indices, _edge_keys(triangles, V))


def _in_sorted(keys: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """keys (any shape) found in the sorted 1-D ``sorted_keys`` (np.isin without sorting again)."""
    if len(sorted_keys) == 0:
        return np.zeros(np.shape(keys), bool)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), len(sorted_keys) - 1)
    return sorted_keys[pos] == keys


def _edge_keys(triangles: np.ndarray, V: int) -> np.ndarray:
    """Sorted keys a * V + b of the mesh's directed edges (both directions)."""
    t = np.asarray(triangles, np.int64)
    a = np.concatenate([t[:, 0], t[:, 1], t[:, 2], t[:, 1], t[:, 2], t[:, 0]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 0], t[:, 0], t[:, 1], t[:, 2]])
    return np.unique(a * V + b)


def apply_gain(bake: "LenschBake", gain: np.ndarray, one_ring: np.ndarray) -> "LenschBake":
    """Scale each receiving vertex's near global response: its one-ring entries of F^0 (``one_ring``,
    ``edge_entries``) and the B^d weights landing on it."""
    V = len(bake.A_v)
    rows = np.repeat(np.arange(V), np.diff(bake.F_indptr))
    w = bake.blend_weights * gain[bake.dual_vertices.astype(np.int64)]
    scale = np.where(one_ring[:, None], gain[rows], 1.0)
    return dataclasses.replace(bake, F_data=(bake.F_data * scale).astype(np.float32),
                               blend_weights=w.astype(np.float32))


def _with_diagonal(indptr, indices, data, diag, depth):
    V = len(indptr) - 1
    rows = np.repeat(np.arange(V), np.diff(indptr))
    rows = np.concatenate([rows, np.arange(V)])
    cols = np.concatenate([indices, np.arange(V)])
    vals = np.concatenate([data, diag.astype(np.float32)])
    depth = np.concatenate([depth, np.zeros(V, np.float32)])
    order = np.lexsort((cols, rows))
    counts = np.bincount(rows, minlength=V)
    return (np.concatenate([[0], np.cumsum(counts)]).astype(np.int32), cols[order].astype(np.int32),
            vals[order].astype(np.float32), depth[order])


def throughput_matrices(F_indptr, F_indices, F_data) -> list:
    """F^0 as one scipy CSR matrix per colour channel (rows: receivers)."""
    from scipy.sparse import csr_matrix

    V = len(F_indptr) - 1
    return [csr_matrix((F_data[:, c], F_indices, F_indptr), shape=(V, V)) for c in range(3)]


def global_product(matrices: list, E_g: np.ndarray, B_d: np.ndarray) -> np.ndarray:
    """B_j = B^d_j + sum_i F^0_ij E^g_i per channel (Lensch Eq. 9, 11): (V, 3)."""
    B = np.array(B_d, np.float64)
    for c, F in enumerate(matrices):
        B[:, c] += F @ np.asarray(E_g[:, c], np.float64)
    return B


def vertex_radiosity(bake: LenschBake, E_surface: np.ndarray) -> np.ndarray:
    """The global response at the vertices, (V, 3), from the irradiance of the surface texels:
    the gather of Eq. 10 into E^g, the direct radiosity B^d (Sec. 5.4) and the product of Eq. 11."""
    return vertex_product(bake, *gathered(bake, E_surface))


def product_matrices(bake: LenschBake, through: bool = False) -> tuple[list, list | None]:
    """(F^0, G) per colour channel as scipy CSR (G None without a far field). ``through``: each entry weighed by
    its ``through_share``, the matrices of B^t. Built once per bake by whoever multiplies every frame."""
    F_data, G_data = bake.F_data, bake.G_data
    if through:
        F_data = F_data * through_share(bake.F_depth, bake.z_r)
        G_data = G_data * through_share(bake.G_depth, bake.z_r) if bake.has_far_field else None
    F = throughput_matrices(bake.F_indptr, bake.F_indices, F_data)
    return F, dataclasses.replace(bake, G_data=G_data).far_matrices() if bake.has_far_field else None


def vertex_product(bake: LenschBake, E_g: np.ndarray, B_d: np.ndarray | None = None,
                   matrices: tuple | None = None, E_P: np.ndarray | None = None) -> np.ndarray:
    """B^d + F^0 E^g + G E_P at the vertices (V, 3) (Lensch Eq. 11 and the far field), with ``product_matrices``
    (built here if not given) and the clusters' power E_P (gathered here if not given); B^d zero if None."""
    F, G = product_matrices(bake) if matrices is None else matrices
    E_g = np.asarray(E_g, np.float64)
    B = global_product(F, E_g, np.zeros_like(E_g) if B_d is None else B_d)
    if G is not None:
        B += far_product(G, bake.cluster_power(E_g) if E_P is None else E_P)
    return B


def gathered(bake: LenschBake, E_surface: np.ndarray):
    """(E^g, B^d) at the vertices (V, 3) from the surface texels' irradiance (Eq. 10, Sec. 5.4)."""
    V = len(bake.A_v)
    E_s = np.asarray(E_surface, np.float64)
    E_g, B_d = np.zeros((V, 3)), np.zeros((V, 3))
    for k in range(3):
        np.add.at(E_g, bake.dual_vertices[:, k], bake.dual_weights[:, k, None] * E_s)
        np.add.at(B_d, bake.dual_vertices[:, k], bake.blend_weights[:, k, :] * E_s)
    return E_g, B_d


def through_share(depth_mm: np.ndarray, z_r: np.ndarray) -> np.ndarray:
    """(n, 3): how much of an entry's light crossed a thin part, ``slab_through.ramp`` of its depth (as the splat
    shader's ramp, 2 to 4 mean free paths): that share leaves by the diffusion mode's law, not the angular law."""
    return slab_through.ramp(np.asarray(depth_mm, np.float64), np.asarray(z_r, np.float64))


def has_through(bake: LenschBake) -> bool:
    return bake.F_depth is not None and bake.z_r is not None


def vertex_through(bake: LenschBake, E_g: np.ndarray) -> np.ndarray:
    """B^t (V, 3): the part of F^0 E^g + G E_P that crossed a thin part (``through_share`` of each entry)."""
    return vertex_product(bake, E_g, matrices=product_matrices(bake, through=True))


def far_product(matrices: list, E_P: np.ndarray) -> np.ndarray:
    """sum_P G_jP E_P per channel (V, 3): the far sources' light at every vertex (``far_field``)."""
    return np.stack([G @ np.asarray(E_P[:, c], np.float64) for c, G in enumerate(matrices)], axis=1)


def local_radiosity(bake: LenschBake, E: np.ndarray) -> np.ndarray:
    """B^l (n_surface, 3): each surface texel's 7x7 kernel over the irradiance of every texel (Eq. 15)."""
    E = np.asarray(E, np.float64)
    E_taps = np.where(bake.kernel_taps[..., None] >= 0, E[np.maximum(bake.kernel_taps, 0)], 0.0)
    return np.einsum("nkc,nkc->nc", bake.kernels.astype(np.float64), E_taps)


def radiosity_parts(atlas: TexelAtlas, bake: LenschBake, E: np.ndarray):
    """CPU twin of the run time on the surface texels: (B^l (n, 3), B^d + B^g0 interpolated (n, 3)).

    ``E`` (n_texels, 3) is the irradiance of every texel (border texels hold their source's):
    Eq. 15 (7x7 filter) and Eq. 10-12 (gather, product, interpolation); their sum is Eq. 9.
    """
    n = atlas.surface_count
    E = np.asarray(E, np.float64)
    B_vertex = vertex_radiosity(bake, E[:n])
    B_global = np.einsum("nk,nkc->nc", atlas.bary[:n].astype(np.float64), B_vertex[bake.dual_vertices])
    return local_radiosity(bake, E), B_global


def radiosity(atlas: TexelAtlas, bake: LenschBake, E: np.ndarray) -> np.ndarray:
    """B (n_surface, 3) = B^l + B^d + B^g0 (Lensch Eq. 9) from the irradiance E of every texel."""
    B_local, B_global = radiosity_parts(atlas, bake, E)
    return B_local + B_global

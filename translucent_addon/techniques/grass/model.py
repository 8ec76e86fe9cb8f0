"""Pure maths of the grass pass (Shah 4.3.3): per-pixel BTF reconstruction, the NumPy twin of
``gpu_shaders/grass/btf.glsl``, and the GPU table layout.

Per pixel with tile coordinates uv (texel units: uv * R), view and light directions in the ground's
local frame (z = normal, x = the object's x axis):
* the three nearest sampled views and lights with barycentric weights (``hemisphere``; a table over
  the polar disk, looked up at the nearest cell, as on the GPU);
* for each of the three views, the hit-weighted bilinear sample of the eigen-textures and of the
  depth map, wrapped across the tile's edges (the patch is periodic, so this is the bilinear
  blending of neighbouring tiles): texels whose ray misses every blade (depth = -1) get no weight;
* coverage = sum_v w_v hit_v; where it is below one half the pixel is a gap (silhouette: discarded);
* radiance = sum_v w_v hit_v sum_k U_v(x, y, k) sum_l w_l F'(k, v, l) / coverage (Eq. 4.4) in Y, Cb,
  Cr, then RGB; depth = the same weighted mean of the depth maps.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.geometry import hemisphere
from .acquire import SENTINEL
from .compress import CompressedBTF, to_rgb


@dataclasses.dataclass(frozen=True)
class GrassLayer:
    """A grass field on a ground mesh (Shah ch. 4): its BTF bake and how it is laid on the ground."""

    bake: object  # BakeHandle of the GRASS bake; load() -> (arrays, meta)
    tile: float  # side of one BTF tile, scene units
    lod: float = 1.0  # texels per pixel above which fewer luminance eigen-textures are summed; 0: never
    min_groups: int = 2  # the fewest luminance groups of four eigen-textures kept far away


TABLE_RES = 256
DEPTH_TILES_PER_ROW = 9


def table_cell(directions: np.ndarray, res: int = TABLE_RES) -> np.ndarray:
    """(..., 2) int cell (column, row) of directions in the disk-map tables, as the shader computes it."""
    d = np.asarray(directions, np.float64)
    d = np.concatenate([d[..., :2], np.maximum(d[..., 2:3], 0.0)], axis=-1)
    xy = hemisphere.disk_coordinates(d)
    return np.clip(np.floor((xy + 1.0) * 0.5 * res), 0, res - 1).astype(np.int64)


@dataclasses.dataclass
class Tables:
    view_indices: np.ndarray  # (T, T, 3)
    view_weights: np.ndarray
    light_indices: np.ndarray
    light_weights: np.ndarray

    @classmethod
    def of(cls, cb: CompressedBTF, res: int = TABLE_RES) -> "Tables":
        vi, vw = hemisphere.direction_table(cb.views, res)
        li, lw = hemisphere.direction_table(cb.lights, res)
        return cls(vi, vw, li, lw)

    def lookup(self, which: str, directions: np.ndarray):
        cell = table_cell(directions, self.view_indices.shape[0])
        idx = getattr(self, f"{which}_indices")[cell[..., 1], cell[..., 0]].astype(np.int64)
        w = getattr(self, f"{which}_weights")[cell[..., 1], cell[..., 0]].astype(np.float64)
        return idx, w


def _bilinear_taps(uv_texels: np.ndarray, R: int):
    """Four wrapped texels (N, 4, 2) and bilinear weights (N, 4) around points in texel units
    (texel i centred at i + 0.5)."""
    t = uv_texels - 0.5
    i0 = np.floor(t).astype(np.int64)
    f = t - i0
    taps, weights = [], []
    for dx, dy in ((0, 0), (1, 0), (0, 1), (1, 1)):
        taps.append(np.stack([(i0[:, 0] + dx) % R, (i0[:, 1] + dy) % R], axis=1))
        weights.append((f[:, 0] if dx else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1]))
    return np.stack(taps, axis=1), np.stack(weights, axis=1)


def shade(cb: CompressedBTF, uv: np.ndarray, omega_v: np.ndarray, omega_l: np.ndarray | None,
          tables: Tables | None = None, n_y: int | None = None):
    """(radiance RGB (N, 3) per unit irradiance facing the light, or per unit sky radiance when
    omega_l is None; coverage (N,); depth (N,) in tile units along the view ray) at tile coordinates
    uv (N, 2) (tile units, any real values: the tile repeats)."""
    tables = tables or Tables.of(cb)
    R = cb.resolution
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    N = len(uv)
    taps, bw = _bilinear_taps(uv * R, R)
    v_idx, v_w = tables.lookup("view", np.broadcast_to(omega_v, (N, 3)))
    n_l = len(cb.lights)
    if omega_l is None:
        l_idx, l_w = np.full((N, 3), n_l), np.tile([1.0, 0.0, 0.0], (N, 1))
    else:
        l_idx, l_w = tables.lookup("light", np.broadcast_to(omega_l, (N, 3)))
    coverage = np.zeros(N)
    depth_sum = np.zeros(N)
    ycc = np.zeros((N, 3))
    for j in range(3):
        v = v_idx[:, j]
        d_taps = cb.depth[v[:, None], taps[..., 1], taps[..., 0]]  # (N, 4)
        hit = (d_taps != SENTINEL) * bw
        h = hit.sum(axis=1)
        wv = v_w[:, j]
        coverage += wv * h
        depth_sum += wv * (hit * d_taps).sum(axis=1)
        for c in range(3):
            B, C = cb.basis[c], cb.coeffs[c]
            k = B.shape[2] if (c > 0 or n_y is None) else 1 + min(n_y, B.shape[2] - 1)
            U = B[taps[..., 1], taps[..., 0], :k]  # (N, 4, k)
            Ub = (hit[..., None] * U).sum(axis=1)  # hit-weighted bilinear
            coef = sum(l_w[:, m, None] * C[:k, v, l_idx[:, m]].T for m in range(3))  # (N, k)
            ycc[:, c] += wv * (Ub * coef).sum(axis=1)
    safe = np.maximum(coverage, 1e-9)
    rgb = np.maximum(to_rgb(ycc / safe[:, None]), 0.0)  # truncation can dip a dim channel below zero
    depth = np.where(coverage > 0, depth_sum / safe, SENTINEL)
    return rgb, coverage, depth


def smooth_corner_normals(positions: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals at triangle corners (3T, 3), corners at the same position sharing
    one: the grass layer is the ground moved out along these, so that flat-shaded ground does not crack
    the layer open along its edges."""
    p = np.asarray(positions, np.float64).reshape(-1, 3, 3)
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # length = 2 area
    _, vertex = np.unique(np.round(p.reshape(-1, 3), 7), axis=0, return_inverse=True)
    vertex = vertex.reshape(-1)
    acc = np.zeros((vertex.max() + 1, 3))
    np.add.at(acc, vertex, np.repeat(face, 3, axis=0))
    n = acc[vertex]
    return (n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)).astype(np.float32)


# -- GPU layout (techniques/grass/passes.py uploads these; the shader indexes them the same way) --------------
def groups(cb: CompressedBTF) -> tuple[int, int, int]:
    """vec4 groups of Y, Cb, Cr basis vectors (the mean counts as basis 0)."""
    return tuple(int(np.ceil(b.shape[2] / 4)) for b in cb.basis)


def packed_basis(cb: CompressedBTF) -> np.ndarray:
    """(R, R * G, 4) float32: group g of the channels, Y then Cb then Cr, at columns g R .. g R + R - 1."""
    R = cb.resolution
    tiles = []
    for B in cb.basis:
        k = B.shape[2]
        g = int(np.ceil(k / 4))
        P = np.zeros((R, R, 4 * g), np.float32)
        P[:, :, :k] = B
        tiles += [P[:, :, 4 * i:4 * i + 4] for i in range(g)]
    return np.concatenate(tiles, axis=1)


def packed_coeffs(cb: CompressedBTF) -> np.ndarray:
    """(G, n_v * (n_l + 1), 4) float32: row = group, column = view * (n_l + 1) + light."""
    rows = []
    for C in cb.coeffs:
        k, n_v, n_l1 = C.shape
        g = int(np.ceil(k / 4))
        P = np.zeros((4 * g, n_v, n_l1), np.float32)
        P[:k] = C
        for i in range(g):
            rows.append(P[4 * i:4 * i + 4].reshape(4, n_v * n_l1).T)
    return np.stack(rows, axis=0)


def packed_depth(cb: CompressedBTF) -> np.ndarray:
    """(rows R, 9 R) float32: view v at tile (v % 9, v // 9)."""
    n_v, R = cb.depth.shape[0], cb.resolution
    rows = int(np.ceil(n_v / DEPTH_TILES_PER_ROW))
    out = np.full((rows * R, DEPTH_TILES_PER_ROW * R), SENTINEL, np.float32)
    for v in range(n_v):
        r, c = divmod(v, DEPTH_TILES_PER_ROW)
        out[r * R:(r + 1) * R, c * R:(c + 1) * R] = cb.depth[v]
    return out


def packed_tables(tables: Tables) -> np.ndarray:
    """(T, 4 T, 4) float32: view indices | view weights | light indices | light weights (w = 0)."""
    parts = [tables.view_indices, tables.view_weights, tables.light_indices, tables.light_weights]
    T = parts[0].shape[0]
    out = np.zeros((T, 4 * T, 4), np.float32)
    for i, p in enumerate(parts):
        out[:, i * T:(i + 1) * T, :3] = p
    return out

"""Interval mapping of height fields (Shah's thesis ch. 3; Risser, Shah & Pattanaik, JGT 2007) and relief
mapping (Policarpo et al. 2005), vectorised over many rays at once. Pure NumPy (no bpy); the GLSL twin is
``gpu_shaders/relief/interval_search.glsl`` and follows the same conventions line by line.

Conventions (shared with the GLSL twin)
---------------------------------------
* ``height``: 2D array ``(rows, cols)`` with values in [0, 1], 1 = top of the relief layer. Row ``i``,
  column ``j`` is the texel covering ``u in [j/W, (j+1)/W)``, ``v in [i/H, (i+1)/H)`` with its centre at
  ``((j + 0.5)/W, (i + 0.5)/H)``: the OpenGL convention for a texture uploaded from the array as is (row 0
  first, at v near 0). Sampling is bilinear with wrap, i.e. ``GL_LINEAR`` + ``GL_REPEAT``.
* depth: ``D(uv) = 1 - height(uv)``, measured downward from the top of the layer (relief-mapping
  convention), in units of the layer thickness, so depths lie in [0, 1].
* a view ray enters the layer at its top (depth 0) at ``uv0`` and moves by ``dir_uv`` in uv per unit of
  depth: at ray depth ``t`` in [0, 1] it is at ``uv0 + t * dir_uv``. The ray parameter *is* the ray depth.
  For a tangent-space unit vector ``V`` from the surface toward the eye and a layer ``depth_scale`` uv
  units thick, ``dir_uv = -V.xy / V.z * depth_scale`` (:func:`view_dir_uv`).
* ``g(t) = t - D(uv0 + t dir_uv)``: ray depth minus surface depth, < 0 above the surface, >= 0 on or below.
  ``g(0) <= 0`` and ``g(1) = height >= 0``, so every ray has a hit in [0, 1].
* convergence (both refiners): stop after the first iteration whose new point has ``|g| < threshold``
  (default ``1e-3`` of the layer thickness: the height difference between ray and surface there), or after
  ``max_iter`` iterations (default 10, the paper's maximum). An iteration is one new height-field sample.
  The hit returned is the last point evaluated, on the ray.
"""
from __future__ import annotations

import dataclasses
import hashlib
from typing import NamedTuple

import numpy as np


def heights_of(pixels: np.ndarray) -> tuple[np.ndarray, str]:
    """(heights, digest): (H, W) float32 heights in [0, 1] from an image's brightness (mean of RGB; row 0 at
    v = 0, Blender's pixel order), and a digest of them (the GPU texture's cache key)."""
    rgb = pixels[..., :3] if pixels.shape[-1] >= 3 else pixels[..., :1]
    height = np.clip(rgb.mean(axis=-1), 0.0, 1.0).astype(np.float32)
    return height, hashlib.blake2b(height.tobytes(), digest_size=8).hexdigest()


@dataclasses.dataclass(frozen=True, eq=False)
class ReliefSurface:
    """A height field over a mesh's UVs (Shah ch. 3): interval or relief mapping."""

    key: str  # names the height image (GPU cache)
    height: np.ndarray  # (H, W) float32 in [0, 1], row 0 at v = 0; 1 is the surface
    depth: float  # scene units from height 1 down to height 0
    mode: int = 0  # 0 interval mapping, 1 relief mapping (gpu_shaders/relief/interval_search.glsl)
    linear_steps: int = 8
    iterations: int = 10
    shadows: bool = True
    uv: np.ndarray | None = None  # (3T, 2) per corner
    tangent_u: np.ndarray | None = None  # (3T, 3) object-space dP/du per corner
    tangent_v: np.ndarray | None = None  # (3T, 3) dP/dv


THRESHOLD = 1e-3  # |ray depth - surface depth| at the new point, in layer thicknesses
MAX_ITER = 10  # the paper's maximum number of refinement iterations
FIELD_SIZE = 256


class Bracket(NamedTuple):
    """The interval from the linear search: ``t_upper`` (last ray depth above the surface, g < 0, or 0) and
    ``t_lower`` (first ray depth on/below it, g >= 0), with the surface depths there."""

    t_upper: np.ndarray
    d_upper: np.ndarray
    t_lower: np.ndarray
    d_lower: np.ndarray


class Hit(NamedTuple):
    uv: np.ndarray  # (R, 2) hit texture coordinates (not wrapped)
    depth: np.ndarray  # (R,) ray depth at the hit, in [0, 1]
    iterations: np.ndarray  # (R,) int, 1..max_iter
    converged: np.ndarray  # (R,) bool: |g| < threshold reached within max_iter


# ---------------------------------------------------------------------------------------------- sampling
def sample_height(height: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear height with wrap at ``uv`` (``(..., 2)``), texel centres at ``(i + 0.5)/N``: what
    ``textureLod(hmap, uv, 0.0)`` returns for a LINEAR + REPEAT sampler."""
    h = np.asarray(height, dtype=np.float64)
    rows, cols = h.shape
    hp = np.empty((rows + 1, cols + 1))  # wrapped copy with one extra row and column: one gather index
    hp[:rows, :cols] = h
    hp[rows, :cols] = h[0]
    hp[:, cols] = hp[:, 0]
    flat = hp.ravel()
    uv = np.asarray(uv, dtype=np.float64)
    x = uv[..., 0] * cols - 0.5
    y = uv[..., 1] * rows - 0.5
    x0 = np.floor(x)
    y0 = np.floor(y)
    fx = x - x0
    fy = y - y0
    idx = (np.mod(y0, rows) * (cols + 1) + np.mod(x0, cols)).astype(np.intp)
    a00 = flat[idx]
    a01 = flat[idx + 1]
    a10 = flat[idx + cols + 1]
    a11 = flat[idx + cols + 2]
    top = a00 * (1.0 - fx) + a01 * fx
    bot = a10 * (1.0 - fx) + a11 * fx
    return top * (1.0 - fy) + bot * fy


def surface_depth(height: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Depth of the surface below the top of the layer, ``D = 1 - height`` (relief-mapping convention)."""
    return 1.0 - sample_height(height, uv)


def ray_uv(uv0: np.ndarray, dir_uv: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Texture coordinates of the ray at ray depth ``t``: ``uv0 + t * dir_uv``."""
    return uv0 + np.asarray(t)[..., None] * dir_uv


def view_dir_uv(view: np.ndarray, depth_scale: float) -> np.ndarray:
    """``dir_uv`` for a tangent-space vector ``view`` from the surface to the eye (z > 0) and a layer
    ``depth_scale`` uv units thick: the uv step per unit of depth going into the surface."""
    v = np.asarray(view, dtype=np.float64)
    return -v[..., :2] / v[..., 2:3] * depth_scale


def light_dir_uv(light: np.ndarray, depth_scale: float) -> np.ndarray:
    """``light_uv`` for :func:`self_shadow`: the uv step per unit of depth climbed toward a tangent-space
    light direction ``light`` (surface to light, z > 0)."""
    l_ = np.asarray(light, dtype=np.float64)
    return l_[..., :2] / l_[..., 2:3] * depth_scale


def _rays(uv0, dir_uv):
    uv0 = np.atleast_2d(np.asarray(uv0, dtype=np.float64))
    dir_uv = np.broadcast_to(np.asarray(dir_uv, dtype=np.float64), uv0.shape)
    return uv0, dir_uv


# --------------------------------------------------------------------------------------- linear search
def linear_search(height: np.ndarray, uv0: np.ndarray, dir_uv: np.ndarray, n_steps: int) -> Bracket:
    """Uniform linear search (Shah §3.3 step 1, identical to relief mapping's): sample the ray at depths
    ``t_k = k / n_steps``, k = 1..n_steps, and bracket the first sample on or below the surface
    (``t_k >= D``) with the previous one (``t_0 = 0``, the top of the layer). ``t = 1`` is always on or
    below the surface, so every ray gets a bracket."""
    uv0, dir_uv = _rays(uv0, dir_uv)
    n = uv0.shape[0]
    t_up = np.zeros(n)
    d_up = surface_depth(height, uv0)
    t_lo = np.ones(n)
    d_lo = np.zeros(n)
    found = np.zeros(n, dtype=bool)
    for k in range(1, n_steps + 1):
        idx = np.flatnonzero(~found)
        if idx.size == 0:
            break
        t = np.full(idx.size, k / n_steps)
        d = surface_depth(height, ray_uv(uv0[idx], dir_uv[idx], t))
        below = t >= d
        hit = idx[below]
        t_lo[hit], d_lo[hit] = t[below], d[below]
        found[hit] = True
        miss = idx[~below]
        t_up[miss], d_up[miss] = t[~below], d[~below]
    return Bracket(t_up, d_up, t_lo, d_lo)


# ------------------------------------------------------------------------------------------ refinement
def interval_point(t_up, d_up, t_lo, d_lo):
    """Shah Eq. 3.1-3.6 in the 2D slice x = ray depth t, y = depth: the view ray is ``x - y = 0``
    (``A_view = 1, B_view = -1``, Eq. 3.1); the line through the surface samples at the bounds has
    ``A_line = y_U - y_L`` (Eq. 3.3), ``B_line = x_L - x_U`` (Eq. 3.4), ``C_line = -B_line y_U - A_line x_U``
    (Eq. 3.5), and they meet at ``x = C_line B_view / (A_view B_line - A_line B_view)`` (Eq. 3.6; y = x,
    Eq. 3.7). This is the regula-falsi (bracketed secant, Eq. 3.8-3.18) step on g(t). The result is
    clamped into the bracket; a zero denominator (both ends on the surface) gives the upper bound."""
    a_line = d_up - d_lo
    b_line = t_lo - t_up
    c_line = -b_line * d_up - a_line * t_up
    den = b_line + a_line  # A_view B_line - A_line B_view = (t_lo - D_lo) - (t_up - D_up) = g_lo - g_up >= 0
    safe = np.where(den > 0.0, den, 1.0)
    x = np.where(den > 0.0, -c_line / safe, t_up)
    return np.clip(x, t_up, t_lo)


def binary_point(t_up, d_up, t_lo, d_lo):
    """Relief mapping (Policarpo 2005): the midpoint ``(upper + lower) / 2`` of the bracket."""
    return 0.5 * (t_up + t_lo)


def _refine(point, height, uv0, dir_uv, bracket, max_iter, threshold) -> Hit:
    uv0, dir_uv = _rays(uv0, dir_uv)
    t_up, d_up, t_lo, d_lo = (np.array(a, dtype=np.float64) for a in bracket)
    n = uv0.shape[0]
    t_hit = t_lo.copy()
    iters = np.full(n, max_iter, dtype=np.int64)
    conv = np.zeros(n, dtype=bool)
    active = np.arange(n)
    for it in range(1, max_iter + 1):
        if active.size == 0:
            break
        t = point(t_up[active], d_up[active], t_lo[active], d_lo[active])
        d = surface_depth(height, ray_uv(uv0[active], dir_uv[active], t))
        g = t - d
        above = g < 0.0  # new upper bound, else new lower bound (the bracket is kept)
        ia, ib = active[above], active[~above]
        t_up[ia], d_up[ia] = t[above], d[above]
        t_lo[ib], d_lo[ib] = t[~above], d[~above]
        t_hit[active] = t
        done = np.abs(g) < threshold
        iters[active[done]] = it
        conv[active[done]] = True
        active = active[~done]
    return Hit(ray_uv(uv0, dir_uv, t_hit), t_hit, iters, conv)


def interval_refine(height, uv0, dir_uv, bracket: Bracket, max_iter: int = MAX_ITER,
                    threshold: float = THRESHOLD) -> Hit:
    """Interval mapping's refinement (Shah §3.3 step 2): replace the upper or lower bound by the
    intersection of the view ray with the line through the two bound samples (Eq. 3.6, see
    :func:`interval_point`), whichever side of the surface it falls on; stop when ``|g| < threshold`` at
    the new point or after ``max_iter`` iterations."""
    return _refine(interval_point, height, uv0, dir_uv, bracket, max_iter, threshold)


def binary_refine(height, uv0, dir_uv, bracket: Bracket, max_iter: int = MAX_ITER,
                  threshold: float = THRESHOLD) -> Hit:
    """Relief mapping's binary search (Policarpo 2005) with the same bracket update and stopping rule as
    :func:`interval_refine`; only the new point differs (the midpoint, Shah §3.4)."""
    return _refine(binary_point, height, uv0, dir_uv, bracket, max_iter, threshold)


def intersect(height, uv0, dir_uv, linear_steps: int = 5, max_iter: int = MAX_ITER,
              threshold: float = THRESHOLD, mode: str = "interval") -> Hit:
    """Linear search then refinement; ``mode`` is "interval" (GLSL mode 0) or "relief" (mode 1)."""
    br = linear_search(height, uv0, dir_uv, linear_steps)
    refine = {"interval": interval_refine, "relief": binary_refine}[mode]
    return refine(height, uv0, dir_uv, br, max_iter, threshold)


# ----------------------------------------------------------------------------------------- self shadow
def self_shadow(height, uv, depth, light_uv, n_steps: int = 16, bias: float = 1e-3) -> np.ndarray:
    """Visibility (1 lit, 0 shadowed) of the point at ``uv``, ray depth ``depth`` toward the light: a
    linear search up the light ray, ``uv + s * light_uv`` at depth ``depth - s`` for ``s = depth * k /
    n_steps``, k = 1..n_steps (relief mapping's shadow test, Shah §3.4). Shadowed if the surface is above
    the light ray at any sample, ``D < depth - s - bias``. ``light_uv`` is the uv step per unit of depth
    climbed (:func:`light_dir_uv`)."""
    uv, light_uv = _rays(uv, light_uv)
    depth = np.broadcast_to(np.asarray(depth, dtype=np.float64), uv.shape[:1])
    lit = np.ones(uv.shape[0], dtype=bool)
    for k in range(1, n_steps + 1):
        s = depth * (k / n_steps)
        d = surface_depth(height, ray_uv(uv, light_uv, s))
        lit &= ~(d < depth - s - bias)
    return lit.astype(np.float64)


# ------------------------------------------------------------------------------------------- reference
def reference_intersect(height, uv0, dir_uv, n_steps: int = 4096, n_bisect: int = 40,
                        t_min=0.0, t_max=1.0, chunk: int = 128) -> np.ndarray:
    """Exact first hit (ray depth) for error measurements: march ``n_steps`` uniform steps over
    ``[t_min, t_max]`` (per ray or scalar) to the first sample with ``g >= 0`` and bisect that step
    ``n_bisect`` times. Rays with no crossing in the range return ``t_max``."""
    uv0, dir_uv = _rays(uv0, dir_uv)
    n = uv0.shape[0]
    t_min = np.broadcast_to(np.asarray(t_min, dtype=np.float64), (n,)).copy()
    t_max = np.broadcast_to(np.asarray(t_max, dtype=np.float64), (n,)).copy()
    lo = t_min.copy()
    hi = t_max.copy()
    g0 = t_min - surface_depth(height, ray_uv(uv0, dir_uv, t_min))
    found = g0 >= 0.0
    hi[found] = t_min[found]
    active = np.flatnonzero(~found)
    ks = np.arange(1, chunk + 1)
    for start in range(0, n_steps, chunk):
        if active.size == 0:
            break
        k = ks[: min(chunk, n_steps - start)] + start
        span = (t_max - t_min)[active]
        t = t_min[active, None] + span[:, None] * (k[None, :] / n_steps)
        uv = uv0[active, None, :] + t[..., None] * dir_uv[active, None, :]
        g = t - surface_depth(height, uv)
        below = g >= 0.0
        anyb = below.any(axis=1)
        first = below.argmax(axis=1)
        rows = np.flatnonzero(anyb)
        idx = active[rows]
        hi[idx] = t[rows, first[rows]]
        lo[idx] = t_min[idx] + (t_max - t_min)[idx] * ((first[rows] + start) / n_steps)
        active = active[~anyb]
    lo[active] = t_max[active]
    hi[active] = t_max[active]
    for _ in range(n_bisect):
        mid = 0.5 * (lo + hi)
        g = mid - surface_depth(height, ray_uv(uv0, dir_uv, mid))
        below = g >= 0.0
        hi = np.where(below, mid, hi)
        lo = np.where(below, lo, mid)
    return hi


# ----------------------------------------------------------------------------------- shading (bench)
def surface_normal(height, uv, depth_scale: float, eps_texels: float = 0.5) -> np.ndarray:
    """Tangent-space normal of the relief (height times ``depth_scale`` in uv units) by central
    differences of the bilinear field ``eps_texels`` texels apart."""
    rows, cols = np.asarray(height).shape
    ex, ey = eps_texels / cols, eps_texels / rows
    du = (sample_height(height, uv + [ex, 0.0]) - sample_height(height, uv - [ex, 0.0])) / (2 * ex)
    dv = (sample_height(height, uv + [0.0, ey]) - sample_height(height, uv - [0.0, ey])) / (2 * ey)
    nrm = np.stack([-du * depth_scale, -dv * depth_scale, np.ones_like(du)], -1)
    return nrm / np.linalg.norm(nrm, axis=-1, keepdims=True)


def shade(height, hit: Hit, light, depth_scale: float, ambient: float = 0.15,
          shadow_steps: int = 16) -> np.ndarray:
    """Lambert shading of the hits with self-shadowing from the hit point (``light`` a tangent-space
    direction toward the light)."""
    l_ = np.asarray(light, dtype=np.float64)
    l_ = l_ / np.linalg.norm(l_)
    nrm = surface_normal(height, hit.uv, depth_scale)
    vis = self_shadow(height, hit.uv, hit.depth, light_dir_uv(l_, depth_scale), shadow_steps)
    return ambient + (1.0 - ambient) * np.clip(nrm @ l_, 0.0, 1.0) * vis


# ---------------------------------------------------------------------------------- procedural fields
def _normalise(h):
    h = h - h.min()
    return h / h.max()


def _wrapped_dist2(x, y, cx, cy):
    dx = (x - cx + 0.5) % 1.0 - 0.5
    dy = (y - cy + 0.5) % 1.0 - 0.5
    return dx * dx + dy * dy


def bumps(n: int = FIELD_SIZE) -> np.ndarray:
    """Smooth periodic bumps: 24 Gaussian bumps of various widths (fixed seed) plus a low sine."""
    rng = np.random.default_rng(3)
    x, y = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n)
    h = 0.15 * np.sin(2 * np.pi * x) * np.sin(4 * np.pi * y)
    for _ in range(24):
        cx, cy = rng.random(2)
        r = rng.uniform(0.04, 0.12)
        a = rng.uniform(0.4, 1.0)
        h += a * np.exp(-_wrapped_dist2(x, y, cx, cy) / (2 * r * r))
    return _normalise(h)


def bricks(n: int = FIELD_SIZE) -> np.ndarray:
    """Bricks with sharp step edges: 8 courses of 4 bricks (half-brick offset every other course), brick
    tops at fixed-seed heights in [0.75, 1], mortar joints 1/64 wide at height 0.1."""
    rng = np.random.default_rng(5)
    x, y = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n)
    courses, per = 8, 4
    row = np.floor(y * courses).astype(int)
    xs = (x + 0.5 / per * (row % 2)) % 1.0
    col = np.floor(xs * per).astype(int)
    tops = rng.uniform(0.75, 1.0, size=(courses, per))
    h = tops[row, col]
    fy = y * courses - row
    fx = xs * per - col
    mortar = 1.0 / 64
    joint = (fy < mortar * courses) | (fx < mortar * per)
    return np.where(joint, 0.1, h)


def rocks(n: int = FIELD_SIZE, octaves: int = 6) -> np.ndarray:
    """Fractal periodic value noise (fixed seed): octaves of bicubic-smoothstep interpolated lattice
    noise, lattice 4 x 2^k, amplitude 0.5^k, then sharpened into rock-like lumps."""
    rng = np.random.default_rng(7)
    x, y = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n)
    h = np.zeros((n, n))
    for k in range(octaves):
        m = 4 * 2**k
        lat = rng.random((m, m))
        gx, gy = x * m, y * m
        i0, j0 = np.floor(gy).astype(int), np.floor(gx).astype(int)
        fy, fx = gy - i0, gx - j0
        sy, sx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
        i0, j0 = i0 % m, j0 % m
        i1, j1 = (i0 + 1) % m, (j0 + 1) % m
        v = (lat[i0, j0] * (1 - sx) + lat[i0, j1] * sx) * (1 - sy) + (lat[i1, j0] * (1 - sx) + lat[i1, j1] * sx) * sy
        h += 0.5**k * v
    h = _normalise(h)
    return _normalise(np.sqrt(h))  # steeper sides, rounder tops


FIELDS = {"bumps": bumps, "bricks": bricks, "rocks": rocks}

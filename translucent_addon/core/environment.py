"""World environment as a cube map with a chain of key filtered maps (Chan & Wang 2005, Sec. 3.1-3.2).

The environment is stored like a mip chain of 2-D cube atlases (see ``core/geometry/cubemap.py``):
level ``l`` has faces of ``res >> l`` texels and holds the environment convolved with a Gaussian
of angular standard deviation ``sigma[l]`` (level 0 is the unfiltered source, ``sigma[0] = 0``).
``sigma[l]`` is the smallest width that the level's resolution can hold without visible aliasing
(Chan & Wang Sec. 3.2 / Table 1, :func:`key_width`). The shader picks a fractional level from the
desired blur width and interpolates linearly between two levels (:func:`sample`, CPU twin).

Filtering is done on the sphere, by direction, not per face (Chan & Wang Sec. 3.1 warn that
per-face filtering leaves seams): every output texel (border texels included, each in its own
direction) is a normalised sum of source texels weighted by ``exp(-theta^2 / 2 sigma^2)`` times
the source texel's solid angle, ``theta`` the angle between the two directions.

Atlas layout (float32, RGBA, alpha = 1)::

    rows[l] .. rows[l] + res_l + 2      level l, res_l = res >> l
    columns f (res_l + 2) .. (f + 1)(res_l + 2)   face f (+X, -X, +Y, -Y, +Z, -Z), bordered

so the atlas is ``sum_l (res_l + 2)`` rows by ``6 (res + 2)`` columns; coarser levels use only
their first ``6 (res_l + 2)`` columns (the rest is zero).

Pure (NumPy / SciPy).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike

from .geometry import cubemap

#: Kernel support, in standard deviations (the truncated weight is exp(-8) = 3e-4 of the total).
KERNEL_CUTOFF = 4.0
#: A level filters a box-downsampled source whose texels are at most sigma / MIN_TEXELS wide.
MIN_TEXELS = 1.5
#: Sources are never coarser than this face resolution (cheap, and keeps coarse levels accurate).
MIN_SOURCE_RES = 16


# --------------------------------------------------------------------------------------------
# Equirectangular images (Blender / Cycles convention)
# --------------------------------------------------------------------------------------------

def equirect_direction_to_uv(d: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) in [0, 1] of directions for Blender's Environment Texture (equirectangular).

    Cycles ``direction_to_equirectangular``: ``u = -atan2(d.y, d.x) / (2 pi) + 0.5``,
    ``v = atan2(d.z, hypot(d.x, d.y)) / pi + 0.5``: the image centre looks along +X, u grows
    towards -Y, v = 1 is +Z (checked against Cycles renders in ``tests/test_environment.py``).
    """
    d = np.asarray(d, np.float64)
    u = -np.arctan2(d[..., 1], d[..., 0]) / (2.0 * np.pi) + 0.5
    v = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1])) / np.pi + 0.5
    return u, v


def sample_equirect(image: ArrayLike, d: ArrayLike) -> np.ndarray:
    """Bilinear lookup of an equirectangular image at directions ``d``: (..., C).

    ``image`` is (H, W, C) with row 0 at the bottom (Blender's ``Image.pixels`` order); pixel
    centres at ((j + 0.5) / W, (i + 0.5) / H); wraps in u, clamps in v. Matches Cycles' linear
    Environment Texture lookup to 1e-5 except within half a pixel row of a pole, where Cycles
    also wraps in v (blending in the opposite pole's row).
    """
    image = np.asarray(image)
    h, w = image.shape[:2]
    u, v = equirect_direction_to_uv(d)
    x = u * w - 0.5
    y = np.clip(v * h - 0.5, 0.0, h - 1.0)
    x0 = np.floor(x)
    y0 = np.minimum(np.floor(y), max(h - 2, 0))
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    x0 = x0.astype(np.int64) % w
    x1 = (x0 + 1) % w
    y0 = y0.astype(np.int64)
    y1 = np.minimum(y0 + 1, h - 1)
    top = image[y0, x0] * (1 - fx) + image[y0, x1] * fx
    bot = image[y1, x0] * (1 - fx) + image[y1, x1] * fx
    return top * (1 - fy) + bot * fy


# --------------------------------------------------------------------------------------------
# Key widths (Chan & Wang Sec. 3.2 / Table 1)
# --------------------------------------------------------------------------------------------

def _reconstruction_error(s: float) -> float:
    """Max |G - bilinear(G sampled at unit spacing)| of a peak-1 bivariate Gaussian of std ``s``,
    worst sample-grid offset (offsets in [0, 1/2]^2 suffice by symmetry).

    The error peaks near the Gaussian's centre, so a window of s / 2 + 2 cells is searched; the
    worst case found is the peak midway between four samples, 1 - exp(-1 / (4 s^2)).
    """
    n = 16  # evaluation points per cell
    k = int(math.ceil(0.5 * s)) + 2
    curves = []
    for o in np.linspace(0.0, 0.5, 5):
        xs = np.arange(-k, k + 1) + o
        xf = np.arange(-k * n, k * n + 1) / n + o
        lin = np.interp(xf, xs, np.exp(-0.5 * (xs / s) ** 2))
        curves.append((lin, np.exp(-0.5 * (xf / s) ** 2)))
    err = 0.0
    for i, (la, ga) in enumerate(curves):
        for lb, gb in curves[i:]:
            err = max(err, float(np.abs(np.outer(la, lb) - np.outer(ga, gb)).max()))
    return err


@lru_cache(maxsize=None)
def _unit_key_width(omega: float) -> float:
    from scipy.optimize import brentq

    return float(brentq(lambda s: _reconstruction_error(s) - omega, 0.3, 30.0, xtol=1e-7))


def key_width(ratio: float, omega: float = 0.02) -> float:
    """Smallest Gaussian width (in base texels) a map down-sampled by ``ratio`` can hold.

    Chan & Wang Sec. 3.2 / Table 1: the smallest ``r`` with max |G_r - E(R(G_r))| <= ``omega``,
    ``G_r`` a peak-normalised bivariate Gaussian, ``R`` point sampling at spacing ``ratio`` (the
    worst grid offset) and ``E`` bilinear enlargement. The width is the standard deviation
    ``sigma`` (G = exp(-x^2 / 2 sigma^2)). It is found numerically (root of the sampled error);
    the worst case is the peak midway between four samples, so it matches the closed form
    ``ratio / (2 sqrt(-ln(1 - omega)))``. The problem is scale-free, so the width is exactly
    linear: ``3.518 * ratio`` for omega = 0.02 (7.04, 14.1, 28.1, 56.3, 112.6, 225.1 for
    /2 .. /64). Table 1 gives 4.6, 10.5, 21.6, 43.4, 86.9, 173.7, tending to 2.71 * ratio: ours is
    1.30x wider from /8 on (1.53x at /2, where Table 1's discrete 512-texel computation falls
    below its own asymptote). The univariate version of the same test gives 2.49 * ratio and a
    univariate box-filtered ``R`` 2.86 * ratio, bracketing Table 1's 2.71, so Table 1 evidently
    measured a one-dimensional profile; the bivariate bound (as the paper's Fig. 9 caption asks)
    makes the error sqrt(2) stricter in width.
    """
    return float(ratio) * _unit_key_width(float(omega))


# --------------------------------------------------------------------------------------------
# The chain
# --------------------------------------------------------------------------------------------

@dataclass
class EnvironmentChain:
    """Key filtered cube maps in one atlas (layout in the module docstring)."""

    res: int  # base face resolution (a power of two)
    levels: int  # number of levels, the last with 1 x 1 faces
    sigma: np.ndarray  # (levels,) Gaussian std per level, radians; sigma[0] = 0 (the source)
    rows: np.ndarray  # (levels,) first atlas row of each level
    atlas: np.ndarray  # float32 (sum(res_l + 2), 6 (res + 2), 4)
    mean: np.ndarray  # (3,) solid-angle-weighted average colour C_A

    def level_res(self, level: int) -> int:
        return self.res >> level

    @classmethod
    def from_equirect(cls, image: ArrayLike, res: int = 128, omega: float = 0.02) -> "EnvironmentChain":
        """Chain of an equirectangular (H, W, C) image, row 0 at the bottom."""
        return build_chain(np.asarray(image), res, omega)

    @classmethod
    def uniform(cls, color: ArrayLike) -> "EnvironmentChain":
        """A constant world: a single level of 1 x 1 faces."""
        c = np.zeros(4, np.float32)
        rgb = np.broadcast_to(np.asarray(color, np.float64).ravel()[:3], (3,))
        c[:3] = rgb
        c[3] = 1.0
        atlas = np.broadcast_to(c, (3, 18, 4)).astype(np.float32)
        return cls(1, 1, np.zeros(1), np.zeros(1, np.int64), atlas, rgb.copy())


def _rgb(values: np.ndarray) -> np.ndarray:
    values = np.asarray(values, np.float64)
    if values.shape[-1] == 1:
        return np.repeat(values, 3, axis=-1)
    return values[..., :3]


def _face_lookup_nearest(faces: np.ndarray) -> Callable[[ArrayLike], np.ndarray]:
    """Direction -> value of the nearest texel of unbordered (6, n, n, C) faces."""
    n = faces.shape[1]

    def look(d: ArrayLike) -> np.ndarray:
        f, s, t = cubemap.direction_to_face_st(d)
        i = np.clip(np.floor((t + 1.0) * 0.5 * n).astype(np.int64), 0, n - 1)
        j = np.clip(np.floor((s + 1.0) * 0.5 * n).astype(np.int64), 0, n - 1)
        return faces[f, i, j]

    return look


def _box_down(faces: np.ndarray, omega: np.ndarray):
    """Solid-angle-weighted 2 x 2 box downsampling of (6, n, n, C) faces with texel solid angles."""
    n = faces.shape[1] // 2
    w = omega.reshape(6, n, 2, n, 2)
    wsum = w.sum(axis=(2, 4))
    v = (faces.reshape(6, n, 2, n, 2, -1) * w[..., None]).sum(axis=(2, 4)) / wsum[..., None]
    return v, wsum


def _level0(source, res: int):
    """Bordered level-0 faces (6, res + 2, res + 2, 3) from a callable, equirect or cube faces."""
    ss = 1
    if callable(source):
        look = source
    elif source.ndim == 4:
        faces = _rgb(source)
        n = faces.shape[1]
        if n % res or (n // res) & (n // res - 1):
            raise ValueError(f"face resolution {n} is not a power-of-two multiple of {res}")
        om = cubemap.texel_solid_angles(n)
        while faces.shape[1] > res:
            faces, om = _box_down(faces, om)
        look = _face_lookup_nearest(faces)
    else:
        image = _rgb(source)
        look = lambda d: sample_equirect(image, d)  # noqa: E731
        ss = max(1, min(4, int(math.ceil(image.shape[1] / (4.0 * res)))))  # equirect px per texel
    # ss x ss sub-samples per texel (anti-aliasing a finer equirect), border texels included.
    i = np.arange(-1, res + 1)[:, None] + (np.arange(ss) + 0.5)[None, :] / ss
    c = (2.0 * i / res - 1.0).ravel()
    t, s = np.meshgrid(c, c, indexing="ij")
    out = []
    for f in range(6):
        v = _rgb(look(cubemap.face_st_to_direction(f, s, t)))
        v = v.reshape(res + 2, ss, res + 2, ss, 3).mean(axis=(1, 3))
        out.append(v)
    return np.stack(out)


def _gaussian_filter(src_dirs, src_vals, src_omega, out_dirs, sigma: float):
    """Direction-based Gaussian convolution on the sphere (Chan & Wang Sec. 3.1, done by direction).

    out_i = sum_j g(theta_ij) Omega_j v_j / sum_j g(theta_ij) Omega_j, g = exp(-theta^2 / 2 sigma^2)
    truncated at KERNEL_CUTOFF sigma.
    """
    theta_max = min(KERNEL_CUTOFF * sigma, np.pi)
    n_out, n_src = len(out_dirs), len(src_dirs)
    if n_out * n_src <= 4_000_000:
        dots = np.clip(out_dirs @ src_dirs.T, -1.0, 1.0)
        theta = np.arccos(dots)
        w = np.exp(-0.5 * (theta / sigma) ** 2) * src_omega[None, :]
        w[theta > theta_max] = 0.0
        return (w @ src_vals) / w.sum(axis=1, keepdims=True)
    from scipy.spatial import cKDTree

    chord = 2.0 * math.sin(0.5 * theta_max) + 1e-12
    pairs = cKDTree(out_dirs).sparse_distance_matrix(cKDTree(src_dirs), chord, output_type="ndarray")
    i, j, c = pairs["i"], pairs["j"], pairs["v"]
    theta = 2.0 * np.arcsin(np.minimum(0.5 * c, 1.0))
    w = np.exp(-0.5 * (theta / sigma) ** 2) * src_omega[j]
    wsum = np.bincount(i, w, n_out)
    return np.stack([np.bincount(i, w * src_vals[j, k], n_out) for k in range(src_vals.shape[1])],
                    axis=1) / wsum[:, None]


def build_chain(source: np.ndarray | Callable[[np.ndarray], ArrayLike], res: int,
                omega: float = 0.02) -> EnvironmentChain:
    """Build the key filtered chain (Chan & Wang Sec. 3.2 / Table 1) at base face resolution ``res``.

    ``source``: an equirectangular (H, W, C) image (row 0 at the bottom), unbordered cube faces
    (6, n, n, C) with n a power-of-two multiple of ``res``, or a callable ``f(directions) -> (..., C)``.
    Level l (faces res >> l) is the source convolved on the sphere with a Gaussian of std
    ``sigma[l] = key_width(2^l, omega) * alpha``, alpha = pi / (2 res) the angle of a base texel at
    a face centre (Table 1's alpha), taking the source box-downsampled to the coarsest power-of-two
    resolution whose texels are at most sigma / MIN_TEXELS wide (not below MIN_SOURCE_RES).

    Cost: res = 128 from a 512 x 256 equirect builds in about 1 s on 2 cores.
    """
    res = int(res)
    if res < 1 or res & (res - 1):
        raise ValueError(f"res must be a power of two, got {res}")
    nlev = int(round(math.log2(res))) + 1
    base = _level0(source, res)  # (6, res + 2, res + 2, 3)
    faces0 = base[:, 1:-1, 1:-1]
    om0 = cubemap.texel_solid_angles(res)
    mean = (faces0 * om0[..., None]).sum(axis=(0, 1, 2)) / om0.sum()

    pyramid = {res: (faces0, om0)}
    r = res
    while r > 1:
        pyramid[r // 2] = _box_down(*pyramid[r])
        r //= 2

    alpha = 0.5 * np.pi / res
    sigma = np.array([0.0] + [key_width(2**lv, omega) * alpha for lv in range(1, nlev)])
    rows = np.cumsum([0] + [(res >> lv) + 2 for lv in range(nlev - 1)]).astype(np.int64)
    height = int(sum((res >> lv) + 2 for lv in range(nlev)))
    atlas = np.zeros((height, 6 * (res + 2), 4), np.float32)
    atlas[..., 3] = 1.0
    atlas[: res + 2, :, :3] = cubemap.atlas_from_faces(base)
    for lv in range(1, nlev):
        rl = res >> lv
        rs = res
        while rs > 1 and rs // 2 >= MIN_SOURCE_RES and 0.5 * np.pi / (rs // 2) * MIN_TEXELS <= sigma[lv]:
            rs //= 2
        vals, om = pyramid[rs]
        out_dirs = cubemap.texel_directions(rl, 1).reshape(-1, 3)
        src_dirs = cubemap.texel_directions(rs, 0).reshape(-1, 3)
        out = _gaussian_filter(src_dirs, vals.reshape(-1, 3), om.ravel(), out_dirs, float(sigma[lv]))
        faces = out.reshape(6, rl + 2, rl + 2, 3)
        atlas[rows[lv]: rows[lv] + rl + 2, : 6 * (rl + 2), :3] = cubemap.atlas_from_faces(faces)
    return EnvironmentChain(res, nlev, sigma, rows, atlas, mean)


# --------------------------------------------------------------------------------------------
# Lookup (CPU twin of the shader)
# --------------------------------------------------------------------------------------------

def fractional_level(sigma: ArrayLike, theta_bar: ArrayLike) -> np.ndarray | float:
    """Fractional level of blur width ``theta_bar`` (radians): piecewise linear in ``sigma``.

    ``f = l + (theta_bar - sigma[l]) / (sigma[l + 1] - sigma[l])`` for sigma[l] <= theta_bar <
    sigma[l + 1]; 0 for theta_bar <= 0, levels - 1 for theta_bar >= sigma[-1].
    """
    sigma = np.asarray(sigma, np.float64)
    theta = np.asarray(theta_bar, np.float64)
    if len(sigma) < 2:
        return np.zeros_like(theta)
    return np.interp(theta, sigma, np.arange(len(sigma), dtype=np.float64))


def sample(chain: EnvironmentChain, d: ArrayLike, theta_bar: ArrayLike = 0.0) -> np.ndarray:
    """Environment colour (..., 3) in directions ``d`` blurred by ``theta_bar`` (radians).

    ``f = fractional_level(chain.sigma, theta_bar)``, ``l0 = floor(f)``, ``l1 = min(l0 + 1,
    levels - 1)``, ``t = f - l0``; result = ``(1 - t) A(l0) + t A(l1)`` with ``A(l)`` the bilinear
    lookup ``cubemap.sample_atlas(atlas, res >> l, d, rows[l])``.
    """
    d = np.asarray(d, np.float64)
    f = np.broadcast_to(fractional_level(chain.sigma, theta_bar), d.shape[:-1])
    out = np.zeros(d.shape[:-1] + (3,))
    for lv in range(chain.levels):
        w = np.maximum(0.0, 1.0 - np.abs(f - lv))  # hat weights = (1 - t, t) on (l0, l1)
        if not w.any():
            continue
        a = cubemap.sample_atlas(chain.atlas, chain.res >> lv, d, int(chain.rows[lv]))[..., :3]
        out += w[..., None] * a
    return out

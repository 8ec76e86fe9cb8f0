"""Caustics mapping (Shah ch. 5): the light-space geometry of the GPU passes, in NumPy.

The GPU passes (``techniques/caustics/passes.py``, ``gpu_shaders/caustics/``) refract a grid of rays
fitted around each caster, estimate where each ray meets the receivers from the receivers'
positions seen by the light (Shah 5.3.3-5.3.4), and splat its flux there. This module is the
same arithmetic on arrays: the tests compare the GPU against it, and the bench uses it to
measure the intersection estimate against exact ray casting.

Pure (NumPy).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...core.geometry.optics import reflect, refract
from ...core.lights import DIRECTIONAL, Emitter
from ...core.physics.fresnel import fresnel_dielectric
from ...gpu import blocks


@dataclasses.dataclass(frozen=True)
class Caster:
    """A caustics caster (Shah ch. 5): it refracts (through one or two surfaces) or mirrors the light of
    every emitter with caustics on, onto every other mesh."""

    mode: str = "REFRACTIVE"  # or "REFLECTIVE"
    eta: float = 1.5
    surfaces: int = 2  # refracting surfaces: 1 (a water surface), 2 (a solid, Wyman 2005)
    sigma_a: tuple = (0.0, 0.0, 0.0)  # absorption K_a per scene unit (Shah Eq. 5.7)
    dispersion: float = 0.0  # eta - s, eta, eta + s for red, green, blue; 0: one index
    tint: tuple = (1.0, 1.0, 1.0)  # reflectance of a reflective caster


@dataclasses.dataclass(frozen=True)
class CausticSettings:
    """Scene-wide caustics mapping settings (Shah 5.3.3-5.3.6)."""

    grid: int = 128  # vertex grid per caster, texels per side
    iterations: int = 4  # look-ups of the intersection estimate
    guard: bool = True  # oscillation guard: bisection once the estimates bracket the root
    secant: bool = True  # secant steps after the first (with the guard); False: Shah's iteration only
    texels: int = 1024  # caustic and receiver-position map, texels per face
    splat_sigma: float = 1.0  # Gaussian splat width, texels (the smallest with adaptive splats)
    adaptive: bool = True  # widen each splat to the spacing of its neighbours' landing points
    splat_sigma_max: float = 16.0


def estimate_intersection(v: np.ndarray, r: np.ndarray, lookup, iterations: int, guard: bool = True,
                          secant: bool = False):
    """Where rays v + d r meet the receivers, by Shah's estimate (Eq. 5.1-5.3).

    ``lookup(points) -> (positions, valid)`` returns the receiver point the light sees in the
    direction of each point (the positions texture). The first distance is that of the receiver
    behind v itself, d_0 = |y(v) - v|; each iteration looks up y_k = y(v + d_k r) and sets
    d_{k+1} = |y_k - v| (Shah's approximation of Newton-Raphson, Eq. 5.4). The root of
    g(d) = |y(v + d r) - v| - d is the intersection (Theorem 1).

    Oscillation guard (Shah 5.3.4: "detected by storing the last two estimates ... remedied by
    switching to ... bisection"): once g has changed sign between two estimates they bracket the
    root; a step that leaves the bracket or does not shrink |g| is replaced by the bracket's
    midpoint. ``secant``: after the first step, the root of the line through the last two (d, g)
    pairs (the Secant method the paper names as an alternative, same one look-up per step).
    Returns (points y_k, valid, d, query) after ``iterations`` look-ups (``query``: the
    point of the last look-up); a ray whose look-up finds no receiver is invalid (its splat is lost,
    as in the paper).
    """
    v = np.asarray(v, np.float64)
    r = np.asarray(r, np.float64)
    y, valid = lookup(v)
    d = np.where(valid, np.linalg.norm(y - v, axis=-1), 0.0)
    lo = np.full(len(v), -np.inf)  # largest d with g > 0
    hi = np.full(len(v), np.inf)  # smallest d with g < 0
    g_prev = np.full(len(v), np.inf)
    d_prev = np.full(len(v), np.nan)
    g_signed = np.full(len(v), np.nan)
    query = v
    for _ in range(max(int(iterations), 1)):
        query = np.where(valid[:, None], v + d[:, None] * r, query)
        y_k, ok = lookup(query)
        valid &= ok
        d_new = np.linalg.norm(y_k - v, axis=-1)
        g = d_new - d
        y = np.where(ok[:, None], y_k, y)
        if secant:
            with np.errstate(divide="ignore", invalid="ignore"):
                slope = (g - g_signed) / (d - d_prev)
            use = np.isfinite(slope) & (np.abs(slope) > 1e-12)
            d_new = np.where(use, d - g / np.where(use, slope, 1.0), d_new)
            d_prev, g_signed = d, g
        if guard:
            lo = np.where(g > 0, np.maximum(lo, d), lo)
            hi = np.where(g < 0, np.minimum(hi, d), hi)
            bracketed = np.isfinite(lo) & np.isfinite(hi)
            bad = bracketed & ((d_new <= lo) | (d_new >= hi) | (np.abs(g) >= np.abs(g_prev)))
            mid = 0.5 * (np.where(bracketed, lo, 0.0) + np.where(bracketed, hi, 0.0))
            d_new = np.where(bad, mid, d_new)
        g_prev = np.abs(g)
        d = np.where(ok, d_new, d)
    return y, valid, d, query


# -- light-space grids and maps -------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class CasterGrid:
    """The vertex grid of one caster: a projection from the light fitted around the caster's
    bounding sphere, ``size`` x ``size`` texels (Shah 5.3.2: one vertex per texel)."""

    view_proj: np.ndarray  # (4, 4) world -> clip
    size: int
    kind: int  # DIRECTIONAL or POINT
    half_extent: float  # tan of the half angle (POINT) or half width in world units (DIRECTIONAL)

    def texel_flux_factor(self) -> np.ndarray:
        """Per texel (size, size): the solid angle it subtends (POINT, times the intensity gives its
        flux) or its area across the beam (DIRECTIONAL, times the irradiance)."""
        c = (np.arange(self.size) + 0.5) / self.size * 2.0 - 1.0
        x, y = np.meshgrid(c, c)
        if self.kind == DIRECTIONAL:
            return np.full(x.shape, (2.0 * self.half_extent / self.size) ** 2)
        return texel_solid_angle(x, y, self.half_extent, self.size)


def texel_solid_angle(x, y, tan_half: float, size: int):
    """Solid angle of a texel of a square perspective image at NDC (x, y): the image plane at unit
    distance spans 2 tan_half; a texel of side a = 2 tan_half / size at (u, v) subtends
    a^2 / (1 + u^2 + v^2)^(3/2)."""
    a = 2.0 * tan_half / size
    u2 = (np.asarray(x) * tan_half) ** 2 + (np.asarray(y) * tan_half) ** 2
    return a * a / (1.0 + u2) ** 1.5


class CausticError(ValueError):
    """A caster that cannot be mapped from a light (the light inside its bounds)."""


def caster_grid(e: Emitter, centre, radius: float, size: int, margin: float = 1.02) -> CasterGrid:
    """A projection from the light that just contains the caster's bounding sphere."""
    centre = np.asarray(centre, np.float64)
    radius = float(radius) * margin
    if e.kind == DIRECTIONAL:
        axis = np.asarray(e.direction, np.float64)
        origin = centre - axis * 2.0 * radius
        vp = blocks.orthographic(radius, radius, 0.0, 4.0 * radius) @ blocks.look_at(origin, axis, (0, 0, 1))
        return CasterGrid(vp, int(size), DIRECTIONAL, radius)
    pos = np.asarray(e.position, np.float64)
    dist = float(np.linalg.norm(centre - pos))
    if dist <= radius * 1.05:
        raise CausticError(f"light '{e.source}' is inside the caster's bounds: no caustic map from there")
    half = math.asin(radius / dist)
    near = max(dist - radius, 1e-4)
    proj = blocks.perspective(2.0 * half, 1.0, near * 0.5, dist + radius)
    vp = proj @ blocks.look_at(pos, centre - pos, (0, 0, 1))
    return CasterGrid(vp, int(size), e.kind, math.tan(half))


def project(view_proj: np.ndarray, points: np.ndarray) -> np.ndarray:
    """NDC (x, y) of world points."""
    p = np.concatenate([np.asarray(points, np.float64), np.ones((len(points), 1))], axis=1) @ view_proj.T
    return p[:, :2] / p[:, 3:4]


def atlas_texels(e: Emitter, faces: np.ndarray, points: np.ndarray, texels: int):
    """Texel (column, row) in the 3 x 2 light atlas of ``pipeline.py`` and the NDC of world points, as
    the GLSL ``light_atlas_texel`` computes them: the cube face by the major axis of p - light (POINT)
    or the single orthographic face (DIRECTIONAL). Returns (col, row, inside)."""
    points = np.asarray(points, np.float64)
    if e.kind == DIRECTIONAL:
        face = np.zeros(len(points), int)
    else:
        rel = points - np.asarray(e.position)
        a = np.abs(rel)
        major = np.where((a[:, 0] >= a[:, 1]) & (a[:, 0] >= a[:, 2]), 0, np.where(a[:, 1] >= a[:, 2], 1, 2))
        face = 2 * major + (np.take_along_axis(rel, major[:, None], 1)[:, 0] < 0)
    ph = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    clip = np.einsum("nij,nj->ni", faces[face], ph)
    uv = clip[:, :2] / clip[:, 3:4] * 0.5 + 0.5
    inside = np.all((uv >= 0.0) & (uv <= 1.0), axis=1) & (clip[:, 3] > 0)
    ij = np.clip(np.floor(uv * texels).astype(int), 0, texels - 1)
    col = (face % 3) * texels + ij[:, 0]
    row = (face // 3) * texels + ij[:, 1]
    return col, row, inside


def atlas_lookup(e: Emitter, faces: np.ndarray, atlas: np.ndarray, texels: int):
    """``lookup`` for ``estimate_intersection`` over a receiver-position atlas (rows, cols, 4):
    xyz and w = 1 where a receiver was drawn (nearest texel, as the GPU's texelFetch)."""

    def lookup(points):
        col, row, inside = atlas_texels(e, faces, points, texels)
        value = atlas[row, col]
        return value[:, :3].astype(np.float64), inside & (value[:, 3] > 0.5)

    return lookup


def receiver_patch_area(e: Emitter, points: np.ndarray, normals: np.ndarray, texels: int, radius: float):
    """Receiver area seen through one caustic-atlas texel at each point: the texel's solid angle times
    r^2 over the cosine to the light (POINT: 90-degree faces), or (2 R / N)^2 over the cosine
    (DIRECTIONAL; R the scene radius of the shadow projection). Flux per texel / area = irradiance."""
    points = np.asarray(points, np.float64)
    normals = np.asarray(normals, np.float64)
    if e.kind == DIRECTIONAL:
        cos_l = np.abs(normals @ np.asarray(e.direction))
        return (2.0 * radius / texels) ** 2 / np.maximum(cos_l, 1e-3)
    rel = points - np.asarray(e.position)
    r = np.linalg.norm(rel, axis=1)
    cos_l = np.abs(np.sum(normals * rel, axis=1)) / r
    a = np.abs(rel)
    major = a.max(axis=1)
    minor2 = (np.sum(a * a, axis=1) - major**2) / major**2  # u^2 + v^2 on the face plane
    omega = (2.0 / texels) ** 2 / (1.0 + minor2) ** 1.5
    return omega * r * r / np.maximum(cos_l, 1e-3)


def grid_lookup(grid: CasterGrid, back_position: np.ndarray):
    """``lookup`` over a caster's back-face positions (size, size, 4) in its grid projection."""

    def lookup(points):
        ph = np.concatenate([np.asarray(points, np.float64), np.ones((len(points), 1))], axis=1) @ grid.view_proj.T
        uv = ph[:, :2] / ph[:, 3:4] * 0.5 + 0.5
        inside = np.all((uv >= 0.0) & (uv <= 1.0), axis=1) & (ph[:, 3] > 0)
        ij = np.clip(np.floor(uv * grid.size).astype(int), 0, grid.size - 1)
        value = back_position[ij[:, 1], ij[:, 0]]
        return value[:, :3].astype(np.float64), inside & (value[:, 3] > 0.5), ij

    return lookup


def trace_grid(e: Emitter, grid: CasterGrid, caster, front_position, front_normal, back_position, back_normal,
               receivers, iterations: int, guard: bool = True, secant: bool = False):
    """The NumPy twin of ``caustics/trace.glsl`` (one channel, no dispersion, no occluder between the light
    and the caster: the shader's shadow-map test is left out): per grid texel the landing point
    (size, size, 3), its flux (size, size, 3) and validity (size, size)."""
    G = grid.size
    covered = front_position[..., 3] > 0.5
    v = front_position[..., :3].reshape(-1, 3).astype(np.float64)
    n = front_normal[..., :3].reshape(-1, 3).astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    factor = grid.texel_flux_factor().reshape(-1)
    radiance = np.asarray(e.radiance, np.float64)
    if e.kind == DIRECTIONAL:
        d = np.broadcast_to(np.asarray(e.direction, np.float64), v.shape).copy()
    else:
        rel = v - np.asarray(e.position)
        d = rel / np.maximum(np.linalg.norm(rel, axis=1, keepdims=True), 1e-12)
    flux = radiance[None, :] * factor[:, None]
    n = np.where((np.sum(n * d, axis=1) > 0)[:, None], -n, n)
    valid = covered.reshape(-1).copy()
    if caster.mode == "REFLECTIVE":
        r = reflect(d, n)
        flux *= np.asarray(caster.tint)
    else:
        flux *= (1.0 - fresnel_dielectric(-np.sum(d * n, axis=1), caster.eta))[:, None]
        r, _ = refract(d, n, 1.0 / caster.eta)
        if caster.surfaces == 2:
            back = grid_lookup(grid, back_position)
            exit_p, ok, _, query = estimate_intersection(v, r, lambda p: back(p)[:2], iterations, guard or secant,
                                                          secant)
            ij = back(query)[2]
            nb = back_normal[ij[:, 1], ij[:, 0], :3].astype(np.float64)
            nb /= np.maximum(np.linalg.norm(nb, axis=1, keepdims=True), 1e-12)
            nb = np.where((np.sum(nb * r, axis=1) > 0)[:, None], -nb, nb)
            r2, ok2 = refract(r, nb, caster.eta)
            T2 = 1.0 - fresnel_dielectric(-np.sum(r * nb, axis=1), 1.0 / caster.eta)
            chord = np.linalg.norm(exit_p - v, axis=1)
            flux *= T2[:, None] * np.exp(-np.outer(chord, np.asarray(caster.sigma_a)))
            valid &= ok & ok2
            v, r = exit_p, r2
    y, ok, _, _ = estimate_intersection(v, r, receivers, iterations, guard or secant, secant)
    valid &= ok
    y = v + np.linalg.norm(y - v, axis=1, keepdims=True) * r  # on the ray, not snapped to the map's texel
    if caster.mode != "REFLECTIVE" and caster.surfaces == 1:
        flux *= np.exp(-np.outer(np.linalg.norm(y - v, axis=1), np.asarray(caster.sigma_a)))
    return y.reshape(G, G, 3), np.where(valid[:, None], flux, 0.0).reshape(G, G, 3), valid.reshape(G, G)

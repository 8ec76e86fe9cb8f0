"""Exact caustic of a glass sphere on a plane: photons traced through the analytic sphere.

The reference the caustics-mapping passes are measured against (bench and tests): rays from a
point or directional light through the sphere's silhouette, refracted in and out with exact
Fresnel transmittance and Beer absorption along the chord (Shah Eq. 5.7), landing on the plane
z = ``plane_z``. No approximation but the Monte Carlo count: stratified over the silhouette,
the total flux is exact to rounding. Paths reflected inside the sphere are left out (the
caustics-mapping model has none; they carry (F_in-side)^2 ~ 0.2 % of the flux).

Pure (NumPy).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..geometry.optics import refract
from ..lights import DIRECTIONAL, Emitter
from ..physics.fresnel import fresnel_dielectric


@dataclasses.dataclass(frozen=True)
class GlassSphere:
    centre: tuple
    radius: float
    eta: float
    sigma_a: tuple = (0.0, 0.0, 0.0)  # per scene unit (Eq. 5.7's K_a)


def _sphere_exit(p, d, centre, radius):
    """Far intersection of rays p + t d (p on or inside the sphere, d unit)."""
    oc = p - centre
    b = np.sum(oc * d, axis=1)
    c = np.sum(oc * oc, axis=1) - radius * radius
    return -b + np.sqrt(np.clip(b * b - c, 0.0, None))


def trace(e: Emitter, sphere: GlassSphere, plane_z: float, n: int = 1_000_000,
          seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Photons through the sphere to the plane: (points (M, 3), flux (M, 3), total flux through the
    silhouette (3,)). Flux in the light's units times steradians (POINT) or area (DIRECTIONAL)."""
    rng = np.random.default_rng(seed)
    c = np.asarray(sphere.centre, np.float64)
    R = float(sphere.radius)
    k = int(math.sqrt(n))
    u = (np.arange(k)[:, None] + rng.random((k, k))) / k  # stratified
    w = (np.arange(k)[None, :] + rng.random((k, k))) / k
    u, w = u.ravel(), w.ravel()
    radiance = np.asarray(e.radiance, np.float64)
    if e.kind == DIRECTIONAL:
        axis = np.asarray(e.direction, np.float64)
        a, b = _basis(axis)
        rad = R * np.sqrt(u)
        phi = 2 * np.pi * w
        origin = c - 2 * R * axis + (rad * np.cos(phi))[:, None] * a + (rad * np.sin(phi))[:, None] * b
        d = np.broadcast_to(axis, origin.shape).copy()
        per_ray = radiance * (math.pi * R * R) / len(u)
    else:
        pos = np.asarray(e.position, np.float64)
        to_c = c - pos
        dist = np.linalg.norm(to_c)
        axis = to_c / dist
        a, b = _basis(axis)
        cos_max = math.sqrt(max(1.0 - (R / dist) ** 2, 0.0))
        cos_t = 1.0 - u * (1.0 - cos_max)  # uniform in solid angle over the cone around the sphere
        sin_t = np.sqrt(1.0 - cos_t**2)
        phi = 2 * np.pi * w
        d = cos_t[:, None] * axis + (sin_t * np.cos(phi))[:, None] * a + (sin_t * np.sin(phi))[:, None] * b
        origin = np.broadcast_to(pos, d.shape).copy()
        per_ray = radiance * (2 * math.pi * (1.0 - cos_max)) / len(u)
        # The spot and area lobes are not modelled here (the bench uses plain point and sun lights).
    total = per_ray * len(u)
    # Entry.
    oc = origin - c
    b_ = np.sum(oc * d, axis=1)
    disc = b_ * b_ - (np.sum(oc * oc, axis=1) - R * R)
    hit = disc > 0
    t0 = -b_ - np.sqrt(np.clip(disc, 0.0, None))
    p1 = origin + t0[:, None] * d
    n1 = (p1 - c) / R
    cos1 = -np.sum(d * n1, axis=1)
    T1 = 1.0 - fresnel_dielectric(cos1, sphere.eta)
    t1, ok1 = refract(d, n1, 1.0 / sphere.eta)
    # Exit.
    chord = _sphere_exit(p1, t1, c, R)
    p2 = p1 + chord[:, None] * t1
    n2 = -(p2 - c) / R  # facing against the ray inside
    cos2 = -np.sum(t1 * n2, axis=1)
    T2 = 1.0 - fresnel_dielectric(cos2, 1.0 / sphere.eta)
    t2, ok2 = refract(t1, n2, sphere.eta)
    flux = (T1 * T2)[:, None] * np.exp(-np.outer(chord, np.asarray(sphere.sigma_a))) * per_ray
    # Plane.
    down = t2[:, 2] < -1e-9
    s = (plane_z - p2[:, 2]) / np.where(down, t2[:, 2], -1.0)
    keep = hit & ok1 & ok2 & down & (s > 0)
    points = p2 + s[:, None] * t2
    return points[keep], flux[keep], total


def irradiance_grid(points: np.ndarray, flux: np.ndarray, lo: float, hi: float,
                    res: int) -> tuple[np.ndarray, np.ndarray]:
    """Histogram of landed flux over the square [lo, hi]^2 of the plane: E (res, res, 3) per unit
    area, rows along y (row 0 at lo), and the cell centres."""
    edges = np.linspace(lo, hi, res + 1)
    cell = (hi - lo) / res
    E = np.stack(
        [np.histogram2d(points[:, 1], points[:, 0], bins=(edges, edges), weights=flux[:, ch])[0] for ch in range(3)],
        axis=-1,
    ) / (cell * cell)
    centres = 0.5 * (edges[:-1] + edges[1:])
    return E, centres


def _basis(axis):
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    a = np.cross(axis, helper)
    a /= np.linalg.norm(a)
    return a, np.cross(axis, a)

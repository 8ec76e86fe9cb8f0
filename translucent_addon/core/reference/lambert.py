"""CPU reference of the base pass: Lambert shading, hard shadows, world light.

Per pixel centre: the nearest triangle along the camera ray, its interpolated
corner normal (flipped to face the viewer, as Cycles does for back faces), then

    L = rho * L_world + sum_lights rho / pi * E_light * V

with E_light from ``render.lights.unshadowed_irradiance`` and V a shadow ray.
The world term is the exact answer for an unoccluded convex surface under a
uniform environment (the GPU pass makes the same approximation); under an
environment image it is rho / pi E_sh(N), its irradiance to spherical-harmonic
order 2 (``physics.sh_irradiance``), as the base pass takes it.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

from ..frame import FrameInputs
from ..geometry.camera import pixel_rays
from ..geometry.mesh_measures import facing_side
from ..geometry.raycast import BruteForceTracer
from ..lights import DIRECTIONAL, unshadowed_irradiance
from ..physics.sh_irradiance import LAMBERT_KERNEL, irradiance

if TYPE_CHECKING:
    from ..lights import Emitter


def scene_triangles(frame: FrameInputs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World-space triangles, corner normals and colours of every mesh, concatenated."""
    if not frame.meshes:
        z = np.zeros((0, 3, 3))
        return z, z, z
    tris = np.concatenate([m.world_positions().reshape(-1, 3, 3) for m in frame.meshes])
    nors = np.concatenate([m.world_normals().reshape(-1, 3, 3) for m in frame.meshes])
    cols = np.concatenate([m.colors.astype(np.float64).reshape(-1, 3, 3) for m in frame.meshes])
    return tris, nors, cols


def shadowed_irradiance(emitters: Iterable[Emitter], points: np.ndarray, normals: np.ndarray,
                        tracer: Any) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Per emitter: (E (N, 3) with shadow rays cast by ``tracer``, unit directions to the light).

    ``points`` are already offset off the surface; directional emitters are tested to infinity.
    """
    for e in emitters:
        E, to_light, dist = unshadowed_irradiance(e, points, normals)
        lit = E.max(axis=1) > 0
        if lit.any():
            t_max = np.full(len(points), np.inf) if e.kind == DIRECTIONAL else dist
            blocked = np.zeros(len(points), dtype=bool)
            blocked[lit] = tracer.occluded(points[lit], to_light[lit], t_max[lit])
            E[blocked] = 0.0
        yield E, to_light


def render_lambert(frame: FrameInputs, shadow_offset: float = 1e-4, tracer: Any = None) -> np.ndarray:
    """Linear RGBA image (height, width, 4) of the frame, row 0 at the bottom.

    ``tracer``: ray queries over ``scene_triangles(frame)`` (brute force by default).
    """
    cam = frame.camera
    origins, dirs = pixel_rays(cam.view_proj, cam.width, cam.height)
    origins = origins.reshape(-1, 3)
    dirs = dirs.reshape(-1, 3)
    tris, nors, cols = scene_triangles(frame)
    tracer = tracer or BruteForceTracer(tris)
    t, tri, u, v = tracer.closest_hit(origins, dirs)
    hit = tri >= 0
    img = np.zeros((len(origins), 4))
    img[:, :3] = frame.world_color
    img[:, 3] = 0.0 if frame.film_transparent else 1.0
    if not hit.any():
        return img.reshape(cam.height, cam.width, 4)
    ti, ui, vi = tri[hit], u[hit, None], v[hit, None]
    w = 1.0 - ui - vi
    P = origins[hit] + t[hit, None] * dirs[hit]
    N = w * nors[ti, 0] + ui * nors[ti, 1] + vi * nors[ti, 2]
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-20)
    Ng = np.cross(tris[ti, 1] - tris[ti, 0], tris[ti, 2] - tris[ti, 0])
    facing_away = np.einsum("ij,ij->i", Ng, dirs[hit]) > 0
    N[facing_away] *= -1.0
    rho = w * cols[ti, 0] + ui * cols[ti, 1] + vi * cols[ti, 2]
    # The world's irradiance to SH order 2, unoccluded, as the base pass takes it (rho L for a uniform world).
    radiance = rho * irradiance(frame.world_sh(), LAMBERT_KERNEL, N) / math.pi
    scene_scale = max(float(np.ptp(tris.reshape(-1, 3), axis=0).max()), 1e-6)
    P_off = P + N * shadow_offset * scene_scale
    # A facet that faces away from a light is in its own shadow whatever its interpolated normal says
    # (a closed surface's ray towards the light enters the object), as in the base pass and Cycles.
    Ng = facing_side(Ng, N)
    for E, to_light in shadowed_irradiance(frame.emitters, P_off, N, tracer):
        facing = np.einsum("ij,ij->i", Ng, to_light) > 0
        radiance += rho * E * facing[:, None] / math.pi
    img[hit, :3] = radiance
    img[hit, 3] = 1.0
    return img.reshape(cam.height, cam.width, 4)

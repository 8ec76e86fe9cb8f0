"""Blender lights as point and directional emitters in Cycles' units.

Measured against Cycles 5.0 (direct light on a white diffuse plane, see
``tests/test_light_units.py``), Blender's light settings mean:

* sun: ``strength`` is the irradiance E [W/m^2] on a surface facing it;
* point and spot: radiant intensity I = P / (4 pi) [W/sr] for power P [W]
  (a spot is a point light with a cone, not a concentrated one);
* area: a one-sided Lambertian emitter of power P, on-axis intensity
  I_0 = P / pi, I(theta) = I_0 cos(theta). We approximate it by n x n point
  emitters of intensity P / (pi n^2) each, with the same cosine lobe.

Outgoing radiance of a Lambertian surface of albedo rho is rho E / pi.
These functions are the single source of that light model; the GLSL in
``gpu_shaders/pipeline/base_lighting.glsl`` implements the same formulas.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike

DIRECTIONAL = 0
POINT = 1


@dataclasses.dataclass(frozen=True)
class Emitter:
    """A point or directional emitter after conversion from Blender's units."""

    kind: int  # DIRECTIONAL or POINT
    position: tuple  # world position (POINT)
    direction: tuple  # unit emission axis: the light's local -Z in world space
    radiance: tuple  # RGB: irradiance [W/m^2] (DIRECTIONAL) or on-axis intensity [W/sr] (POINT)
    cos_half_angle: float = -2.0  # spot cone; below -1 means no cone
    spot_smooth: float = 0.0  # width of the spot blend, in cosine units
    cosine_lobe: bool = False  # area-light sample: intensity scaled by cos to the axis
    source: str = ""  # the Blender light it came from
    caustics: bool = True  # casters throw caustics of this emitter's light


def fitted_tan_half(e: Emitter) -> float:
    """The tangent of the half angle of one perspective face along a spot's axis that holds its whole cone
    (1 % wider), where that face is finer than a cube face at the same texels (a cone under 45 degrees);
    0 for other emitters. Outside the cone a spot sends no light, so no shadow is needed there."""
    if e.kind == DIRECTIONAL or e.cos_half_angle < -1.0 or e.cosine_lobe:
        return 0.0
    half = math.acos(min(e.cos_half_angle, 1.0)) * 1.01
    return math.tan(half) if half < math.pi / 4 else 0.0


def _normalized(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v)
    if n == 0:
        raise ValueError("light has a degenerate orientation (zero scale)")
    return v / n


def _area_sample_offsets(shape: str, size_x: float, size_y: float, n: int) -> np.ndarray:
    """Stratified sample centres on a rectangle or ellipse in the light's local XY plane."""
    c = (np.arange(n) + 0.5) / n * 2.0 - 1.0  # cell centres in [-1, 1]
    u, v = np.meshgrid(c, c, indexing="ij")
    u, v = u.ravel(), v.ravel()
    if shape in ("DISK", "ELLIPSE"):
        # Shirley-Chiu concentric map: equal-area square -> disk.
        r = np.where(np.abs(u) > np.abs(v), u, v)
        phi = np.where(
            np.abs(u) > np.abs(v),
            (math.pi / 4) * np.divide(v, u, out=np.zeros_like(v), where=u != 0),
            math.pi / 2 - (math.pi / 4) * np.divide(u, v, out=np.zeros_like(u), where=v != 0),
        )
        u, v = r * np.cos(phi), r * np.sin(phi)
    return np.stack([u * size_x * 0.5, v * size_y * 0.5, np.zeros_like(u)], axis=1)


def unnormalized_power(light_type: str, matrix_world: ArrayLike, *, radius: float = 0.0, angle: float = 0.0,
                       area_shape: str = "SQUARE", size: float = 0.0, size_y: float = 0.0) -> float:
    """What Cycles multiplies a light's power by when its Normalize is off (measured against Cycles, power off /
    on: tests/test_light_units.py): the emitting surface's area, 4 pi r^2 for a point or spot of radius r (4 at
    r = 0), the rectangle's or ellipse's area with the object's scale for an area light, pi sin^2(angle / 2) for
    a sun of angular diameter angle (1 at 0)."""
    if light_type in ("POINT", "SPOT"):
        return 4.0 * math.pi * radius * radius if radius > 0.0 else 4.0
    if light_type == "SUN":
        return math.pi * math.sin(0.5 * angle) ** 2 if angle > 0.0 else 1.0
    m = np.asarray(matrix_world, dtype=np.float64).reshape(4, 4)
    width = size * float(np.linalg.norm(m[:3, 0]))
    height = (size if area_shape in ("SQUARE", "DISK") else size_y) * float(np.linalg.norm(m[:3, 1]))
    return width * height * (math.pi / 4.0 if area_shape in ("DISK", "ELLIPSE") else 1.0)


def emitters_from_light(
    name: str,
    light_type: str,
    matrix_world: ArrayLike,
    color: ArrayLike,
    energy: float,
    *,
    spot_size: float = math.pi / 4,
    spot_blend: float = 0.15,
    area_shape: str = "SQUARE",
    size: float = 0.25,
    size_y: float = 0.25,
    area_samples: int = 2,
) -> list[Emitter]:
    """Convert one Blender light (its settings as plain values) into emitters."""
    m = np.asarray(matrix_world, dtype=np.float64).reshape(4, 4)
    rgb = np.asarray(color, dtype=np.float64)[:3] * float(energy)
    position = m[:3, 3]
    # The light points along its -Z; a light flattened along Z (an area light scaled to 0 there) still faces
    # the normal of its X and Y. Scaled to nothing: ValueError (``_normalized``).
    z = -m[:3, 2] if np.linalg.norm(m[:3, 2]) > 0 else -np.cross(m[:3, 0], m[:3, 1])
    axis = _normalized(z)
    if light_type == "SUN":
        return [Emitter(DIRECTIONAL, tuple(position), tuple(axis), tuple(rgb), source=name)]
    if light_type in ("POINT", "SPOT"):
        intensity = rgb / (4.0 * math.pi)
        cos_half, smooth = -2.0, 0.0
        if light_type == "SPOT":
            cos_half = math.cos(min(spot_size, math.pi) * 0.5)
            smooth = (1.0 - cos_half) * float(spot_blend)
        return [Emitter(POINT, tuple(position), tuple(axis), tuple(intensity), cos_half, smooth, source=name)]
    if light_type == "AREA":
        n = max(1, int(area_samples))
        sy = size_y if area_shape in ("RECTANGLE", "ELLIPSE") else size
        local = _area_sample_offsets(area_shape, size, sy, n)
        world = local @ m[:3, :3].T + position
        intensity = rgb / (math.pi * n * n)
        return [
            Emitter(POINT, tuple(p), tuple(axis), tuple(intensity), cosine_lobe=True, source=name) for p in world
        ]
    raise ValueError(f"light '{name}': unsupported type {light_type}")


def smoothstep01(x: ArrayLike) -> np.ndarray | float:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def unshadowed_irradiance(e: Emitter, points: np.ndarray,
                          normals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Irradiance from one emitter at surface points, without occlusion.

    Returns (E, to_light, distance): E (N, 3) in W/m^2, unit directions to the
    light (N, 3), distances (N,) (inf for a directional emitter).
    """
    points = np.asarray(points, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    radiance = np.asarray(e.radiance)
    if e.kind == DIRECTIONAL:
        to_light = np.broadcast_to(-np.asarray(e.direction), points.shape)
        cos_s = np.clip(np.einsum("ij,ij->i", normals, to_light), 0.0, None)
        return cos_s[:, None] * radiance, to_light, np.full(len(points), np.inf)
    d = np.asarray(e.position) - points
    dist = np.linalg.norm(d, axis=1)
    to_light = d / np.maximum(dist, 1e-12)[:, None]
    cos_s = np.clip(np.einsum("ij,ij->i", normals, to_light), 0.0, None)
    cos_axis = -to_light @ np.asarray(e.direction)  # angle from the emission axis
    lobe = np.ones(len(points))
    if e.cos_half_angle >= -1.0:
        if e.spot_smooth > 0:
            lobe *= smoothstep01((cos_axis - e.cos_half_angle) / e.spot_smooth)
        else:
            lobe *= cos_axis > e.cos_half_angle
    if e.cosine_lobe:
        lobe *= np.clip(cos_axis, 0.0, None)
    E = (lobe * cos_s / np.maximum(dist, 1e-12) ** 2)[:, None] * radiance
    return E, to_light, dist

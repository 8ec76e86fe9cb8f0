"""A tileable procedural grass patch: curved, tapering blades over the unit square (Shah 4.3.1).

Units are the tile's side (1.0). Blade roots lie in [0, 1)^2 and the patch repeats with period 1
in x and y, so a render of it (``techniques/grass/acquire.py``) is tileable by construction. Each blade is
a strip of ``segments`` quads along a bent centre line, narrowing to a point; it leans toward a
random azimuth and is twisted about its axis. Per vertex: the reflectance rho_r and the
transmittance rho_t of the leaf (diffuse through the blade: grass is translucent), from a root
colour to a tip colour with a per-blade variation and a share of dry, yellowed blades.
"""
from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class GrassParams:
    """What the BTF depends on. Sizes are fractions of the tile side."""

    blades: int = 500  # blades per tile
    height: float = 0.45  # tallest blade; the top of the grass layer
    width: float = 0.032  # blade width at its root
    bend: float = 0.35  # mean lean: tip's horizontal offset / blade height
    segments: int = 6
    dry_fraction: float = 0.12
    root_color: tuple = (0.020, 0.055, 0.012)  # rho_r at the root (linear)
    tip_color: tuple = (0.110, 0.260, 0.045)  # rho_r at the tip
    dry_color: tuple = (0.300, 0.250, 0.090)  # rho_r of a dry blade's tip
    transmit_ratio: float = 0.8  # rho_t / rho_r: a leaf transmits about as much as it reflects
    specular: float = 0.04  # cuticle sheen (Blinn-Phong weight)
    seed: int = 7

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclasses.dataclass
class GrassPatch:
    positions: np.ndarray  # (V, 3) float32, tile units, z up, roots at z = 0
    normals: np.ndarray  # (V, 3) float32 (one side; shading is two-sided)
    rho_r: np.ndarray  # (V, 3) float32 reflectance
    rho_t: np.ndarray  # (V, 3) float32 transmittance
    triangles: np.ndarray  # (T, 3) int32
    params: GrassParams


def build_patch(p: GrassParams = GrassParams()) -> GrassPatch:
    """The blades of one tile, vectorised over blades and segments."""
    if p.blades < 1 or p.segments < 1:
        raise ValueError("a grass patch needs at least one blade of one segment")
    rng = np.random.default_rng(p.seed)
    n, m = int(p.blades), int(p.segments)
    root = np.concatenate([rng.random((n, 2)), np.zeros((n, 1))], axis=1)
    H = p.height * (0.55 + 0.45 * rng.random(n))
    lean = p.bend * (0.4 + 1.2 * rng.random(n))
    azimuth = 2.0 * np.pi * rng.random(n)
    twist = (rng.random(n) - 0.5) * 0.9  # radians between the lean and the blade's flat side
    width = p.width * (0.7 + 0.6 * rng.random(n))
    s = np.linspace(0.0, 1.0, m + 1)  # parameter along the blade
    # Centre line: a quadratic lean, the height shortened so that the blade keeps its length.
    lean_dir = np.stack([np.cos(azimuth), np.sin(azimuth), np.zeros(n)], axis=1)
    horiz = (lean * H)[:, None] * s[None, :] ** 2  # (n, m+1)
    vert = H[:, None] * s[None, :] * (1.0 - 0.25 * (lean[:, None] ** 2) * s[None, :])
    centre = root[:, None, :] + horiz[..., None] * lean_dir[:, None, :] + vert[..., None] * np.array([0, 0, 1.0])
    # Tangent along the centre line, the blade's side vector horizontal and turned by the twist.
    tangent = np.gradient(centre, axis=1)
    tangent /= np.linalg.norm(tangent, axis=2, keepdims=True)
    side_angle = azimuth + 0.5 * np.pi + twist
    side = np.stack([np.cos(side_angle), np.sin(side_angle), np.zeros(n)], axis=1)[:, None, :]
    side = side - np.sum(side * tangent, axis=2, keepdims=True) * tangent
    side /= np.linalg.norm(side, axis=2, keepdims=True)
    normal = np.cross(tangent, side)
    half = 0.5 * width[:, None] * (1.0 - s[None, :] ** 1.5)  # tapering to a point
    left = centre - half[..., None] * side
    right = centre + half[..., None] * side
    positions = np.stack([left, right], axis=2).reshape(n, 2 * (m + 1), 3)
    normals = np.repeat(normal, 2, axis=1)
    # Colour: root to tip, +-20 % per blade, some blades dry.
    dry = rng.random(n) < p.dry_fraction
    tip = np.where(dry[:, None], np.asarray(p.dry_color), np.asarray(p.tip_color)) * (0.8 + 0.4 * rng.random((n, 1)))
    t = s[None, :, None] ** 0.8
    rho_r = (1.0 - t) * np.asarray(p.root_color)[None, None, :] + t * tip[:, None, :]
    rho_r = np.repeat(rho_r, 2, axis=1)
    # Triangles: two per quad of the strip.
    base = (np.arange(n) * 2 * (m + 1))[:, None]
    k = np.arange(m)[None, :] * 2
    a, b, c, d = base + k, base + k + 1, base + k + 2, base + k + 3
    tris = np.stack([np.stack([a, b, d], -1), np.stack([a, d, c], -1)], axis=2).reshape(-1, 3)
    return GrassPatch(
        positions=positions.reshape(-1, 3).astype(np.float32),
        normals=normals.reshape(-1, 3).astype(np.float32),
        rho_r=rho_r.reshape(-1, 3).astype(np.float32),
        rho_t=(p.transmit_ratio * rho_r).reshape(-1, 3).astype(np.float32),
        triangles=tris.astype(np.int32),
        params=p,
    )

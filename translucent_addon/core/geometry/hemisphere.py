"""Sampled directions on the upper hemisphere for BTFs (Shah 4.3.1) and their interpolation.

Views: 81 directions on six rings of constant polar angle, 0/15/30/45/60/75 degrees with
1/6/12/18/20/24 directions (the sampling of the Bonn BTF database, Sattler et al. 2003, which
has the 81 views of Shah's grass BTF). Lights: 21 directions on rings at 0/25/50/75 degrees with
1/5/7/8 directions. Both leave out the last 15 degrees above the horizon; a direction there is
drawn with the nearest direction on the outer ring.

Interpolation uses the three nearest sampled directions (Shah 4.3.3): the Delaunay triangle of
the direction's point in the polar disk map (x, y) = theta / (pi / 2) (cos phi, sin phi) and its
barycentric weights. The GPU reads them from a table over that disk (``direction_table``).
"""
from __future__ import annotations

from collections.abc import Iterable

import numpy as np

VIEW_RINGS = ((0.0, 1), (15.0, 6), (30.0, 12), (45.0, 18), (60.0, 20), (75.0, 24))
LIGHT_RINGS = ((0.0, 1), (25.0, 5), (50.0, 7), (75.0, 8))


def ring_directions(rings: Iterable[tuple[float, int]]) -> np.ndarray:
    """Unit directions (N, 3), z up, ring by ring; each ring starts at phi = 0 (odd rings offset by
    half a step, so that neighbouring rings interleave)."""
    out = []
    for k, (theta_deg, count) in enumerate(rings):
        theta = np.radians(theta_deg)
        phi = 2.0 * np.pi * (np.arange(count) + 0.5 * (k % 2)) / count
        out.append(np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                             np.full(count, np.cos(theta))], axis=1))
    return np.concatenate(out).astype(np.float64)


def view_directions() -> np.ndarray:
    return ring_directions(VIEW_RINGS)


def light_directions() -> np.ndarray:
    return ring_directions(LIGHT_RINGS)


def disk_coordinates(directions: np.ndarray) -> np.ndarray:
    """(x, y) = theta / (pi/2) (cos phi, sin phi): the polar map of the hemisphere onto the unit disk."""
    d = np.asarray(directions, np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    theta = np.arccos(np.clip(d[..., 2], -1.0, 1.0))
    rho = np.hypot(d[..., 0], d[..., 1])
    safe = np.where(rho > 1e-12, rho, 1.0)
    r = theta / (0.5 * np.pi)
    return np.stack([np.where(rho > 1e-12, d[..., 0] / safe, 1.0) * r,
                     np.where(rho > 1e-12, d[..., 1] / safe, 0.0) * r], axis=-1)


def solid_angle_weights(directions: np.ndarray, samples: int = 400_000, seed: int = 1) -> np.ndarray:
    """Solid angle of each direction's spherical Voronoi cell on the upper hemisphere (sums to 2 pi):
    uniform hemisphere samples, each given to its nearest direction."""
    counts, _ = _voronoi_cells(directions, samples, seed)
    return counts * (2.0 * np.pi / samples)


def sky_weights(directions: np.ndarray, samples: int = 400_000, seed: int = 1) -> np.ndarray:
    """Weights w_l integrating a BTF over a uniform sky: the integral of cos over each Voronoi cell divided
    by the cos of its direction, so that sum_l w_l f(l) is exact for a flat Lambert leaf (f ~ cos theta:
    sum w_l cos theta_l = pi). Plain solid angles overweight the outer ring, whose cell reaches the
    horizon (+6 % on the views, +4 % on the lights)."""
    counts, cos_sum = _voronoi_cells(directions, samples, seed)
    cos_l = np.maximum(np.asarray(directions, np.float64)[:, 2], 1e-6)
    cos_integral = cos_sum * (np.pi / cos_sum.sum())  # the cells' share of the exact total, pi
    return cos_integral / cos_l


def _voronoi_cells(directions, samples, seed):
    rng = np.random.default_rng(seed)
    u = rng.random((samples, 2))
    z = u[:, 0]
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    w = np.stack([r * np.cos(2 * np.pi * u[:, 1]), r * np.sin(2 * np.pi * u[:, 1]), z], axis=1)
    nearest = np.argmax(w @ np.asarray(directions, np.float64).T, axis=1)
    n = len(directions)
    return (np.bincount(nearest, minlength=n).astype(np.float64),
            np.bincount(nearest, weights=z, minlength=n))


class DirectionInterpolator:
    """The three nearest sampled directions of any direction, with barycentric weights (Shah 4.3.3)."""

    def __init__(self, directions: np.ndarray):
        from scipy.spatial import Delaunay

        self.directions = np.asarray(directions, np.float64)
        self.points = disk_coordinates(self.directions)
        self.triangulation = Delaunay(self.points)

    def __call__(self, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(indices (..., 3) int32, weights (..., 3) float64) of directions (..., 3); a direction below
        the horizon is taken at the horizon, one outside the sampled cone at the nearest point of the
        sampled region."""
        d = np.asarray(directions, np.float64)
        d = np.concatenate([d[..., :2], np.maximum(d[..., 2:3], 0.0)], axis=-1)
        return self.at_points(disk_coordinates(d))

    def at_points(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        shape = xy.shape[:-1]
        p = np.asarray(xy, np.float64).reshape(-1, 2).copy()
        tri = self.triangulation
        simplex = tri.find_simplex(p)
        scale = 1.0
        while np.any(simplex < 0):  # outside the hull: pull radially inward until inside
            out = simplex < 0
            scale *= 0.995
            rmax = np.max(np.linalg.norm(self.points, axis=1))
            r = np.linalg.norm(p[out], axis=1, keepdims=True)
            p[out] = p[out] / np.maximum(r, 1e-12) * np.minimum(r, rmax * scale)
            simplex[out] = tri.find_simplex(p[out])
        T = tri.transform[simplex]  # (N, 3, 2): affine map to barycentrics
        b = np.einsum("nij,nj->ni", T[:, :2], p - T[:, 2])
        weights = np.concatenate([b, 1.0 - b.sum(axis=1, keepdims=True)], axis=1)
        weights = np.clip(weights, 0.0, None)
        weights /= weights.sum(axis=1, keepdims=True)
        indices = tri.simplices[simplex].astype(np.int32)
        return indices.reshape(*shape, 3), weights.reshape(*shape, 3)


def direction_table(directions: np.ndarray, res: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """Interpolation table over the disk map's square [-1, 1]^2, cell centres: (indices (res, res, 3)
    float32 holding exact integers, weights (res, res, 3) float32), row = y, column = x. The GPU reads
    the cell of a direction (nearest); the table error is that of moving the direction by half a cell
    (0.18 degrees at 256)."""
    c = (np.arange(res) + 0.5) / res * 2.0 - 1.0
    xy = np.stack(np.meshgrid(c, c, indexing="xy"), axis=-1)
    indices, weights = DirectionInterpolator(directions).at_points(xy)
    return indices.astype(np.float32), weights.astype(np.float32)

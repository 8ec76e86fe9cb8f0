"""Light entering at an angle starts its diffusion one mean free path along the refracted beam. Pure.

Jensen 2001 puts the dipole's real source one mean free path ell = 1 / sigma_t' below the point where light
enters, straight down: right for light arriving along the normal. A beam arriving at an angle travels along
its refracted direction before it scatters, so its source lies ell along that direction: displaced sideways by
s = ell v, with v the refracted beam's component in the tangent plane,

    v = -(l - (l . n) n) / eta        (|v| = sin theta_t; l the unit direction to the light),

towards where the light is going. On a flat face under one light every source moves alike and nothing
changes; on a curved face the light drifts towards and past the terminator. Measured by Monte Carlo of a
back-lit marble cylinder (index-matched, isotropic scattering at the reduced coefficients, radius 3-10 mm):
the half-space profile with sources at the entry points leaves the lit face up to 13 % too bright at its centre
and the band before the terminator 30-45 % too dark (relative RMS over the lit half 0.11-0.17); shifted by ell
(no fitted constant), 0.040-0.048 (tests/test_oblique_entry.py).

The methods that gather light at the receiver (IMAGE_SPACE's near field, its light-view samples) take the same
model from the entry side: the power that becomes a source at x entered upstream, at x - s, with the cosine
there and the area ratio of the shift, the Jacobian

    J = 1 - div_S s = 1 - ell (l . n) div_S n / eta       (div_S n: the surface's curvature, 2 / R on a ball)

(div_S l = 0 for a sun; the light's own spread, ell / distance, is left out). Its integral over a closed surface
is the unshifted one to first order in ell: no light is made or lost. Only points that are lit themselves take
it (the light that drifts past the terminator is left out: measured, it costs 0.02-0.04 of the RMS above).
Per channel, ell differs (marble: 0.46 / 0.38 / 0.33 mm).

The surface's normal field is the mesh's interpolated normal. Its gradient on one triangle (``normal_gradient``)
jumps from triangle to triangle on a smooth-shaded mesh, and a mean free path of a millimetre (skin) turns the
jumps into blotches (front-lit skin in IMAGE_SPACE: block error 0.035 to 0.135); the methods take the
corners' mean, interpolated (``corner_shape_operators``).
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

# The shift is a first-order account, trusted while ell is small against the radius of curvature: over ell the
# normal turns by at most TURN_MAX (radians, a radius of 1 / TURN_MAX ell), and ell div_S n is at most twice that.
# A low-poly mesh's interpolated normals turn much faster at its ridges (the cow's by 1.2 / mm in one triangle
# of a hundred, 0.5 over marble's ell) than the surface they stand for.
TURN_MAX = 0.15


def mean_free_path(sigma_a: ArrayLike, sigma_s_prime: ArrayLike) -> np.ndarray:
    """ell = 1 / sigma_t' per channel (mm for coefficients per mm): how far the entering beam goes before it
    scatters, on average (Jensen 2001's z_r)."""
    return 1.0 / (np.asarray(sigma_a, np.float64) + np.asarray(sigma_s_prime, np.float64))


def shift_length(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, profile: str, layered: bool = False) -> np.ndarray:
    """ell (3,) of a medium as the methods take it: the EXACT profile's; 0 (no shift) for the papers' dipole
    (DIPOLE keeps their model) and for a layer over a base (its profile is the multipole's)."""
    if profile != "EXACT" or layered:
        return np.zeros(3)
    return mean_free_path(sigma_a, sigma_s_prime)


def medium_shift_mm(medium: Any) -> np.ndarray:
    """``shift_length`` of a medium description (sigma_a, sigma_s_prime, profile, layer_thickness_mm)."""
    return shift_length(medium.sigma_a, medium.sigma_s_prime, medium.profile, medium.layer_thickness_mm is not None)


def beam_tangent(to_light: ArrayLike, normals: ArrayLike, eta: float) -> np.ndarray:
    """v (..., 3): the refracted beam's part in the tangent plane, per unit of ell (module docstring)."""
    l = np.asarray(to_light, np.float64)
    n = np.asarray(normals, np.float64)
    return -(l - np.sum(l * n, axis=-1, keepdims=True) * n) / eta


def normal_gradient(positions: ArrayLike, normals: ArrayLike) -> np.ndarray:
    """(T, 3, 3) per triangle: the linear map J with dN = J dP of its interpolated (unnormalised) normal, for
    dP in the triangle's plane (zero along its normal). positions, normals: (T, 3 corners, 3)."""
    P = np.asarray(positions, np.float64)
    N = np.asarray(normals, np.float64)
    E = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=1)  # (T, 2, 3)
    F = np.stack([N[:, 1] - N[:, 0], N[:, 2] - N[:, 0]], axis=1)
    G = np.einsum("tid,tjd->tij", E, E)
    det = G[:, 0, 0] * G[:, 1, 1] - G[:, 0, 1] ** 2
    ok = det > 1e-30 * np.maximum(G[:, 0, 0] * G[:, 1, 1], 1e-300)
    G_inv = np.zeros_like(G)
    G_inv[ok] = np.linalg.inv(G[ok])
    # dN = F^T G^-1 E dP: the edge coordinates of dP, then the normal's change along them.
    return np.einsum("tid,tij,tje->tde", F, G_inv, E)


def corner_shape_operators(positions: ArrayLike, normals: ArrayLike) -> np.ndarray:
    """(T, 3, 3, 3): the shape operator S (dN = S dP, symmetric, in the corner normal's tangent plane) at each
    triangle corner, the area-weighted mean of ``normal_gradient`` over the triangles that share the corner's
    position and normal (a hard edge keeps its sides apart). A triangle's own gradient jumps from one triangle
    to the next on a smooth-shaded mesh; the corners' mean, interpolated across a triangle, does not.
    positions, normals: (T, 3 corners, 3)."""
    P = np.asarray(positions, np.float64)
    N = np.asarray(normals, np.float64)
    T = len(P)
    J = normal_gradient(P, N)
    S_t = 0.5 * (J + np.swapaxes(J, 1, 2))
    area = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    corner = _corner_groups(P.reshape(-1, 3), N.reshape(-1, 3))
    weight = np.repeat(area, 3)
    total = np.bincount(corner, weight)
    per_corner = np.repeat(S_t.reshape(T, 9) * area[:, None], 3, axis=0)  # (3T, 9), area-weighted
    summed = np.bincount((corner[:, None] * 9 + np.arange(9)).ravel(), per_corner.ravel(),
                         minlength=9 * len(total)).reshape(-1, 9)
    S = (summed / np.maximum(total, 1e-300)[:, None])[corner].reshape(3 * T, 3, 3)
    # In the corner normal's tangent plane: (I - n n) S (I - n n), S symmetric.
    n = N.reshape(-1, 3)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    Sn = np.einsum("cij,cj->ci", S, n)
    nSn = np.einsum("ci,ci->c", Sn, n)
    nn = n[:, :, None] * n[:, None, :]
    S -= n[:, :, None] * Sn[:, None, :] + Sn[:, :, None] * n[:, None, :] - nSn[:, None, None] * nn
    return S.reshape(T, 3, 3, 3)


def packed_shape(S: ArrayLike) -> np.ndarray:
    """(N, 6) float32: symmetric shape operators (N, 3, 3) as the shaders take them, the diagonal then the (xy, xz,
    yz) entries (``curv_d``, ``curv_o``; ``shape_operator`` in common/oblique_entry.glsl unpacks them)."""
    S = np.asarray(S, np.float64)
    return np.concatenate([S[:, [0, 1, 2], [0, 1, 2]], S[:, [0, 0, 1], [1, 2, 2]]], axis=1).astype(np.float32)


def unpacked_shape(packed: ArrayLike) -> np.ndarray:
    """(N, 3, 3) float64 from ``packed_shape``'s (N, 6)."""
    packed = np.asarray(packed, np.float64)
    S = np.zeros((len(packed), 3, 3))
    S[:, [0, 1, 2], [0, 1, 2]] = packed[:, :3]
    S[:, [0, 0, 1], [1, 2, 2]] = S[:, [1, 2, 2], [0, 0, 1]] = packed[:, 3:]
    return S


def _corner_groups(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(3T,) int: one index per distinct (position, normal) of the corners, from a 64-bit key of both quantised
    (positions to 2^-20 of the mesh's extent, normals to 2^-8): one 1-D sort instead of a row sort."""
    low = points.min(axis=0)
    scale = max(float(np.ptp(points, axis=0).max()), 1e-30)
    # floor after an offset: a symmetric mesh's coordinates (0 and 1e-16 about the centre) fall mid-cell
    q = np.floor((points - low) / scale * (2**20 - 2) + 0.318).astype(np.int64)
    m = np.floor((normals + 1.0) * 127.0 + 0.318).astype(np.int64)
    key = (q[:, 0] << 40) | (q[:, 1] << 20) | q[:, 2]
    key = key * 1_000_003 + ((m[:, 0] << 16) | (m[:, 1] << 8) | m[:, 2])  # wraps: a hash, collisions ~1e-12
    return np.unique(key, return_inverse=True)[1].ravel()


def entering_cosine(to_light: ArrayLike, normals: ArrayLike, gradient: ArrayLike, ell: ArrayLike,
                    eta: float) -> np.ndarray:
    """(N, 3): what replaces the cosine cos_i in the irradiance entering at each point, per channel: the cosine
    at the upstream point x - ell v times the Jacobian J (module docstring); 0 where the point is not lit itself.
    to_light, normals: (N, 3) unit; gradient: (N, 3, 3) the normal field's dN = gradient dP at each point
    (``corner_shape_operators`` interpolated, or a triangle's ``normal_gradient``); ell (3,) in the positions'
    units."""
    l = np.asarray(to_light, np.float64)
    n = np.asarray(normals, np.float64)
    J_n = np.asarray(gradient, np.float64)
    ell = np.asarray(ell, np.float64)
    cos_i = np.sum(l * n, axis=-1)
    v = beam_tangent(l, n, eta)
    dn_v = np.einsum("nde,ne->nd", J_n, v)  # the normal's change along v
    div_n = np.trace(J_n, axis1=1, axis2=2)
    turn = ell[None, :] * np.linalg.norm(dn_v, axis=-1)[:, None]  # (N, 3): how far the normal turns over ell
    step = ell[None, :] * np.minimum(1.0, TURN_MAX / np.maximum(turn, 1e-30))
    n_up = n[:, None, :] - step[:, :, None] * dn_v[:, None, :]  # (N, 3 channels, 3)
    n_up /= np.maximum(np.linalg.norm(n_up, axis=-1, keepdims=True), 1e-30)
    cos_up = np.maximum(np.einsum("ncd,nd->nc", n_up, l), 0.0)
    spread = np.clip(ell[None, :] * div_n[:, None], -2.0 * TURN_MAX, 2.0 * TURN_MAX)
    jacobian = 1.0 - spread * cos_i[:, None] / eta
    return np.where((cos_i > 0.0)[:, None], cos_up * jacobian, 0.0)

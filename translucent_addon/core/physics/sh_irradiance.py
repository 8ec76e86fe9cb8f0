"""Transmitted irradiance from an environment in spherical harmonics (Shah 6.4.2, Eq. 6.19-6.21).

    E(n) = int L(w) F_t(eta, n . w) (n . w)^+ dw                            (Shah Eq. 6.19-6.21)

Shah projects L and the kernel F'_t = F_t (n . w) into SH and stores coefficients pre-rotated per
normal in environment maps. The kernel is zonal (it depends on n . w only), so by the Funk-Hecke
theorem the rotation is closed form (Ramamoorthi & Hanrahan 2001):

    E(n) = sum_{l <= 2, m} A_l L_lm Y_lm(n),   A_l = 2 pi int_0^1 F_t(mu) mu P_l(mu) d mu

which needs 9 RGB coefficients and no maps. With F_t = 1, A = (pi, 2 pi / 3, pi / 4); a uniform
world L gives E = pi L (1 - F_dr), the closed form the base pass used. Order 2 keeps the smooth part
of the lighting that irradiance carries (the clamped cosine's higher bands are under 1 %). Pure.
"""
from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike

from .fresnel import fresnel_dielectric

# Real SH normalisation constants, bands 0-2 (Ramamoorthi & Hanrahan 2001, Eq. 3).
_C0 = 0.5 * math.sqrt(1.0 / math.pi)
_C1 = math.sqrt(3.0 / (4.0 * math.pi))
_C2 = 0.5 * math.sqrt(15.0 / math.pi)
_C20 = 0.25 * math.sqrt(5.0 / math.pi)
BAND = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2])  # band l of each of the 9 coefficients
LAMBERT_KERNEL = np.array([math.pi, 2.0 * math.pi / 3.0, math.pi / 4.0])  # A_l of the clamped cosine alone


def sh_basis(d: ArrayLike) -> np.ndarray:
    """Y_lm at unit directions d (..., 3): (..., 9) in the order 00, 1-1, 10, 11, 2-2, 2-1, 20, 21, 22."""
    d = np.asarray(d, np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([np.full_like(x, _C0), _C1 * y, _C1 * z, _C1 * x, _C2 * x * y, _C2 * y * z,
                     _C20 * (3.0 * z * z - 1.0), _C2 * x * z, 0.5 * _C2 * (x * x - y * y)], axis=-1)


def project(directions: ArrayLike, radiance: ArrayLike, solid_angle: ArrayLike) -> np.ndarray:
    """L_lm = sum L(w) Y_lm(w) dw over samples of the sphere: (9, C)."""
    Y = sh_basis(np.asarray(directions).reshape(-1, 3))
    L = np.asarray(radiance, np.float64).reshape(len(Y), -1)
    return Y.T @ (L * np.asarray(solid_angle, np.float64).reshape(-1, 1))


def equirect_directions(height: int, width: int,
                        rows: slice = slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre directions (h, W, 3) and solid angles (h, W) of an equirectangular image in
    Blender's convention (``bake.environment.equirect_direction_to_uv``), row 0 at the bottom; only
    the given rows."""
    u = (np.arange(width) + 0.5) / width
    v = ((np.arange(height) + 0.5) / height)[rows]
    phi = -(u - 0.5) * 2.0 * np.pi  # atan2(y, x)
    lat = (v - 0.5) * np.pi
    cl = np.cos(lat)[:, None]
    d = np.stack([cl * np.cos(phi)[None, :], cl * np.sin(phi)[None, :],
                  np.broadcast_to(np.sin(lat)[:, None], (len(v), width))], axis=-1)
    omega = np.broadcast_to(cl * (2.0 * np.pi / width) * (np.pi / height), (len(v), width))
    return d, omega


def project_equirect(image: ArrayLike, rows_per_block: int = 64) -> np.ndarray:
    """The 9 RGB coefficients (9, 3) of an equirectangular radiance image (H, W, >=3).

    Summed over blocks of rows, so that an 8k HDRI needs tens of MB, not gigabytes."""
    image = np.asarray(image)
    h, w = image.shape[:2]
    step = max(1, int(rows_per_block))
    out = np.zeros((9, 3))
    for start in range(0, h, step):
        rows = slice(start, min(start + step, h))
        d, omega = equirect_directions(h, w, rows)
        out += project(d, image[rows, :, :3], omega)
    return out


def uniform_coefficients(color: ArrayLike) -> np.ndarray:
    """L_lm (9, 3) of a uniform world: only L_00 = L sqrt(4 pi)."""
    out = np.zeros((9, 3))
    out[0] = np.asarray(color, np.float64).ravel()[:3] * math.sqrt(4.0 * math.pi)
    return out


def transmittance_kernel(eta: float) -> np.ndarray:
    """A_l = 2 pi int_0^1 F_t(eta, mu) mu P_l(mu) d mu for l = 0, 1, 2 (Funk-Hecke of Shah's F'_t).

    Cached per IOR to 1e-6 (float32 properties round-trip with noise below that)."""
    return _transmittance_kernel(round(float(eta), 6))


@functools.lru_cache(maxsize=64)
def _transmittance_kernel(eta: float, samples: int = 4096) -> np.ndarray:
    mu = (np.arange(samples) + 0.5) / samples  # midpoint rule, error ~1e-8
    k = (1.0 - fresnel_dielectric(mu, float(eta))) * mu
    P = np.stack([np.ones_like(mu), mu, 0.5 * (3.0 * mu * mu - 1.0)])
    return 2.0 * np.pi * (P * k).mean(axis=1)


def irradiance(coefficients: ArrayLike, kernel: ArrayLike, normals: ArrayLike) -> np.ndarray:
    """E(n) (..., C) = sum A_l L_lm Y_lm(n): transmitted irradiance at unit normals (..., 3)."""
    coefficients = np.asarray(coefficients, np.float64)
    weighted = coefficients * np.asarray(kernel, np.float64)[BAND][:, None]
    return sh_basis(normals) @ weighted

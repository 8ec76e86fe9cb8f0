"""Lookup tables of diffuse reflectance profiles for the GPU (Shah 6.4: "compute dipole LUT").

The profile is tabulated over [0, r_max] with r = r_max u^2 (u uniform in [0, 1]), which puts
samples where R_d is steep; a shader maps r to u = sqrt(r / r_max) and filters linearly.
"""
from __future__ import annotations

import dataclasses
import functools
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike

from . import dipole, exact_profile
from .multipole import Grid, Layer, layered_profiles, radial_profile
from .quadrature import trapezoid

# The radial profiles a homogeneous medium can take: each module has R_d, R_d_disk, r_max and
# total_diffuse_reflectance with the same arguments and units. EXACT (half-space Monte Carlo) is the default;
# DIPOLE is the papers' (Jensen 2001), kept for comparison.
PROFILES = {"EXACT": exact_profile, "DIPOLE": dipole}


def profile_model(kind: str = "EXACT") -> ModuleType:
    """The module of profile ``kind`` (``PROFILES``); ValueError for an unknown one."""
    try:
        return PROFILES[kind]
    except KeyError:
        raise ValueError(f"unknown profile {kind!r}: one of {', '.join(PROFILES)}") from None


@dataclasses.dataclass(frozen=True)
class ProfileLUT:
    table: np.ndarray  # (N, 3) float32, R_d in mm^-2 per RGB channel
    r_max: np.ndarray  # (3,) mm, per channel

    def lookup(self, r: ArrayLike) -> np.ndarray:
        """CPU twin of the shader lookup: (..., 3) for distances r [mm] (..., )."""
        r = np.asarray(r, dtype=np.float64)[..., None]
        u = np.sqrt(np.clip(r / self.r_max, 0.0, 1.0)) * (len(self.table) - 1)
        i0 = np.floor(u).astype(int)
        i1 = np.minimum(i0 + 1, len(self.table) - 1)
        f = u - i0
        ch = np.arange(3)
        value = (1 - f) * self.table[i0, ch] + f * self.table[i1, ch]
        return np.where(r <= self.r_max, value, 0.0)


def dipole_lut(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike, samples: int = 256,
               epsilon: float = 0.01, profile: str = "DIPOLE") -> ProfileLUT:
    model = profile_model(profile)
    radius = np.asarray(model.r_max(np.asarray(sigma_a, float), np.asarray(sigma_s_prime, float), eta, epsilon))
    u = np.linspace(0.0, 1.0, samples)[:, None]
    r = radius[None, :] * u**2
    table = model.R_d(r, np.asarray(sigma_a, float), np.asarray(sigma_s_prime, float), eta)
    return ProfileLUT(table.astype(np.float32), radius)


# -- IMAGE_SPACE: the profile split into a near field and a splatted far field ----------------
BLUR_MIN = 0.25  # smallest distance multiplier M_d (4x the spread), Shah Eq. 7.4


# The splats stop at r_max, beyond which epsilon of the flat profile's energy lies (Shah Eq. 6.16); light
# through a back-lit object arrives from farther than on a plane, and the cut left red 4 % dark on the cow.
# So the profile goes on to TAIL_REACH r_max in a second set of splats from 4x4 blocks of light-view samples
# (16 times fewer; smooth at that spacing), the two sets crossing over smoothly from TAIL_START r_max to r_max.
TAIL_REACH = 2.0
TAIL_START = 0.5
TAIL_BLOCK = 4


def crossover(s: ArrayLike, r_max: float | np.ndarray) -> np.ndarray | float:
    """t(s): the tail splats' share of R_d at scaled distance s [mm]; 0 below TAIL_START r_max, 1 from r_max."""
    x = np.clip((np.asarray(s, dtype=np.float64) / r_max - TAIL_START) / (1.0 - TAIL_START), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def partition(r: ArrayLike, rho: float | np.ndarray) -> np.ndarray | float:
    """w(r): 0 for r <= rho, 1 for r >= 2 rho, smoothstep between (the splatted share of R_d)."""
    x = np.clip((np.asarray(r, dtype=np.float64) - rho) / rho, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def partition_off_plane(r: ArrayLike, rho: float | np.ndarray, h: ArrayLike) -> np.ndarray | float:
    """w(r) for a sample at height h over x_o's tangent plane: samples well off the plane (h > 0.8 r,
    e.g. the far side of a thin part) are not in the near field's disk and keep their whole share;
    in the plane (h < 0.5 r) the usual w(r); smoothstep between."""
    r = np.asarray(r, dtype=np.float64)
    x = np.clip((np.asarray(h, dtype=np.float64) / np.maximum(r, 1e-12) - 0.5) / 0.3, 0.0, 1.0)
    s = 1.0 - x * x * (3.0 - 2.0 * x)
    return 1.0 - (1.0 - partition(r, rho)) * s


@dataclasses.dataclass(frozen=True)
class ImageSpaceTables:
    """What the IMAGE_SPACE shaders need of one material.

    The splat at x_i adds R_d(M r) M^2 w(r) Phi_i to x_o at distance r (far field); the lighting
    pass adds E(x_o) * near(M) with near(M) = int R_d(M r) M^2 (1 - w(r)) 2 pi r dr (near field).
    M is the painted distance multiplier (Shah Eq. 7.4), here with the factor M^2 that keeps the
    integral of the profile, so that blur spreads light without brightening it.
    """

    far: np.ndarray  # (N, 3) R_d(s) at s = r_max u^2, u in [0, 1]
    tail: np.ndarray  # (N, 3) R_d(s) at s = TAIL_REACH r_max u^2, u in [0, 1]
    near: np.ndarray  # (K, 3) near(M) at M = linspace(BLUR_MIN, 1, K)
    r_max: float  # mm, the splat radius at M = 1 (largest channel)
    rho: float  # mm, the partition radius
    total: np.ndarray  # (3,) total diffuse reflectance


def near_integral(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike, rho_mm: float,
                  M: float = 1.0, profile: str = "DIPOLE") -> np.ndarray:
    """near(M) = int R_d(M r) M^2 (1 - w(r)) 2 pi r dr: the part of the profile taken at E(x_o).

    Up to rho it is the closed-form disk integral R_d_disk(M rho) (substitute s = M r); the blend
    ring [rho, 2 rho] by quadrature.
    """

    model = profile_model(profile)
    ring = np.linspace(rho_mm, 2 * rho_mm, 2049)[:, None]
    f = model.R_d(M * ring, sigma_a, sigma_s_prime, eta) * M * M * (1.0 - partition(ring, rho_mm)) * 2 * np.pi * ring
    return model.R_d_disk(M * rho_mm, sigma_a, sigma_s_prime, eta) + trapezoid(f, ring, axis=0)


def image_space_tables(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike, rho_mm: float,
                       epsilon: float = 0.01, samples: int = 256, near_samples: int = 32,
                       profile: str = "DIPOLE") -> ImageSpaceTables:
    """The tables of a homogeneous medium with the radial profile ``profile`` (``PROFILES``)."""
    model = profile_model(profile)
    sa = np.asarray(sigma_a, dtype=np.float64)
    ss = np.asarray(sigma_s_prime, dtype=np.float64)
    radius = float(np.max(model.r_max(sa, ss, eta, epsilon)))
    u = np.linspace(0.0, 1.0, samples)[:, None]
    far = model.R_d(radius * u**2, sa, ss, eta)
    tail = model.R_d(TAIL_REACH * radius * u**2, sa, ss, eta)
    near = np.stack([near_integral(sa, ss, eta, rho_mm, M, profile)
                     for M in np.linspace(BLUR_MIN, 1.0, near_samples)])
    return ImageSpaceTables(far.astype(np.float32), tail.astype(np.float32), near.astype(np.float32), radius,
                            float(rho_mm), model.total_diffuse_reflectance(sa, ss, eta))


def profile_tables(radii: ArrayLike, profile: ArrayLike, rho_mm: float, epsilon: float = 0.01, samples: int = 256,
                   near_samples: int = 32) -> ImageSpaceTables:
    """ImageSpaceTables from any radial profile R(r) [mm^-2] tabulated at radii [mm] (RGB), e.g. a multipole.

    r_max from the cumulative integral of R 2 pi r dr (Eq. 6.16); the near field by quadrature.
    """
    radii = np.asarray(radii, dtype=np.float64)
    profile = np.asarray(profile, dtype=np.float64)
    ring = 2 * np.pi * radii[:, None] * profile
    cumulative = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (ring[1:] + ring[:-1]) * np.diff(radii)[:, None],
                                                              axis=0)])
    total = cumulative[-1]
    radius = float(max(np.interp((1 - epsilon) * t, c, radii) for t, c in zip(total, cumulative.T)))

    def R(r: ArrayLike) -> np.ndarray:
        return np.stack([np.interp(r, radii, profile[:, c], right=0.0) for c in range(3)], axis=-1)

    u = np.linspace(0.0, 1.0, samples)
    far = R(radius * u**2)
    near = np.empty((near_samples, 3))
    r = np.linspace(0.0, 2 * rho_mm, 4097)
    for k, M in enumerate(np.linspace(BLUR_MIN, 1.0, near_samples)):
        f = R(M * r) * (M * M * (1.0 - partition(r, rho_mm)) * 2 * np.pi * r)[:, None]
        near[k] = trapezoid(f, r, axis=0)
    tail = R(TAIL_REACH * radius * u**2)
    return ImageSpaceTables(far.astype(np.float32), tail.astype(np.float32), near.astype(np.float32), radius,
                            float(rho_mm), total)


def layer_problem(top_sigma_a: tuple, top_sigma_s_prime: tuple, thickness_mm: float) -> str | None:
    """Why the multipole cannot model this layer (thinner than its source depth z_r = 1 / sigma_t' in some
    channel: the first source lies outside it), or None."""
    z_r = max(1.0 / (a + s) for a, s in zip(top_sigma_a, top_sigma_s_prime))
    if thickness_mm < z_r:
        return (f"layer thickness {thickness_mm:g} mm is thinner than the layer's mean free path {z_r:.3g} mm: "
                "the multipole needs at least one")
    return None


@functools.lru_cache(maxsize=16)
def multipole_profile(top_sigma_a: tuple, top_sigma_s_prime: tuple, thickness_mm: float, base_sigma_a: tuple,
                      base_sigma_s_prime: tuple, eta: float, extent_mm: float = 60.0,
                      h_mm: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Radial reflectance profile (radii, R (N, 3)) of a layer over a semi-infinite base (Donner & Jensen 2005).

    Per channel, by Fourier-domain adding on a grid of h_mm cells spanning +-extent_mm (cached).
    The layer must be at least as thick as its source depth z_r = 1 / sigma_t' (in every channel):
    thinner, the multipole's first source lies outside the layer and the model breaks down.
    """

    problem = layer_problem(top_sigma_a, top_sigma_s_prime, thickness_mm)
    if problem:
        raise ValueError(problem)

    n = int(2 * extent_mm / h_mm) // 2 * 2
    grid = Grid(n=n, h=h_mm)
    radii = np.arange(0.0, extent_mm, h_mm)
    R = np.empty((len(radii), 3))
    for c in range(3):
        layers = [Layer(top_sigma_a[c], top_sigma_s_prime[c], thickness_mm),
                  Layer(base_sigma_a[c], base_sigma_s_prime[c], np.inf)]
        image, _ = layered_profiles(layers, eta, grid)
        R[:, c] = np.maximum(radial_profile(image, grid, radii), 0.0)
    return radii, R

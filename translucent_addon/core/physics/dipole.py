"""The dipole diffusion approximation (Jensen et al. 2001), as in Lensch Fig. 2 and Shah Eq. 6.5-6.12.

Units: coefficients in mm^-1, distances in mm, R_d(r) in mm^-2. Arrays broadcast, so RGB
coefficients of shape (3,) against distances of shape (N, 1) give (N, 3).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .fresnel import F_dr


def A(eta: ArrayLike) -> np.ndarray | float:
    """Internal reflection parameter A = (1 + F_dr) / (1 - F_dr) (Shah Eq. 6.11)."""
    f = F_dr(eta)
    return (1.0 + f) / (1.0 - f)


def dipole_parameters(
    sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike
) -> tuple[np.ndarray | float, np.ndarray | float, np.ndarray | float, np.ndarray | float]:
    """(alpha', sigma_tr, z_r, z_v) of the dipole (Shah Eq. 6.6-6.10).

    sigma_t' = sigma_a + sigma_s', alpha' = sigma_s' / sigma_t', sigma_tr = sqrt(3 sigma_a sigma_t'),
    D = 1 / (3 sigma_t'), z_r = 1 / sigma_t', z_v = z_r + 4 A D.
    """
    sigma_a = np.asarray(sigma_a, dtype=np.float64)
    sigma_s_prime = np.asarray(sigma_s_prime, dtype=np.float64)
    sigma_t_prime = sigma_a + sigma_s_prime
    alpha_prime = sigma_s_prime / sigma_t_prime
    sigma_tr = np.sqrt(3.0 * sigma_a * sigma_t_prime)
    D = 1.0 / (3.0 * sigma_t_prime)
    z_r = 1.0 / sigma_t_prime
    z_v = z_r + 4.0 * A(eta) * D
    return alpha_prime, sigma_tr, z_r, z_v


def R_d(r: ArrayLike, sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike) -> np.ndarray | float:
    """Diffuse reflectance profile R_d(r) [mm^-2] at distance r [mm] (Jensen 2001 Eq. 5; Shah Eq. 6.5).

    R_d(r) = alpha'/(4 pi) [ z_r (sigma_tr d_r + 1) e^{-sigma_tr d_r} / d_r^3
                           + z_v (sigma_tr d_v + 1) e^{-sigma_tr d_v} / d_v^3 ],
    d_r = sqrt(r^2 + z_r^2), d_v = sqrt(r^2 + z_v^2).
    """
    alpha_prime, sigma_tr, z_r, z_v = dipole_parameters(sigma_a, sigma_s_prime, eta)
    r = np.asarray(r, dtype=np.float64)
    d_r = np.sqrt(r**2 + z_r**2)
    d_v = np.sqrt(r**2 + z_v**2)
    real = z_r * (sigma_tr * d_r + 1.0) * np.exp(-sigma_tr * d_r) / d_r**3
    virtual = z_v * (sigma_tr * d_v + 1.0) * np.exp(-sigma_tr * d_v) / d_v**3
    return alpha_prime / (4.0 * np.pi) * (real + virtual)


def total_diffuse_reflectance(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike) -> np.ndarray | float:
    """Closed form of the integral of R_d over the plane (Jensen 2001 Eq. 6):

    R_d = (alpha'/2) (1 + e^{-(4/3) A sqrt(3 (1 - alpha'))}) e^{-sqrt(3 (1 - alpha'))}.
    """
    alpha_prime, _, _, _ = dipole_parameters(sigma_a, sigma_s_prime, eta)
    s = np.sqrt(3.0 * (1.0 - alpha_prime))
    return 0.5 * alpha_prime * (1.0 + np.exp(-4.0 / 3.0 * A(eta) * s)) * np.exp(-s)


def R_d_disk(radius: ArrayLike, sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike) -> np.ndarray | float:
    """Integral of R_d over a disk of the given radius [mm] (closed form).

    With d^2 = r^2 + z^2 and r dr = d dd, and d/dd[-e^{-s d}/d] = (s d + 1) e^{-s d}/d^2:
    int_0^R z (s d + 1) e^{-s d}/d^3 2 pi r dr = 2 pi (e^{-s z} - z e^{-s D}/D), D = sqrt(R^2 + z^2).
    As R -> inf this is the total diffuse reflectance of Jensen 2001 Eq. 6.
    """
    alpha_prime, sigma_tr, z_r, z_v = dipole_parameters(sigma_a, sigma_s_prime, eta)
    radius = np.asarray(radius, dtype=np.float64)
    total = 0.0
    for z in (z_r, z_v):
        D = np.sqrt(radius**2 + z**2)
        total = total + np.exp(-sigma_tr * z) - z * np.exp(-sigma_tr * D) / D
    return 0.5 * alpha_prime * total


def r_max(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike,
          epsilon: float = 0.01) -> np.ndarray | float:
    """Splat radius r_max [mm]: the disk holding all but epsilon of R_d's integral (Shah Eq. 6.16).

    Solved by bisection on the closed-form disk integral; per channel for RGB input.
    """
    sa, ss = np.broadcast_arrays(np.asarray(sigma_a, float), np.asarray(sigma_s_prime, float))
    total = total_diffuse_reflectance(sa, ss, eta)
    lo = np.zeros(sa.shape)
    hi = np.full(sa.shape, 1.0)
    # Grow the bracket until the disk holds enough (the profile tail is exponential, or 1/r for sigma_a = 0).
    for _ in range(200):
        short = R_d_disk(hi, sa, ss, eta) < (1.0 - epsilon) * total
        if not short.any():
            break
        hi = np.where(short, hi * 2.0, hi)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        short = R_d_disk(mid, sa, ss, eta) < (1.0 - epsilon) * total
        lo, hi = np.where(short, mid, lo), np.where(short, hi, mid)
    return hi if hi.shape else float(hi)


def overlap_count(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike, epsilon: float = 0.01,
                  radius: ArrayLike | None = None) -> np.ndarray | float:
    """Overlapping splats n_o per point, the smallest with R_d(0) / (n_o R_d(r_max)) < epsilon (Shah Eq. 6.17)."""
    if radius is None:
        radius = r_max(sigma_a, sigma_s_prime, eta, epsilon)
    ratio = R_d(0.0, sigma_a, sigma_s_prime, eta) / R_d(radius, sigma_a, sigma_s_prime, eta)
    return np.floor(ratio / epsilon) + 1.0


def splat_grid(frustum_width: float, sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike,
               epsilon: float = 0.01) -> np.ndarray | float:
    """Splat grid resolution n (n x n splats) for a light frustum W mm wide (Shah Eq. 6.18): n = n_o W / (2 r_max)."""
    radius = r_max(sigma_a, sigma_s_prime, eta, epsilon)
    n_o = overlap_count(sigma_a, sigma_s_prime, eta, epsilon, radius)
    return np.ceil(0.5 * n_o * frustum_width / radius)


def angular_table(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, n: int = 16) -> np.ndarray:
    """The angular weights of the papers' model, (n, 3) ones: Jensen 2001 Eq. 4 sends R_d out Lambertian under
    light from any angle (``angular_law`` is the exact profile's; n is its SAMPLES)."""
    return np.ones((n, 3))


def through_exit_table(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, n: int = 16) -> np.ndarray:
    """How the light that crossed a thin part leaves, (n, 3) ones: the papers' model sends all of it out
    Lambertian (``angular_law.through_exit_table`` is the exact profile's)."""
    return np.ones((n, 3))

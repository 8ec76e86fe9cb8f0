"""The dipole diffusion approximation (Jensen et al. 2001), as in Lensch Fig. 2 and Shah Eq. 6.5-6.12.

Units: coefficients in mm^-1, distances in mm, R_d(r) in mm^-2. Arrays broadcast, so RGB
coefficients of shape (3,) against distances of shape (N, 1) give (N, 3).
"""
from __future__ import annotations

import numpy as np

from .fresnel import F_dr


def A(eta):
    """Internal reflection parameter A = (1 + F_dr) / (1 - F_dr) (Shah Eq. 6.11)."""
    f = F_dr(eta)
    return (1.0 + f) / (1.0 - f)


def dipole_parameters(sigma_a, sigma_s_prime, eta):
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


def R_d(r, sigma_a, sigma_s_prime, eta):
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


def total_diffuse_reflectance(sigma_a, sigma_s_prime, eta):
    """Closed form of the integral of R_d over the plane (Jensen 2001 Eq. 6):

    R_d = (alpha'/2) (1 + e^{-(4/3) A sqrt(3 (1 - alpha'))}) e^{-sqrt(3 (1 - alpha'))}.
    """
    alpha_prime, _, _, _ = dipole_parameters(sigma_a, sigma_s_prime, eta)
    s = np.sqrt(3.0 * (1.0 - alpha_prime))
    return 0.5 * alpha_prime * (1.0 + np.exp(-4.0 / 3.0 * A(eta) * s)) * np.exp(-s)

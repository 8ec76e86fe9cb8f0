"""Single scattering under the boundary: the term a diffusion solution leaves out. Pure NumPy.

Wang et al. 2010 (Sec. 7) model multiple scattering only and name low-order scattering as what is
missing; Jensen et al. 2001 add it as the single-scattering term L^(1) beside the dipole. Along the
refracted view ray x(t) = x_o + t w_t inside the medium, light of normal irradiance E that has crossed a
path d(t) of the medium reaches x(t) and scatters once towards the eye:

    L^(1)(x_o, w_o) = T_o T_i  integral_0^inf  sigma_s p(cos theta) E exp(-sigma_t (t + d(t))) dt

with sigma_s = sigma_s' / (1 - g), sigma_t = sigma_a + sigma_s, p the Henyey-Greenstein phase function
and T_o, T_i the Fresnel transmittances out of and into the medium. The GPU pass (``qg_single.glsl``)
reads d(t) from the light's distance map at the nodes ``march_nodes`` and integrates segment by segment
with the exponent linear inside each segment (``march``): exact wherever d is linear in t, as under a
flat face lit by a distant light, for which (eta = 1)

    L^(1) / E = alpha p(cos theta) mu_i / (mu_i + mu_o)        (``half_space``).
"""
from __future__ import annotations

import numpy as np

TAU_MAX = 8.0  # optical depth the march covers along the view ray (exp(-8) = 3e-4 left out)
SEGMENTS = 16  # march segments; nodes crowd the surface (t_k = t_max (k / N)^2)


def hg_phase(cos_theta, g: float):
    """Henyey-Greenstein phase function, normalised over the sphere (1 / (4 pi) for g = 0)."""
    cos_theta = np.asarray(cos_theta, np.float64)
    return (1.0 - g * g) / (4.0 * np.pi * np.power(1.0 + g * g - 2.0 * g * cos_theta, 1.5))


def coefficients(sigma_a, sigma_s_prime, g: float):
    """(sigma_s, sigma_t) per channel from the reduced coefficients (sigma_s = sigma_s' / (1 - g))."""
    sigma_s = np.asarray(sigma_s_prime, np.float64) / (1.0 - g)
    return sigma_s, np.asarray(sigma_a, np.float64) + sigma_s


def march_nodes(sigma_t, segments: int = SEGMENTS, tau_max: float = TAU_MAX) -> np.ndarray:
    """Depths t_k along the view ray (same units as 1 / sigma_t): TAU_MAX optical depths of the most
    transparent channel, quadratically spaced so that the first segments resolve the surface."""
    t_max = tau_max / float(np.min(sigma_t))
    return t_max * (np.arange(segments + 1) / segments) ** 2


def march(t, d, sigma_t, source) -> np.ndarray:
    """integral of source(t) exp(-sigma_t (t + d(t))) dt from nodes: per segment, the exponent is linear
    between its ends (integrated exactly) and the source (sigma_s p E, slowly varying) is their mean.
    t, d: (n,); sigma_t: (c,); source: (n, c) or (c,). Returns (c,)."""
    t = np.asarray(t, np.float64)
    a = -np.asarray(sigma_t, np.float64)[None, :] * (t + np.asarray(d, np.float64))[:, None]
    s = np.broadcast_to(np.asarray(source, np.float64), a.shape)
    dt = np.diff(t)[:, None]
    a0, a1 = a[:-1], a[1:]
    da = a1 - a0
    small = np.abs(da) < 1e-6
    seg = np.where(small, dt * np.exp(0.5 * (a0 + a1)),
                   dt * (np.exp(a1) - np.exp(a0)) / np.where(small, 1.0, da))
    return (0.5 * (s[:-1] + s[1:]) * seg).sum(axis=0)


def half_space(sigma_a, sigma_s_prime, g: float, mu_i: float, mu_o: float, cos_theta: float,
               thickness: float = np.inf) -> np.ndarray:
    """Closed form of L^(1) / E under a flat face at eta = 1, light at cosine mu_i and eye at mu_o
    (d(t) = t mu_o / mu_i): alpha p(cos theta) mu_i / (mu_i + mu_o), times
    1 - exp(-sigma_t H (1 / mu_o + 1 / mu_i)) for a slab of thickness H (the view ray leaves at H / mu_o)."""
    sigma_s, sigma_t = coefficients(sigma_a, sigma_s_prime, g)
    kept = -np.expm1(-sigma_t * thickness * (1.0 / mu_o + 1.0 / mu_i)) if np.isfinite(thickness) else 1.0
    return sigma_s / sigma_t * hg_phase(cos_theta, g) * mu_i / (mu_i + mu_o) * kept

"""Fresnel reflectance at a smooth dielectric boundary."""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def fresnel_dielectric(cos_i: ArrayLike, eta: float | np.ndarray) -> np.ndarray:
    """Unpolarised Fresnel reflectance, light arriving from the outside (index 1) onto index eta.

    cos_i: cosine of the incidence angle. eta: relative index n_inside / n_outside; eta < 1
    describes light leaving a denser medium, with total internal reflection (R = 1) past the
    critical angle.
    """
    cos_i = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
    sin2_t = (1.0 - cos_i**2) / eta**2
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.clip(1.0 - sin2_t, 0.0, 1.0))
    r_s = (cos_i - eta * cos_t) / np.maximum(cos_i + eta * cos_t, 1e-300)
    r_p = (eta * cos_i - cos_t) / np.maximum(eta * cos_i + cos_t, 1e-300)
    return np.where(tir, 1.0, 0.5 * (r_s**2 + r_p**2))


def fresnel_schlick(cos_i: ArrayLike, eta: float | np.ndarray) -> np.ndarray | float:
    """Schlick's approximation R0 + (1 - R0)(1 - cos)^5 with R0 = ((eta - 1)/(eta + 1))^2."""
    r0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    return r0 + (1.0 - r0) * (1.0 - np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)) ** 5


def hemispherical_transmittance(eta: float, n: int = 4096) -> float:
    """1 - F_dr for light entering: 2 int_0^1 (1 - F(mu, eta)) mu dmu (uniform diffuse illumination)."""
    mu = (np.arange(n) + 0.5) / n
    return float(2.0 * np.mean((1.0 - fresnel_dielectric(mu, eta)) * mu))


def F_dr(eta: ArrayLike) -> np.ndarray | float:
    """Diffuse Fresnel reflectance, the polynomial fit of Jensen 2001 / Shah Eq. 6.12.

    F_dr = -1.440/eta^2 + 0.710/eta + 0.668 + 0.0636 eta. (Shah prints 0.0668 for the
    last coefficient: a typo; the fit and Jensen 2001 use 0.0636.)
    """
    eta = np.asarray(eta, dtype=np.float64)
    return -1.440 / eta**2 + 0.710 / eta + 0.668 + 0.0636 * eta

"""Refraction and reflection of ray directions, as GLSL's ``refract`` and ``reflect`` (pure, NumPy).

Shared by the caustics technique (``techniques/caustics/model.py``) and the exact glass-sphere reference
(``core/reference/caustic_sphere.py``).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def refract(d: np.ndarray, n: np.ndarray, eta_ratio: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Refracted unit directions (GLSL ``refract``): ``d`` travels toward the surface, ``n`` faces
    against it, ``eta_ratio`` = n_from / n_to. Returns (t, ok); ok is False at total internal
    reflection (t is zero there, as in GLSL)."""
    d = np.asarray(d, np.float64)
    n = np.asarray(n, np.float64)
    eta = np.asarray(eta_ratio, np.float64)
    cos_i = -np.sum(d * n, axis=-1)
    k = 1.0 - eta**2 * (1.0 - cos_i**2)
    ok = k >= 0.0
    scale = eta[..., None] if eta.ndim else eta
    t = scale * d + (eta * cos_i - np.sqrt(np.clip(k, 0.0, None)))[..., None] * n
    return np.where(ok[..., None], t, 0.0), ok


def reflect(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Mirror directions (GLSL ``reflect``)."""
    d = np.asarray(d, np.float64)
    n = np.asarray(n, np.float64)
    return d - 2.0 * np.sum(d * n, axis=-1, keepdims=True) * n

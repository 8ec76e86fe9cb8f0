"""Lookup tables of diffuse reflectance profiles for the GPU (Shah 6.4: "compute dipole LUT").

The profile is tabulated over [0, r_max] with r = r_max u^2 (u uniform in [0, 1]), which puts
samples where R_d is steep; a shader maps r to u = sqrt(r / r_max) and filters linearly.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .dipole import R_d, r_max


@dataclasses.dataclass(frozen=True)
class ProfileLUT:
    table: np.ndarray  # (N, 3) float32, R_d in mm^-2 per RGB channel
    r_max: np.ndarray  # (3,) mm, per channel

    def lookup(self, r) -> np.ndarray:
        """CPU twin of the shader lookup: (..., 3) for distances r [mm] (..., )."""
        r = np.asarray(r, dtype=np.float64)[..., None]
        u = np.sqrt(np.clip(r / self.r_max, 0.0, 1.0)) * (len(self.table) - 1)
        i0 = np.floor(u).astype(int)
        i1 = np.minimum(i0 + 1, len(self.table) - 1)
        f = u - i0
        ch = np.arange(3)
        value = (1 - f) * self.table[i0, ch] + f * self.table[i1, ch]
        return np.where(r <= self.r_max, value, 0.0)


def dipole_lut(sigma_a, sigma_s_prime, eta, samples: int = 256, epsilon: float = 0.01) -> ProfileLUT:
    radius = np.asarray(r_max(np.asarray(sigma_a, float), np.asarray(sigma_s_prime, float), eta, epsilon))
    u = np.linspace(0.0, 1.0, samples)[:, None]
    r = radius[None, :] * u**2
    table = R_d(r, np.asarray(sigma_a, float), np.asarray(sigma_s_prime, float), eta)
    return ProfileLUT(table.astype(np.float32), radius)

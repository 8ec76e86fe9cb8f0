"""From our medium (sigma_a, sigma_s', eta, g in mm^-1) to Blender's shader inputs. Pure.

Cycles brute force (a volume inside a smooth dielectric): Volume Scatter and Volume Absorption
nodes, whose coefficients are density x colour (scatter) and density x (1 - colour) (absorption),
per Blender unit.

Cycles random walk (Principled BSDF, subsurface method RANDOM_WALK): Cycles maps the inputs
Base Color A and radius d = Subsurface Radius x Subsurface Scale to a medium with
sigma_t' = 1 / d and single-scattering albedo alpha_c = f(A, g), a fit by Wrenninge, Villemin and
Hery (Cycles ``subsurface_random_walk_remap``) made for an index-matched boundary. Copying our
sigma_t' and alpha' into it renders about 30 % too bright against the brute force (measured on a
slab, see tests/test_cycles_conversion.py): our medium traps light by internal reflection at eta.
So we match the two things a viewer sees instead:

* the diffuse albedo with the boundary: rho = R_d(alpha', eta) (1 - F_dr,in(eta)), the total diffuse
  reflectance (Jensen Eq. 6) times the hemispherical Fresnel transmittance into the medium. Cycles'
  walk does not render albedo A for Base Color A (about 0.9 A, and at most 0.897: its walk stops after
  256 steps), so A comes from inverting rho_eff(A, eta), measured in Cycles by
  scripts/calibrate_random_walk.py (data/cycles_random_walk_albedo.csv) and re-checked by a test;
* the diffusion length 1 / sigma_tr, sigma_tr = sqrt(3 sigma_a sigma_t'): Cycles' medium has
  sigma_t = 1 / (d (1 - g)) and single-scattering albedo alpha_c, so sigma_a = sigma_t (1 - alpha_c),
  sigma_t' = sigma_t (1 - alpha_c g) and sigma_tr,c = sqrt(3 (1 - alpha_c) (1 - alpha_c g)) / (d (1 - g)):
  d = ``walk_length(alpha_c, g)`` / sigma_tr (sqrt(3 (1 - alpha_c)) / sigma_tr at g = 0).
"""
from __future__ import annotations

import dataclasses
import functools

import numpy as np
from numpy.typing import ArrayLike

from ..data import DATA
from .dipole import dipole_parameters, total_diffuse_reflectance
from .fresnel import hemispherical_transmittance

CALIBRATION_CSV = DATA / "cycles_random_walk_albedo.csv"


def walk_length(alpha_c: ArrayLike, g: float) -> np.ndarray:
    """sigma_tr d of Cycles' random-walk medium for radius d: sqrt(3 (1 - alpha_c) (1 - alpha_c g)) / (1 - g) (module
    doc; Cycles ``subsurface_random_walk_remap`` takes sigma_t = 1 / (d (1 - g)))."""
    alpha_c = np.asarray(alpha_c, dtype=np.float64)
    return np.sqrt(3.0 * (1.0 - alpha_c) * (1.0 - alpha_c * g)) / (1.0 - g)


def _poly(g, coeffs):
    return sum(c * g**k for k, c in enumerate(coeffs))


def cycles_single_scattering_albedo(A: ArrayLike, g: float = 0.0) -> np.ndarray | float:
    """alpha = f(A, g): Cycles' multiple-scattering (Base Color) to single-scattering albedo."""
    A = np.asarray(A, dtype=np.float64)
    a = _poly(g, (1.8260523782, -1.28451056436, -1.79904629312, 9.19393289202, -22.8215585862, 32.0234874259,
                  -23.6264803333, 7.21067002658))
    b = 4.98511194385 + 0.127355959438 * np.exp(_poly(g, (0, 31.1491581433, -201.847017512, 841.576016723,
                                                            -2018.09288505, 2731.71560286, -1935.41424244,
                                                            559.009054474)))
    c = _poly(g, (1.09686102424, -0.394704063468, 1.05258115941, -8.83963712726, 28.8643230661, -46.8802913581,
                  38.5402837518, -12.7181042538))
    d = _poly(g, (0.496310210422, 0.360146581622, -2.15139309747, 17.8896899217, -55.2984010333, 82.065982243,
                  -58.5106008578, 15.8478295021))
    e = 4.23190299701 + 0.00310603949088 * np.exp(_poly(g, (0, 76.7316253952, -594.356773233, 2448.8834203,
                                                              -5576.68528998, 7116.60171912, -4763.54467887,
                                                              1303.5318055)))
    f = _poly(g, (2.40602999408, -2.51814844609, 9.18494908356, -79.2191708682, 259.082868209, -403.613804597,
                  302.85712436, -87.4370473567))
    blend = A**0.25
    alpha = (1 - blend) * a * np.arctan(b * A) ** c + blend * d * np.arctan(e * A) ** f
    return np.clip(alpha, 0.0, 0.999999)


def base_color_for_albedo(alpha: ArrayLike, g: float = 0.0, iterations: int = 60) -> np.ndarray | float:
    """Inverse of ``cycles_single_scattering_albedo`` in A over [0, 1], by bisection."""
    alpha = np.asarray(alpha, dtype=np.float64)
    lo, hi = np.zeros_like(alpha), np.ones_like(alpha)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        low = cycles_single_scattering_albedo(mid, g) < alpha
        lo, hi = np.where(low, mid, lo), np.where(low, hi, mid)
    return 0.5 * (lo + hi)


@functools.lru_cache(maxsize=1)
def random_walk_calibration() -> dict[float, tuple[np.ndarray, np.ndarray]]:
    """eta -> (A, rho_eff) as measured in Cycles, rho_eff made non-decreasing."""
    data = np.loadtxt(CALIBRATION_CSV, delimiter=",", comments="#", skiprows=2)
    table = {}
    for eta in np.unique(data[:, 0]):
        rows = data[data[:, 0] == eta]
        order = np.argsort(rows[:, 1])
        table[float(eta)] = (rows[order, 1], np.maximum.accumulate(rows[order, 2]))
    return table


def _across_eta(eta: float, curve) -> np.ndarray | float:
    """``curve(A, rho_eff)`` on the calibration tables either side of eta, linear in eta between them (clamped
    to the tabulated range). Each table starts at A = 0, rho_eff = 0: a black medium reflects nothing."""
    table = random_walk_calibration()
    etas = np.array(sorted(table))
    eta = float(np.clip(eta, etas[0], etas[-1]))
    hi = int(np.clip(np.searchsorted(etas, eta), 1, len(etas) - 1))
    lo = hi - 1
    t = (eta - etas[lo]) / (etas[hi] - etas[lo])

    def on(e: float) -> np.ndarray | float:
        return curve(*(np.concatenate([[0.0], x]) for x in table[float(e)]))

    return (1 - t) * on(etas[lo]) + t * on(etas[hi])


def random_walk_base_color(rho: ArrayLike, eta: float) -> np.ndarray | float:
    """Base Color A for which Cycles' random walk renders diffuse albedo rho (clamped to its range)."""

    def invert(A: np.ndarray, r: np.ndarray) -> np.ndarray | float:
        # np.interp needs rising x: break the plateau ties at the top by keeping the first A.
        keep = np.concatenate([[True], np.diff(r) > 0])
        return np.interp(rho, r[keep], A[keep])

    return _across_eta(eta, invert)


def random_walk_max_albedo(eta: float) -> float:
    table = random_walk_calibration()
    nearest = min(table, key=lambda e: abs(e - eta))
    return float(table[nearest][1].max())


@dataclasses.dataclass(frozen=True)
class RandomWalkInputs:
    base_color: tuple  # Principled Base Color A
    radius: tuple  # Subsurface Radius in Blender units (with Subsurface Scale = 1)
    ior: float
    anisotropy: float
    target_albedo: tuple  # rho the medium has; Cycles renders min(rho, its maximum)


def random_walk_inputs(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, g: float,
                       mm_per_unit: float) -> RandomWalkInputs:
    """Principled random-walk inputs with our diffuse albedo and diffusion length (see module doc)."""

    sa = np.asarray(sigma_a, dtype=np.float64)
    ss = np.asarray(sigma_s_prime, dtype=np.float64)
    rho = np.clip(total_diffuse_reflectance(sa, ss, eta) * hemispherical_transmittance(eta), 0.0, 1.0)
    A = np.clip(random_walk_base_color(rho, eta), 0.0, 1.0)
    alpha_c = cycles_single_scattering_albedo(A, g)
    _, sigma_tr, _, _ = dipole_parameters(sa, ss, eta)
    with np.errstate(divide="ignore", invalid="ignore"):
        radius_mm = np.where(sigma_tr > 0, walk_length(alpha_c, g) / sigma_tr, 1.0 / (sa + ss))
    return RandomWalkInputs(tuple(A), tuple(radius_mm / mm_per_unit), float(eta), float(g), tuple(rho))


@dataclasses.dataclass(frozen=True)
class VolumeInputs:
    scatter_color: tuple
    scatter_density: float  # per Blender unit
    absorption_color: tuple
    absorption_density: float  # per Blender unit
    anisotropy: float
    ior: float


def volume_inputs(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, g: float,
                  mm_per_unit: float) -> VolumeInputs:
    """Volume Scatter (sigma_s = density x colour) and Volume Absorption (sigma_a = density x (1 - colour))."""
    sigma_s = np.asarray(sigma_s_prime, dtype=np.float64) / (1.0 - g) * mm_per_unit
    sigma_a = np.asarray(sigma_a, dtype=np.float64) * mm_per_unit
    rho_s = float(sigma_s.max())
    rho_a = float(sigma_a.max())
    return VolumeInputs(
        scatter_color=tuple(sigma_s / rho_s),
        scatter_density=rho_s,
        absorption_color=tuple(1.0 - sigma_a / rho_a) if rho_a > 0 else (1.0, 1.0, 1.0),
        absorption_density=rho_a,
        anisotropy=float(g),
        ior=float(eta),
    )


def random_walk_albedo(base_color: ArrayLike, eta: float) -> np.ndarray | float:
    """rho_eff(A, eta): the diffuse albedo Cycles' random walk renders for Base Color A (the calibration,
    linear in A between its samples and in eta between its tables; the inverse of ``random_walk_base_color``
    where rho_eff rises)."""
    A = np.asarray(base_color, dtype=np.float64)
    return _across_eta(eta, lambda samples, rho: np.interp(A, samples, rho))


def reduced_albedo_for(rho: ArrayLike, eta: float, iterations: int = 60) -> np.ndarray:
    """alpha' whose diffuse albedo with the boundary, R_d(alpha', eta) (1 - F_dr,in(eta)) (Jensen 2001 Eq. 6
    times the hemispherical transmittance), is rho: the inverse of the albedo ``random_walk_inputs`` matches,
    by bisection (R_d rises with alpha'). rho beyond the albedo of alpha' = 1 gives alpha' = 1."""
    rho = np.asarray(rho, dtype=np.float64)
    T = hemispherical_transmittance(eta)
    lo, hi = np.zeros_like(rho), np.ones_like(rho)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        low = total_diffuse_reflectance(1.0 - mid, mid, eta) * T < rho  # sigma_a + sigma_s' = 1: alpha' = mid
        lo, hi = np.where(low, mid, lo), np.where(low, hi, mid)
    return 0.5 * (lo + hi)


SHORTEST_RADIUS_MM = 1e-4  # a radius of 0 (Cycles: that channel does not scatter) is taken as this
MAX_REDUCED_ALBEDO = 1.0 - 1e-9  # alpha' = 1 has sigma_tr = 0: no finite coefficients give it


def medium_from_random_walk(base_color: ArrayLike, radius: ArrayLike, ior: float, anisotropy: float,
                            mm_per_unit: float) -> tuple[np.ndarray, np.ndarray]:
    """(sigma_a, sigma_s') in mm^-1 of a Principled BSDF's random-walk subsurface: the inverse of
    ``random_walk_inputs``. ``radius``: Subsurface Radius x Subsurface Scale, in Blender units.

    The medium keeps what a viewer sees of Cycles' material: its diffuse albedo rho = rho_eff(A, eta) (as
    Cycles renders Base Color A, measured) and its diffusion length: d sigma_tr = ``walk_length(alpha_c, g)`` with
    Cycles' single-scattering albedo alpha_c = f(A, g). Our alpha' follows from rho (``reduced_albedo_for``),
    then sigma_t' = sigma_tr / sqrt(3 (1 - alpha')) (sigma_tr = sqrt(3 sigma_a sigma_t'), Jensen 2001),
    sigma_s' = alpha' sigma_t' and sigma_a = sigma_t' - sigma_s'."""
    A = np.clip(np.asarray(base_color, dtype=np.float64), 0.0, 1.0)
    d_mm = np.maximum(np.asarray(radius, dtype=np.float64) * float(mm_per_unit), SHORTEST_RADIUS_MM)
    alpha_c = cycles_single_scattering_albedo(A, anisotropy)
    sigma_tr = walk_length(alpha_c, anisotropy) / d_mm
    alpha_prime = np.minimum(reduced_albedo_for(random_walk_albedo(A, ior), ior), MAX_REDUCED_ALBEDO)
    sigma_t_prime = sigma_tr / np.sqrt(3.0 * (1.0 - alpha_prime))
    sigma_s_prime = alpha_prime * sigma_t_prime
    return sigma_t_prime - sigma_s_prime, sigma_s_prime

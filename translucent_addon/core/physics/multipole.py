"""Multipole diffusion for slabs and layered materials (Donner and Jensen 2005), used by Shah 6.5.

A slab of thickness d has two boundaries; the dipole is mirrored about both
extrapolated boundaries (z_b above the top, z_b below the bottom) into 2n + 1 pairs.
With z_r = 1/sigma_t', D = 1/(3 sigma_t'), z_b = 2 A D and l = d + 2 z_b (Donner & Jensen Eq. 9-10):

    z_{r,i} = 2 i l + z_r,          z_{v,i} = 2 i l - z_r - 2 z_b,   i = -n..n

    R(r) = alpha'/(4 pi) sum_i [ z_{r,i} (sigma_tr d_{r,i} + 1) e^{-sigma_tr d_{r,i}} / d_{r,i}^3
                               - z_{v,i} (sigma_tr d_{v,i} + 1) e^{-sigma_tr d_{v,i}} / d_{v,i}^3 ]
    T(r) = alpha'/(4 pi) sum_i [ (d - z_{r,i}) (...)_{r,i} / d_{r,i}^3 - (d - z_{v,i}) (...)_{v,i} / d_{v,i}^3 ]

(d_{r,i} = sqrt(r^2 + z_{r,i}^2) for R, sqrt(r^2 + (d - z_{r,i})^2) for T). The i = 0 pair of R is the
dipole, so a thick slab reproduces it. Layers are combined in the Fourier domain (Donner & Jensen
Eq. 14-15): R12 = R1 + T1 R2 T1 / (1 - R2 R1), T12 = T1 T2 / (1 - R2 R1), with the convolutions of the
radially symmetric profiles done by 2D FFT on a grid whose cells hold exact ring averages (every
pair integrates over a disk in closed form), since T has sharp peaks that point samples miss.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import ArrayLike

from .dipole import A, R_d_disk


def _pair_terms(r, z, sigma_tr):
    d = np.sqrt(r**2 + z**2)
    return (sigma_tr * d + 1.0) * np.exp(-sigma_tr * d) / d**3


MAX_PAIRS = 500  # mirror pairs at most (a medium that does not absorb converges algebraically, not in e^-x)
PAIR_DEPTH_TR = 8.0  # the farthest pair lies this many diffusion lengths 1 / sigma_tr beyond the reach


def _slab_images(sigma_a, sigma_s_prime, eta, thickness, n_pairs=None, eta_bottom=None, reach=0.0):
    """alpha', sigma_tr and the depths (z_r,i, z_v,i) of the mirrored dipole pairs of a slab.

    eta is the relative index at the top boundary, eta_bottom (default eta) at the bottom one; each
    boundary has its own extrapolation distance z_b = 2 A D, and the period of the mirrored pairs is
    l = d + z_b,top + z_b,bottom (Donner & Jensen 2005). The pairs' contributions fall off as
    e^{-sigma_tr 2 i l} (their disk totals), so by default they reach PAIR_DEPTH_TR diffusion lengths beyond the
    largest radius asked for (``reach``): a count of mean free paths instead (Donner & Jensen's ~10 z_r) left a
    1 mm slab of whole milk 25 % too bright in red, where the diffusion length is 11 times the slab.
    """
    sigma_t_prime = sigma_a + sigma_s_prime
    alpha_prime = sigma_s_prime / sigma_t_prime
    sigma_tr = np.sqrt(3.0 * sigma_a * sigma_t_prime)
    z_r = 1.0 / sigma_t_prime
    D = 1.0 / (3.0 * sigma_t_prime)
    z_b = 2.0 * A(eta) * D
    z_b_bottom = 2.0 * A(eta if eta_bottom is None else eta_bottom) * D
    ell = thickness + z_b + z_b_bottom
    if n_pairs is None:
        depth = max(10.0 * z_r, reach + PAIR_DEPTH_TR / max(float(sigma_tr), 1e-300))
        n_pairs = int(max(2.0, min(np.ceil(depth / (2.0 * ell)), MAX_PAIRS)))
    pairs = [(2.0 * i * ell + z_r, 2.0 * i * ell - z_r - 2.0 * z_b) for i in range(-n_pairs, n_pairs + 1)]
    return alpha_prime, sigma_tr, pairs


def slab_profiles(r: ArrayLike, sigma_a: float, sigma_s_prime: float, eta: float, thickness: float,
                  n_pairs: int | None = None,
                  eta_bottom: float | None = None) -> tuple[np.ndarray | float, np.ndarray | float]:
    """R(r) and T(r) [mm^-2] of a homogeneous slab of the given thickness [mm] (scalar coefficients)."""
    r = np.asarray(r, dtype=np.float64)
    alpha_prime, sigma_tr, pairs = _slab_images(sigma_a, sigma_s_prime, eta, thickness, n_pairs, eta_bottom,
                                                reach=float(np.max(r, initial=0.0)))
    R = np.zeros_like(r)
    T = np.zeros_like(r)
    for z_ri, z_vi in pairs:
        R += z_ri * _pair_terms(r, z_ri, sigma_tr) - z_vi * _pair_terms(r, z_vi, sigma_tr)
        T += (thickness - z_ri) * _pair_terms(r, thickness - z_ri, sigma_tr) - (thickness - z_vi) * _pair_terms(
            r, thickness - z_vi, sigma_tr
        )
    scale = alpha_prime / (4.0 * np.pi)
    return scale * R, scale * T


def _pair_disk(radius, z, sigma_tr):
    """int_0^radius z (sigma_tr d + 1) e^{-sigma_tr d} / d^3 2 pi r dr, d = sqrt(r^2 + z^2), in closed form:
    2 pi sign(z) (e^{-sigma_tr |z|} - |z| e^{-sigma_tr D} / D), D = sqrt(radius^2 + z^2)."""
    a = np.abs(z)
    D = np.sqrt(radius**2 + z * z)
    return 2.0 * np.pi * np.sign(z) * (np.exp(-sigma_tr * a) - a * np.exp(-sigma_tr * D) / D)


def slab_disk_integrals(radius: ArrayLike, sigma_a: float, sigma_s_prime: float, eta: float, thickness: float,
                        n_pairs: int | None = None,
                        eta_bottom: float | None = None) -> tuple[np.ndarray | float, np.ndarray | float]:
    """Integrals of R and T of ``slab_profiles`` over a disk of the given radius [mm] (closed form)."""
    radius = np.asarray(radius, dtype=np.float64)
    alpha_prime, sigma_tr, pairs = _slab_images(sigma_a, sigma_s_prime, eta, thickness, n_pairs, eta_bottom,
                                                reach=float(np.max(radius, initial=0.0)))
    R = np.zeros_like(radius)
    T = np.zeros_like(radius)
    for z_ri, z_vi in pairs:
        R += _pair_disk(radius, z_ri, sigma_tr) - _pair_disk(radius, z_vi, sigma_tr)
        T += _pair_disk(radius, thickness - z_ri, sigma_tr) - _pair_disk(radius, thickness - z_vi, sigma_tr)
    scale = alpha_prime / (4.0 * np.pi)
    return scale * R, scale * T


@dataclasses.dataclass(frozen=True)
class Layer:
    sigma_a: float
    sigma_s_prime: float
    thickness: float  # mm; np.inf for a semi-infinite base


@dataclasses.dataclass(frozen=True)
class Grid:
    """A square grid of n x n cells of size h [mm] centred on the origin, for FFT convolutions."""

    n: int
    h: float

    def radii(self) -> np.ndarray:
        c = (np.arange(self.n) - self.n // 2) * self.h
        x, y = np.meshgrid(c, c)
        return np.sqrt(x**2 + y**2)


def _to_fourier(profile_2d, grid: Grid):
    return np.fft.fft2(np.fft.ifftshift(profile_2d)) * grid.h**2


def _from_fourier(spectrum, grid: Grid):
    return np.real(np.fft.fftshift(np.fft.ifft2(spectrum))) / grid.h**2


def _ring_average(cumulative, grid: Grid):
    """Cell values of radial profiles from their disk integrals C(r): the mean over the annulus of
    width h at each cell's radius (the centre cell: the disk of the cell's area). Conserves energy
    where point samples of a sharp peak would not; cumulative maps radii to a tuple of C(r)."""
    r = grid.radii()
    h = grid.h
    inner = np.maximum(r - 0.5 * h, 0.0)
    outer = np.where(r > 0, r + 0.5 * h, h / np.sqrt(np.pi))
    radii = np.unique(np.concatenate([inner.ravel(), outer.ravel()]))
    values = cumulative(radii)
    out = []
    for c in values:
        c_in = np.interp(inner, radii, c)
        c_out = np.interp(outer, radii, c)
        out.append((c_out - c_in) / (np.pi * (outer**2 - inner**2)))
    return tuple(out)


def layered_profiles(layers: list[Layer], eta: float, grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """R and T of a stack of layers (top first) on a grid, by Kubelka-Munk adding in frequency space.

    Returns two (n, n) arrays in mm^-2 (cell averages). The stack sits inside one dielectric
    boundary of relative index eta (the top of the first layer, and the bottom of the last one if
    finite); the interfaces between layers are index-matched (eta = 1).
    """
    R_tot = T_tot = None
    for k, layer in enumerate(layers):
        top = eta if k == 0 else 1.0
        bottom = eta if k == len(layers) - 1 else 1.0
        if np.isinf(layer.thickness):
            (R_img,) = _ring_average(lambda r: (R_d_disk(r, layer.sigma_a, layer.sigma_s_prime, top),), grid)
            R2, T2 = _to_fourier(R_img, grid), 0.0
        else:
            R_img, T_img = _ring_average(
                lambda r: slab_disk_integrals(r, layer.sigma_a, layer.sigma_s_prime, top, layer.thickness,
                                              eta_bottom=bottom), grid)
            R2, T2 = _to_fourier(R_img, grid), _to_fourier(T_img, grid)
        if R_tot is None:
            R_tot, T_tot = R2, T2
        else:
            denom = 1.0 - R2 * R_tot
            R_tot = R_tot + T_tot * R2 * T_tot / denom
            T_tot = T_tot * T2 / denom
    return _from_fourier(R_tot, grid), _from_fourier(T_tot, grid)


def radial_profile(image: np.ndarray, grid: Grid, radii: np.ndarray) -> np.ndarray:
    """Radial average of a grid profile at the given radii (linear interpolation of ring means)."""
    r = grid.radii().ravel()
    bins = np.floor(r / grid.h).astype(int)
    sums = np.bincount(bins, weights=image.ravel())
    counts = np.bincount(bins)
    ring_r = np.bincount(bins, weights=r) / np.maximum(counts, 1)
    means = sums / np.maximum(counts, 1)
    return np.interp(radii, ring_r, means)

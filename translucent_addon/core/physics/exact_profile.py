"""The diffuse reflectance profile R_d of exact transport, tabulated from Monte Carlo of a half-space.

The dipole (``dipole.py``, Jensen 2001 Eq. 5) is the papers' profile; against exact transport its total is
off by up to 10 % for the measured media (high albedo, and more at eta > 1) and its shape more, so
IMAGE_SPACE and TEXTURE_SPACE read R_d from here instead: the same functions, the same units (mm^-2),
the same broadcasting, so a shader's lookup table or a bake's form factors change nothing but their values.

The table (``data/half_space_profile.npz``, written by ``scripts/tabulate_profile.py`` from
``half_space_mc``) holds R^ in units of sigma_t'^2 over annuli of rho = r sigma_t' for a grid of albedos
(s = sqrt(1 - alpha')) and indices of refraction; a medium's profile is R_d(r) = sigma_t'^2 R^(r sigma_t').
Between albedos and etas it is interpolated in log R^ (linear where a value is zero), along rho in log-log
between annulus centres; integrals come from the annulus sums, exact for the tabulated means.
Outside the table's eta range [1, 2] the nearest eta is used.
"""
from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from ..data import DATA
from . import angular_law, dipole

TABLE = DATA / "half_space_profile.npz"
# How the light it sends back depends on the angles it arrives and leaves at (the profile is tabulated for
# cosine-weighted light, sent out Lambertian): the module of that name.
angular_table = angular_law.table
# How the light that crossed a thin part leaves (the slowest diffusion mode's law).
through_exit_table = angular_law.through_exit_table
ETAS = (1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.8, 2.0)
# Albedos: every 0.03 up to 0.9, then 1 - alpha' geometric in 50 steps of 19 % from 0.086 to 1.6e-5, and 1.
HIGH_ROOTS = np.geomspace(0.004, 1.0, 64)[:50]  # s = sqrt(1 - alpha') of the high albedos
ALBEDOS = np.concatenate([np.linspace(0.0, 0.9, 31), (1.0 - HIGH_ROOTS**2)[::-1], [1.0]])
LONG_RUN_FROM = 31  # nodes from here on need paths of up to 4e5 scatterings; below, 3000 suffice
RHO_EDGES = np.concatenate([[0.0], np.geomspace(1e-3, 1e4, 7 * 12 + 1)])  # mean free paths, 12 per decade


@dataclasses.dataclass(frozen=True)
class _Table:
    R_per_albedo: np.ndarray  # (etas, albedos, annuli) float64: R^ / alpha' in sigma_t'^2 units
    eta: np.ndarray
    x: np.ndarray  # (albedos,) the interpolation coordinate of each albedo (``_x``)
    edges: np.ndarray
    centres: np.ndarray  # (annuli,) geometric centres (arithmetic for the first)
    annulus: np.ndarray  # (annuli,) pi (r_1^2 - r_0^2)


def _x(alpha_prime: float | np.ndarray) -> float | np.ndarray:
    """-log(1 - alpha'): about alpha' at low albedo, about log(1 / (1 - alpha')) at high, where profiles change."""
    return -np.log1p(-(np.asarray(alpha_prime, np.float64) - 1e-7))


@functools.lru_cache(maxsize=1)
def _table() -> _Table:
    with np.load(TABLE) as f:
        R = f["R_per_albedo"].astype(np.float64)
        edges = f["rho_edges"].astype(np.float64)
        table = _Table(R, f["eta"].astype(np.float64), _x(f["albedo"].astype(np.float64)), edges,
                       np.concatenate([[0.5 * edges[1]], np.sqrt(edges[1:-1] * edges[2:])]),
                       np.pi * np.diff(edges**2))
    return table


def _blend(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """Interpolate two profiles: geometric where both are positive (exponential tails stay exponential)."""
    if t <= 0.0:
        return a
    if t >= 1.0:
        return b
    positive = (a > 0) & (b > 0)
    out = (1.0 - t) * a + t * b
    with np.errstate(divide="ignore"):
        out[positive] = np.exp((1.0 - t) * np.log(a[positive]) + t * np.log(b[positive]))
    return out


def _bracket(nodes: np.ndarray, x: float) -> tuple[int, int, float]:
    x = float(np.clip(x, nodes[0], nodes[-1]))
    i = int(np.clip(np.searchsorted(nodes, x) - 1, 0, len(nodes) - 2))
    return i, i + 1, (x - nodes[i]) / (nodes[i + 1] - nodes[i])


@functools.lru_cache(maxsize=256)
def scaled(alpha_prime: float, eta: float) -> np.ndarray:
    """R^ per annulus (sigma_t'^2 units) of albedo alpha' and index eta, interpolated from the table: R^ / alpha'
    (smooth down to alpha' = 0, where it is the first order's profile) between the nodes, times alpha'."""
    t = _table()
    e0, e1, te = _bracket(t.eta, eta)
    a0, a1, ta = _bracket(t.x, float(_x(alpha_prime)))
    at = [_blend(t.R_per_albedo[e, a0], t.R_per_albedo[e, a1], ta) for e in (e0, e1)]
    return _diffusion_tail(_blend(at[0], at[1], te) * alpha_prime, alpha_prime, eta)


TAIL_SHARE = 1e-3  # the outermost light, in few photons: drawn from the diffusion's shape instead


def _diffusion_tail(R: np.ndarray, alpha_prime: float, eta: float) -> np.ndarray:
    """The profile with its outermost TAIL_SHARE of light (where the Monte Carlo's annuli hold few photons and
    scatter by orders of magnitude) replaced by the dipole's far field, the diffusion's e^(-sigma_tr r)
    decay, matched to the table over the three annuli before (geometric mean of the ratio)."""
    t = _table()
    power = R * t.annulus
    if power.sum() <= 0.0:
        return R
    k = int(np.searchsorted(np.cumsum(power) / power.sum(), 1.0 - TAIL_SHARE))
    if k >= len(R) - 1 or k < 4:
        return R
    dip = dipole.R_d(t.centres, 1.0 - alpha_prime, alpha_prime, eta)
    ref = slice(k - 3, k)
    ok = (R[ref] > 0) & (dip[ref] > 0)
    if not ok.any():
        return R
    ratio = float(np.exp(np.mean(np.log(R[ref][ok] / dip[ref][ok]))))
    out = R.copy()
    out[k:] = ratio * dip[k:]
    return out


@functools.lru_cache(maxsize=256)
def _cumulative(alpha_prime: float, eta: float) -> np.ndarray:
    """int R^ 2 pi rho drho from 0 to each annulus edge (the disk integrals R_d_disk and r_max read)."""
    return np.concatenate([[0.0], np.cumsum(scaled(alpha_prime, eta) * _table().annulus)])


def _groups(*arrays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique (alpha', eta, sigma_t') combinations of broadcast coefficient arrays: (keys, inverse)."""
    stacked = np.stack([a.ravel() for a in arrays], axis=1)
    keys, inverse = np.unique(stacked, axis=0, return_inverse=True)
    return keys, inverse.ravel()


def _coefficients(sigma_a: ArrayLike, sigma_s_prime: ArrayLike,
                  eta: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    sigma_a = np.asarray(sigma_a, np.float64)
    sigma_s_prime = np.asarray(sigma_s_prime, np.float64)
    sigma_t_prime = sigma_a + sigma_s_prime
    return sigma_s_prime / sigma_t_prime, sigma_t_prime, np.asarray(eta, np.float64)


def _per_medium(x: ArrayLike, sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike,
                evaluate: Callable[[np.ndarray, float, float, float], np.ndarray]) -> np.ndarray | float:
    """Apply evaluate(x * sigma_t', alpha', eta, sigma_t') to each distinct medium of the broadcast inputs."""
    alpha_prime, sigma_t_prime, eta = _coefficients(sigma_a, sigma_s_prime, eta)
    x, alpha_prime, sigma_t_prime, eta = np.broadcast_arrays(np.asarray(x, np.float64), alpha_prime,
                                                             sigma_t_prime, eta)
    keys, inverse = _groups(alpha_prime, eta, sigma_t_prime)
    out = np.empty(x.size)
    flat = x.ravel()
    for k, (a, e, st) in enumerate(keys):
        sel = inverse == k
        out[sel] = evaluate(flat[sel] * st, float(a), float(e), float(st))
    return out.reshape(x.shape) if x.shape else float(out[0])


def R_d(r: ArrayLike, sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike) -> np.ndarray | float:
    """Exact-transport R_d(r) [mm^-2] at distance r [mm]: sigma_t'^2 R^(r sigma_t'), log-log between annulus
    centres, the innermost annulus's mean below its centre, zero beyond the table."""
    t = _table()
    log_c = np.log(t.centres)

    def evaluate(rho: np.ndarray, a: float, e: float, st: float) -> np.ndarray:
        R = scaled(a, e)
        positive = R > 0
        if not positive.any():
            return np.zeros_like(rho)
        lc, lR = log_c[positive], np.log(R[positive])
        with np.errstate(divide="ignore"):
            value = np.exp(np.interp(np.log(np.maximum(rho, 1e-300)), lc, lR))
        return np.where(rho > t.edges[-1], 0.0, value) * st * st

    return _per_medium(r, sigma_a, sigma_s_prime, eta, evaluate)


def R_d_disk(radius: ArrayLike, sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike) -> np.ndarray | float:
    """Integral of R_d over a disk of the given radius [mm]: the annulus sums, linear in r^2 inside an annulus."""
    t = _table()
    edges2 = t.edges**2

    def evaluate(rho: np.ndarray, a: float, e: float, st: float) -> np.ndarray:
        return np.interp(rho * rho, edges2, _cumulative(a, e))

    return _per_medium(radius, sigma_a, sigma_s_prime, eta, evaluate)


def total_diffuse_reflectance(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike) -> np.ndarray | float:
    """Integral of R_d over the plane (the table's reach, 10^4 mean free paths)."""
    return R_d_disk(np.inf, sigma_a, sigma_s_prime, eta)


def r_max(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike, epsilon: float = 0.01) -> np.ndarray | float:
    """Radius [mm] of the disk holding all but epsilon of R_d's integral (Shah Eq. 6.16), per channel."""
    t = _table()
    edges2 = t.edges**2

    def evaluate(rho: np.ndarray, a: float, e: float, st: float) -> np.ndarray:
        cumulative = _cumulative(a, e)
        if cumulative[-1] <= 0.0:
            return np.zeros_like(rho)
        return np.full_like(rho, np.sqrt(np.interp((1.0 - epsilon) * cumulative[-1], cumulative, edges2)) / st)

    return _per_medium(0.0, sigma_a, sigma_s_prime, eta, evaluate)

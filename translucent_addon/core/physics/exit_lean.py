"""How the light leaving a surface leans away from where it entered. Pure.

IMAGE_SPACE draws the light that entered at x_i and leaves at x_o with one law of the exit angle for all of it
(``angular_law``: Lambertian times a(mu_o)), blind to where x_i lies. In exact transport the light that leaves
at x_o is still travelling away from x_i: near the entry point it has scattered a few times and not forgotten
its direction. Written about the Lambertian radiance L_0,

    L(x_o, w_o) = L_0 (1 + beta(r) sin(theta_o) cos(psi)),   psi the azimuth of w_o from e = (x_o - x_i)_t / |.|,

so that beta is the first azimuthal moment of the exit direction: beta = 4 <sin(theta_o) cos(psi)> over the
exiting power (``half_space_mc.lean``). The lean leaves each pair's exitance as it was (cos(psi) integrates to
0) and, summed over a uniformly lit flat face, cancels; near a terminator the sources lie on one side and it
does not. Measured on a back-lit cylinder (``scripts/cylinder_mc.py --angular``): marble's terminator band sends
1.15-1.24 of the Lambertian radiance towards the dark side at view cosine 0.5, 2.2-3.0 at 0.2.

Marble at eta = 1 (alpha' 0.999): beta 1.34 within a quarter of a mean free path, 1.09 at 1-2, 0.62 at 4-8, 0.24
at 16-32; the diffusion's own lean (the P1 radiance with the dipole's tangential flux) is 2.5-18 times weaker
there. Lower albedos lean more (alpha' 0.7: about 1.5 at every distance: what leaves far has scattered little),
a refracting boundary less (internal reflection turns the light: at eta = 1.3 marble's 1.23 near the source,
0.54 at 1-2 mean free paths).

The table (``data/half_space_lean.npz``, ``scripts/tabulate_lean.py``) holds beta per eta, albedo (the
profile's nodes) and annulus of rho = r sigma_t'; between nodes it is linear in eta, in the profile's albedo
coordinate and in log rho between annulus centres. Beyond 1 the linear law goes negative at grazing angles
away from the entry point: clamped at 0 there, it sends out N(beta) of the light, 1.003, 1.014, 1.042, 1.080 at
beta 1.2, 1.4, 1.7, 2 (the hemisphere's integral; fitted on [1, 2] as 1 + x^2 (0.0985 - 0.0181 x), x = beta - 1,
within 0.0006), so the methods divide by it: the pair's exitance stays the profile's (``normalisation``). The
table is held to BETA_MAX = 2, where the fit ends (low albedos lean up to 2.2 far from the entry point, where
little light leaves). What the clamped law does not keep: seen from one direction, a uniformly lit flat face's
pairs of beta > 1 average 1 / N(beta) of the unleaned radiance at views within asin(1 / beta) of the normal and
more beyond (skin1's beta of about 1.4: 1.4 % less light towards the normal).
"""
from __future__ import annotations

import dataclasses
import functools

import numpy as np
from numpy.typing import ArrayLike

from ..data import DATA
from . import exact_profile
from .exact_profile import _bracket, _x  # the profile table's interpolation in eta and albedo
from .lut import partition
from .quadrature import trapezoid

TABLE = DATA / "half_space_lean.npz"
ETAS = (1.0, 1.2, 1.3, 1.4, 1.6, 2.0)
EDGES = np.concatenate([[0.0], np.geomspace(0.01, 1000.0, 21)])  # mean free paths, 4 annuli per decade
BETA_MAX = 2.0  # where normalisation's fit holds (module doc)


@dataclasses.dataclass(frozen=True)
class _Table:
    beta: np.ndarray  # (etas, albedos, annuli)
    eta: np.ndarray
    x: np.ndarray  # the albedos' interpolation coordinate (exact_profile)
    log_centres: np.ndarray  # (annuli,) log of the annuli's geometric centres (half the first edge for the disk)


@functools.lru_cache(maxsize=1)
def _table() -> _Table:
    with np.load(TABLE) as f:
        edges = f["edges"].astype(np.float64)
        centres = np.concatenate([[0.5 * edges[1]], np.sqrt(edges[1:-1] * edges[2:])])
        return _Table(np.clip(f["beta"].astype(np.float64), 0.0, BETA_MAX), f["eta"].astype(np.float64),
                      _x(f["albedo"].astype(np.float64)), np.log(centres))


@functools.lru_cache(maxsize=256)
def scaled(alpha_prime: float, eta: float) -> np.ndarray:
    """beta per annulus of albedo alpha' and index eta, interpolated from the table."""
    t = _table()
    e0, e1, te = _bracket(t.eta, eta)
    a0, a1, ta = _bracket(t.x, float(_x(alpha_prime)))
    at = [(1.0 - ta) * t.beta[e, a0] + ta * t.beta[e, a1] for e in (e0, e1)]
    return (1.0 - te) * at[0] + te * at[1]


def beta(r: ArrayLike, sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float) -> np.ndarray:
    """beta(r) (..., 3) of a medium at distances r [mm] from the entry point: rgb coefficients per mm, r (...)."""
    sigma_a = np.asarray(sigma_a, np.float64)
    sigma_t_prime = sigma_a + np.asarray(sigma_s_prime, np.float64)
    log_rho = np.log(np.maximum(np.asarray(r, np.float64)[..., None] * sigma_t_prime, 1e-300))
    lc = _table().log_centres
    out = np.empty(log_rho.shape)
    for c in range(3):
        out[..., c] = np.interp(log_rho[..., c], lc, scaled(float(1.0 - sigma_a[c] / sigma_t_prime[c]), float(eta)))
    return out


def normalisation(beta_rgb: ArrayLike) -> np.ndarray:
    """N(beta): the hemisphere's cosine-weighted mean of max(0, 1 + beta sin(theta) cos(psi)) (fit, module doc)."""
    x = np.clip(np.asarray(beta_rgb, np.float64), 1.0, BETA_MAX) - 1.0
    return 1.0 + x * x * (0.0985 - 0.0181 * x)


def pair_factor(beta_rgb: ArrayLike, x_i: ArrayLike, x_o: ArrayLike, n_o: ArrayLike, to_eye: ArrayLike) -> np.ndarray:
    """(..., 3): max(0, 1 + beta sin(theta_o) cos(psi)) / N(beta) for light from x_i leaving x_o (normal n_o)
    towards the eye; sin(theta_o) cos(psi) = to_eye . e, e the unit part of x_o - x_i along x_o's surface
    (none where x_i lies on x_o's normal)."""
    d = np.asarray(x_o, np.float64) - np.asarray(x_i, np.float64)
    n_o = np.asarray(n_o, np.float64)
    e = d - n_o * np.sum(d * n_o, axis=-1, keepdims=True)
    length = np.linalg.norm(e, axis=-1, keepdims=True)
    c = np.sum(np.asarray(to_eye, np.float64) * e, axis=-1, keepdims=True) / np.maximum(length, 1e-300)
    beta_rgb = np.asarray(beta_rgb, np.float64)
    return np.where(length > 0, np.maximum(1.0 + beta_rgb * c, 0.0) / normalisation(beta_rgb), 1.0)


def near_constant(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, rho_mm: float) -> np.ndarray:
    """K (3,) mm: the lean of the light that enters within the near field's disk (IMAGE_SPACE draws it from E(x_o),
    the partition 1 - w(r) of ``lut.partition`` at rho). Lit by E(x) = E(x_o) + grad E . (x - x_o), the disk
    sends int R_d (1 - w) beta (w_o . e) E(x_o - r e) dA = -K (w_o . grad E) more towards w_o than it would unleaned
    (the even part of E leans to nothing), K = pi int R_d(r) (1 - w(r)) beta(r) r^2 dr (int e e^T dpsi = pi I)."""
    r = np.geomspace(1e-6, 2.0 * rho_mm, 4001)
    integrand = exact_profile.R_d(r[:, None], sigma_a, sigma_s_prime, eta) * (1.0 - partition(r, rho_mm))[:, None] \
        * beta(r, sigma_a, sigma_s_prime, eta) * (r * r)[:, None]
    return np.pi * trapezoid(integrand, r, axis=0)

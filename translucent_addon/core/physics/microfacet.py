"""The Principled BSDF's specular layer: a GGX microfacet dielectric over the subsurface or diffuse base. Pure.

What the surface layer (``gpu_shaders/pipeline/surface_layer.glsl``) draws and the tests check it against:

* GGX distribution D with alpha = roughness^2 (Walter et al. 2007 Eq. 33, Blender's convention), Smith's
  height-correlated masking-shadowing G2 = 1 / (1 + Lambda(mu_o) + Lambda(mu_i)) (Heitz 2014 Eq. 99), the
  dielectric Fresnel F(h . w_o, eta): f_s = D G2 F / (4 mu_i mu_o) (Walter Eq. 20);
* Cycles' multiscatter GGX keeps the energy a single bounce loses: f_s is scaled by
  1 + F_0 (1 - E_1(mu_o)) / E_1(mu_o), E_1 the single-bounce albedo with F = 1 (Turquin 2019, the form
  Cycles' ``microfacet_ggx_preserve_energy`` uses);
* the Principled BSDF's layering (Cycles ``closure_layering_weight``): what lies below the specular layer
  (the subsurface or diffuse light) is weighed by 1 - E_s(mu_o), E_s the layer's directional albedo seen from
  the eye (``specular_albedo``, tabulated over mu_o, roughness and F_0: ``albedo_table``);
* the IOR Level input scales F_0 = ((eta - 1) / (eta + 1))^2 by 2 x level (0.5 keeps the IOR's), and the layer's
  eta follows from that F_0 (``layer_eta``);
* the world's specular light: its radiance in spherical harmonics, each band l weighed by the lobe's
  attenuation exp(-l (l + 1) s^2 / 2), s = the GGX lobe's angular spread in reflected directions
  (``sh_lobe_kernel``; a Gaussian lobe's SH coefficients, Ramamoorthi & Hanrahan 2001), times E_s(mu_o): the
  split-sum of Karis 2013 with SH in place of a pre-filtered map.
"""
from __future__ import annotations

import functools

import numpy as np
from numpy.typing import ArrayLike

from ..data import DATA
from .fresnel import fresnel_dielectric

TABLE_FILE = DATA / "specular_albedo.npz"  # written by scripts/tabulate_specular.py (``compute_tables``)

MIN_ALPHA = 1e-3  # below this (roughness ~0.03) the layer is a mirror: no light's highlight, the world's only
TABLE_MU = 32  # albedo_table: cosines of the view (mu_o = (j + 0.5) / 32)
TABLE_ROUGHNESS = 32  # roughness r = k / 31
TABLE_F0 = 16  # F_0 = (m / 15)^2 (a square spacing: dielectrics sit near 0.02-0.08)


def alpha_of(roughness: ArrayLike) -> np.ndarray:
    """GGX alpha of Blender's Roughness (alpha = r^2), kept above the mirror limit."""
    return np.maximum(np.asarray(roughness, np.float64) ** 2, MIN_ALPHA)


def ggx_D(mu_h: ArrayLike, alpha: ArrayLike) -> np.ndarray:
    """GGX normal distribution (Walter Eq. 33): alpha^2 / (pi (mu_h^2 (alpha^2 - 1) + 1)^2)."""
    mu_h = np.asarray(mu_h, np.float64)
    a2 = np.asarray(alpha, np.float64) ** 2
    return a2 / (np.pi * (mu_h * mu_h * (a2 - 1.0) + 1.0) ** 2)


def smith_lambda(mu: ArrayLike, alpha: ArrayLike) -> np.ndarray:
    """Smith's Lambda for GGX (Heitz Eq. 72): (-1 + sqrt(1 + alpha^2 tan^2)) / 2."""
    mu = np.clip(np.asarray(mu, np.float64), 1e-6, 1.0)
    tan2 = (1.0 - mu * mu) / (mu * mu)
    return 0.5 * (-1.0 + np.sqrt(1.0 + np.asarray(alpha, np.float64) ** 2 * tan2))


def f0_of(ior: float, ior_level: float = 0.5) -> float:
    """F_0 of the Principled specular layer: ((eta - 1) / (eta + 1))^2 x 2 level, at most 1."""
    base = ((ior - 1.0) / (ior + 1.0)) ** 2
    return float(np.clip(base * 2.0 * ior_level, 0.0, 1.0))


def layer_eta(f0: ArrayLike) -> np.ndarray:
    """The eta whose normal-incidence Fresnel reflectance is F_0 (the inverse of ((eta - 1) / (eta + 1))^2)."""
    s = np.sqrt(np.clip(np.asarray(f0, np.float64), 0.0, 0.999))
    return (1.0 + s) / (1.0 - s)


def single_bounce(mu_i: ArrayLike, mu_o: ArrayLike, mu_h: ArrayLike, cos_oh: ArrayLike, alpha: ArrayLike,
                  eta: ArrayLike) -> np.ndarray:
    """f_s mu_i of one bounce (Walter Eq. 20 times the cosine): D G2 F / (4 mu_o); 0 below the horizon.
    ``eta`` None-like values are not allowed: eta 1 reflects nothing."""
    mu_i = np.asarray(mu_i, np.float64)
    mu_o = np.asarray(mu_o, np.float64)
    G2 = 1.0 / (1.0 + smith_lambda(mu_o, alpha) + smith_lambda(mu_i, alpha))
    F = fresnel_dielectric(np.clip(cos_oh, 0.0, 1.0), eta)
    value = ggx_D(mu_h, alpha) * G2 * F / (4.0 * np.maximum(mu_o, 1e-6))
    return np.where((mu_i > 0.0) & (mu_o > 0.0), value, 0.0)


def _hemisphere(n: int = 48):
    """(w (n*n*2, 3), solid-angle weights): a midpoint grid in (cos theta, phi) over the upper hemisphere, fine
    enough near the pole for alpha >= MIN_ALPHA when refined by ``_albedo``'s half-vector sampling."""
    u = (np.arange(n) + 0.5) / n
    v = (np.arange(2 * n) + 0.5) / (2 * n)
    mu, phi = np.meshgrid(u, v * 2.0 * np.pi, indexing="ij")
    s = np.sqrt(1.0 - mu * mu)
    w = np.stack([s * np.cos(phi), s * np.sin(phi), mu], -1).reshape(-1, 3)
    return w, np.full(len(w), 2.0 * np.pi / (n * 2 * n))


def _albedo(mu_o: np.ndarray, alpha: np.ndarray, eta: np.ndarray | None, n: int = 64) -> np.ndarray:
    """E(mu_o) = int f_s mu_i dw_i by sampling half-vectors from D(h) (h . n) (pdf of w_i: D mu_h / (4 |o . h|)),
    a stratified grid in (xi_1, xi_2): deterministic. ``eta`` None: F = 1. Broadcasts mu_o, alpha, eta."""
    xi1 = (np.arange(n) + 0.5) / n
    xi2 = (np.arange(n) + 0.5) / n
    X1, X2 = (x.ravel() for x in np.meshgrid(xi1, xi2, indexing="ij"))
    mu_o, alpha = np.broadcast_arrays(np.asarray(mu_o, np.float64), np.asarray(alpha, np.float64))
    shape = mu_o.shape
    mu_o = mu_o.reshape(-1, 1)
    a = alpha.reshape(-1, 1)
    # GGX: tan^2 theta_h = alpha^2 xi / (1 - xi)
    cos_h = 1.0 / np.sqrt(1.0 + a * a * X1 / (1.0 - X1))
    sin_h = np.sqrt(1.0 - cos_h * cos_h)
    phi = 2.0 * np.pi * X2
    h = np.stack([sin_h * np.cos(phi), sin_h * np.sin(phi), cos_h], -1)
    o = np.stack([np.sqrt(1.0 - mu_o * mu_o), np.zeros_like(mu_o), mu_o], -1)
    cos_oh = np.sum(o * h, -1)
    i = 2.0 * cos_oh[..., None] * h - o
    mu_i = i[..., 2]
    G2 = 1.0 / (1.0 + smith_lambda(mu_o, a) + smith_lambda(mu_i, a))
    # f mu_i / pdf = D G2 F / (4 mu_o) * 4 |o.h| / (D mu_h) = G2 F |o.h| / (mu_o mu_h)
    F = 1.0 if eta is None else fresnel_dielectric(np.clip(cos_oh, 0.0, 1.0),
                                                   np.broadcast_to(eta, shape).reshape(-1, 1))
    value = np.where((mu_i > 0.0) & (cos_oh > 0.0), G2 * F * cos_oh / (mu_o * cos_h), 0.0)
    return value.mean(axis=1).reshape(shape)


def energy_scale(mu_o: ArrayLike, alpha: ArrayLike, f0: ArrayLike) -> np.ndarray:
    """Multiscatter GGX's factor on f_s: 1 + F_0 (1 - E_1) / E_1 (Turquin 2019)."""
    E1 = np.maximum(_albedo(mu_o, alpha, None), 1e-3)
    return 1.0 + np.asarray(f0, np.float64) * (1.0 - E1) / E1


def specular_albedo(mu_o: ArrayLike, roughness: ArrayLike, f0: ArrayLike) -> np.ndarray:
    """E_s(mu_o): the share of light from the eye's direction the specular layer reflects (multiscatter)."""
    alpha = alpha_of(roughness)
    single = _albedo(mu_o, alpha, layer_eta(f0))
    return np.clip(single * energy_scale(mu_o, alpha, f0), 0.0, 1.0)


def compute_tables(n: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """(albedo, energy) float32 tables: ``albedo`` (TABLE_F0 * TABLE_ROUGHNESS, TABLE_MU) is E_s at
    mu_o = (j + 0.5) / TABLE_MU, roughness k / (TABLE_ROUGHNESS - 1), F_0 = (m / (TABLE_F0 - 1))^2, row
    m * TABLE_ROUGHNESS + k; ``energy`` (TABLE_ROUGHNESS, TABLE_MU) is (1 - E_1) / E_1, which times F_0 plus 1 is
    ``energy_scale``. About half a minute at n = 64: shipped in ``TABLE_FILE``."""
    mu = (np.arange(TABLE_MU) + 0.5) / TABLE_MU
    r = np.arange(TABLE_ROUGHNESS) / (TABLE_ROUGHNESS - 1)
    f0 = (np.arange(TABLE_F0) / (TABLE_F0 - 1)) ** 2
    rows = []
    for value in f0:  # one F_0 at a time: the sample arrays stay small
        R, MU = np.meshgrid(r, mu, indexing="ij")
        alpha = alpha_of(R)
        single = _albedo(MU, alpha, np.full(MU.shape, layer_eta(value)), n)
        E1 = np.maximum(_albedo(MU, alpha, None, n), 1e-3)
        rows.append(np.clip(single * (1.0 + value * (1.0 - E1) / E1), 0.0, 1.0))
    R, MU = np.meshgrid(r, mu, indexing="ij")
    E1 = np.maximum(_albedo(MU, alpha_of(R), None, n), 1e-3)
    return (np.concatenate(rows).astype(np.float32), ((1.0 - E1) / E1).astype(np.float32))


@functools.lru_cache(maxsize=1)
def _tables() -> tuple[np.ndarray, np.ndarray]:
    with np.load(TABLE_FILE) as data:
        return data["albedo"], data["energy"]


def albedo_table() -> np.ndarray:
    """E_s tabulated (``compute_tables``), as shipped."""
    return _tables()[0]


def energy_table() -> np.ndarray:
    """(1 - E_1) / E_1 tabulated (``compute_tables``), as shipped."""
    return _tables()[1]


def table_lookup(mu_o: ArrayLike, roughness: ArrayLike, f0: ArrayLike) -> np.ndarray:
    """E_s read from ``albedo_table`` the way the shader reads it (bilinear in mu and roughness, linear in sqrt
    F_0): the CPU twin the tests hold the GPU to."""
    table = albedo_table().astype(np.float64).reshape(TABLE_F0, TABLE_ROUGHNESS, TABLE_MU)
    mu = np.clip(np.asarray(mu_o, np.float64) * TABLE_MU - 0.5, 0.0, TABLE_MU - 1.0)
    r = np.clip(np.asarray(roughness, np.float64), 0.0, 1.0) * (TABLE_ROUGHNESS - 1)
    m = np.clip(np.sqrt(np.clip(np.asarray(f0, np.float64), 0.0, 1.0)), 0.0, 1.0) * (TABLE_F0 - 1)
    mu, r, m = np.broadcast_arrays(mu, r, m)
    out = np.zeros(mu.shape)
    i0, j0, k0 = (np.minimum(np.floor(x).astype(int), n - 2) for x, n in
                  ((m, TABLE_F0), (r, TABLE_ROUGHNESS), (mu, TABLE_MU)))
    fm, fr, fu = m - i0, r - j0, mu - k0
    for di, wi in ((0, 1 - fm), (1, fm)):
        for dj, wj in ((0, 1 - fr), (1, fr)):
            for dk, wk in ((0, 1 - fu), (1, fu)):
                out += wi * wj * wk * table[i0 + di, j0 + dj, k0 + dk]
    return out


def sh_lobe_kernel(roughness: ArrayLike) -> np.ndarray:
    """(..., 3) SH band weights (l = 0, 1, 2) of the specular lobe around the reflected direction: a Gaussian of
    angular spread s = 2 alpha / sqrt(2) (the half-vector's spread doubled by reflection), exp(-l (l + 1) s^2 / 2)
    (Ramamoorthi & Hanrahan 2001); 1, 1, 1 for a mirror."""
    s2 = 2.0 * alpha_of(roughness) ** 2
    s2 = np.asarray(s2)[..., None]
    l = np.array([0.0, 1.0, 2.0])
    return np.exp(-l * (l + 1.0) * s2 / 2.0)


def point_light_radiance(mu_i: ArrayLike, mu_o: ArrayLike, mu_h: ArrayLike, cos_oh: ArrayLike, roughness: ArrayLike,
                         f0: float, irradiance: ArrayLike) -> np.ndarray:
    """L_o = f_s mu_i E (multiscatter): what the layer sends to the eye from a light of irradiance E (normal to
    the light) arriving at cosine mu_i. The CPU twin of the emitter mode of the surface layer."""
    alpha = alpha_of(roughness)
    single = single_bounce(mu_i, mu_o, mu_h, cos_oh, alpha, layer_eta(f0))
    return single * energy_scale(mu_o, alpha, f0) * np.asarray(irradiance, np.float64)

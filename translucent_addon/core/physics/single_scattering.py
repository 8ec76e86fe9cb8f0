"""The surface's own response to the light entering it: the terms a diffusion solution draws wrongly.
Pure NumPy.

Wang et al. 2010 (Sec. 7) model multiple scattering only and name low-order scattering as what is
missing; Jensen et al. 2001 add it as the single-scattering term L^(1) beside the dipole. Along the
refracted view ray x(t) = x_o + t w_t inside the medium, light of normal irradiance E that has crossed a
path d(t) of the medium reaches x(t) and scatters once towards the eye:

    L^(1)(x_o, w_o) = T_o T_i / eta^2  integral_0^inf  sigma_s p(cos theta) E exp(-sigma_t (t + d(t))) dt

with sigma_s = sigma_s' / (1 - g), sigma_t = sigma_a + sigma_s, p the Henyey-Greenstein phase function
and T_o, T_i the Fresnel transmittances out of and into the medium. The 1 / eta^2 is the radiance's n^2
law: light leaving a denser medium spreads its flux over a wider solid angle (Jensen 2001 Eq. 7 leaves it
out; with it the flux out is what crossed the boundary, which ``boundary_gain`` relies on).
The GPU pass (``quadgraph/surface_term.glsl``) reads d(t) from the light's distance map at the nodes ``march_nodes`` and
integrates segment by segment with the exponent linear inside each segment (``march``): exact wherever d is
linear in t, as under a flat face lit by a distant light, for which (eta = 1)

    L^(1) / E = alpha p(cos theta) mu_i / (mu_i + mu_o)        (``half_space``).

Near where light enters, the diffusion's exitance also has the wrong angular law: Lambertian, where the
multiply-scattered light of a lit half-space grows towards grazing light and view (Chandrasekhar's
H functions, ``multiple_half_space``). The pass draws that too, at the pixel, and the diffusion gives
up its own flat-face response there (``exitance_loss``).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .diffusion import slab_reflectance
from .dipole import A as internal_reflection
from .fresnel import fresnel_dielectric

TAU_MAX = 8.0  # optical depth the march covers along the view ray (exp(-8) = 3e-4 left out)
SEGMENTS = 16  # march segments; nodes crowd the surface (t_k = t_max (k / N)^2)
CHORD_FACTOR_MAX = 4.0  # the local multiple scattering's geometry factor is held below this


def hg_phase(cos_theta: ArrayLike, g: float) -> np.ndarray | float:
    """Henyey-Greenstein phase function, normalised over the sphere (1 / (4 pi) for g = 0)."""
    cos_theta = np.asarray(cos_theta, np.float64)
    return (1.0 - g * g) / (4.0 * np.pi * np.power(1.0 + g * g - 2.0 * g * cos_theta, 1.5))


def refracted_cosine(mu: ArrayLike, eta: float) -> np.ndarray | float:
    """Cosine inside a medium of relative index eta >= 1 of a ray arriving at cosine mu (Snell)."""
    mu = np.asarray(mu, np.float64)
    return np.sqrt(1.0 - (1.0 - mu**2) / eta**2)


def coefficients(sigma_a: ArrayLike, sigma_s_prime: ArrayLike,
                 g: float) -> tuple[np.ndarray | float, np.ndarray | float]:
    """(sigma_s, sigma_t) per channel from the reduced coefficients (sigma_s = sigma_s' / (1 - g))."""
    sigma_s = np.asarray(sigma_s_prime, np.float64) / (1.0 - g)
    return sigma_s, np.asarray(sigma_a, np.float64) + sigma_s


def march_nodes(sigma_t: ArrayLike, segments: int = SEGMENTS, tau_max: float = TAU_MAX) -> np.ndarray:
    """Depths t_k along the view ray (same units as 1 / sigma_t): TAU_MAX optical depths of the most
    transparent channel, quadratically spaced so that the first segments resolve the surface."""
    t_max = tau_max / float(np.min(sigma_t))
    return t_max * (np.arange(segments + 1) / segments) ** 2


def _segments(t, a) -> np.ndarray:
    """integral of exp(a(t)) over each segment between nodes t (n,), a (n, c) linear inside it: exact
    (below |da| = 1e-3, as the shader, where float32 cancels: sinh(x) / x = 1 + x^2 / 6, x = da / 2)."""
    dt = np.diff(t)[:, None]
    a0, a1 = a[:-1], a[1:]
    da = a1 - a0
    small = np.abs(da) < 1e-3
    return np.where(small, dt * np.exp(0.5 * (a0 + a1)) * (1.0 + da * da / 24.0),
                    dt * (np.exp(a1) - np.exp(a0)) / np.where(small, 1.0, da))


def march(t: ArrayLike, d: ArrayLike, sigma_t: ArrayLike, source: ArrayLike) -> np.ndarray:
    """integral of source(t) exp(-sigma_t (t + d(t))) dt from nodes: per segment, the exponent is linear
    between its ends (integrated exactly) and the source (sigma_s p E, slowly varying) is their mean.
    t, d: (n,); sigma_t: (c,); source: (n, c) or (c,). Returns (c,)."""
    t = np.asarray(t, np.float64)
    a = -np.asarray(sigma_t, np.float64)[None, :] * (t + np.asarray(d, np.float64))[:, None]
    s = np.broadcast_to(np.asarray(source, np.float64), a.shape)
    return (0.5 * (s[:-1] + s[1:]) * _segments(t, a)).sum(axis=0)


def diffuse_reach(t: ArrayLike, d: ArrayLike, sigma_t: ArrayLike, sigma_tr: ArrayLike) -> np.ndarray:
    """integral of exp(-sigma_t t - sigma_tr d(t)) dt along the view ray from the march's nodes: how much
    of the multiply-scattered light, which falls off as exp(-sigma_tr d) with the light's path d, the
    eye's ray gathers before the medium hides it or the ray leaves. (c,)."""
    t = np.asarray(t, np.float64)
    a = -(np.asarray(sigma_t, np.float64)[None, :] * t[:, None]
          + np.asarray(sigma_tr, np.float64)[None, :] * np.asarray(d, np.float64)[:, None])
    return _segments(t, a).sum(axis=0)


def flat_reach(sigma_t: ArrayLike, sigma_tr: ArrayLike, mu_t: float | np.ndarray, mu_i: float | np.ndarray,
               t_max: float) -> np.ndarray:
    """``diffuse_reach`` under a flat face with no far side within t_max: the light's straight path
    d = t mu_t / mu_i (mu_t the view ray's cosine inside, mu_i the light's outside, as the distance map
    measures it), (1 - exp(-k t_max)) / k with k = sigma_t + sigma_tr mu_t / mu_i."""
    k = np.asarray(sigma_t, np.float64) + np.asarray(sigma_tr, np.float64) * mu_t / mu_i
    return -np.expm1(-k * t_max) / k


def chord_factor(t: ArrayLike, d: ArrayLike, sigma_t: ArrayLike, sigma_tr: ArrayLike, mu_t: float | np.ndarray,
                 mu_i: float | np.ndarray, t_full: float | None = None) -> np.ndarray:
    """The local multiple scattering's geometry factor (``qg_single``): ``diffuse_reach`` along the eye's
    actual chord (nodes t up to where it leaves, the light's paths d from the distance map) over a flat
    face's, ``flat_reach`` to the march's full depth TAU_MAX / min sigma_t. 1 under a flat face (the
    half-space law stays exact); above 1 on a ridge whose far side the light meets at a steeper angle
    (the eye's ray passes under it), below 1 where the medium ends behind a thin part. At most
    CHORD_FACTOR_MAX. ``t_full``: the march's full depth when sigma_t holds fewer channels than the
    medium's."""
    sigma_t = np.asarray(sigma_t, np.float64)
    full = flat_reach(sigma_t, sigma_tr, mu_t, mu_i, TAU_MAX / float(np.min(sigma_t)) if t_full is None else t_full)
    return np.clip(diffuse_reach(t, d, sigma_t, sigma_tr) / full, 0.0, CHORD_FACTOR_MAX)


def half_space(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, g: float, mu_i: float, mu_o: float, cos_theta: float,
               thickness: float = np.inf, eta: float = 1.0) -> np.ndarray:
    """Closed form of L^(1) / E under a flat face, light at cosine mu_i and eye at mu_o, as ``qg_single``
    models it: the view ray refracted to cosine mu_t inside (d(t) = t mu_t / mu_i, the light's path
    straight), T_o = 1 - F_r(mu_o) and T_i = 1 - F_0 (1 at eta = 1):
    T_o T_i / eta^2 alpha p(cos theta) mu_i / (mu_i + mu_t), times 1 - exp(-sigma_t H (1 / mu_t + 1 / mu_i))
    for a slab of thickness H (the view ray leaves at H / mu_t)."""

    sigma_s, sigma_t = coefficients(sigma_a, sigma_s_prime, g)
    mu_t = refracted_cosine(mu_o, eta)
    T = (1.0 - fresnel_dielectric(mu_o, eta)) * (1.0 - fresnel_dielectric(1.0, eta))
    kept = -np.expm1(-sigma_t * thickness * (1.0 / mu_t + 1.0 / mu_i)) if np.isfinite(thickness) else 1.0
    return T / eta**2 * sigma_s / sigma_t * hg_phase(cos_theta, g) * mu_i / (mu_i + mu_t) * kept


def single_albedo(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, g: float, eta: float, mu_i: ArrayLike,
                  n: int = 48) -> np.ndarray:
    """R_1(mu_i): the flux the single-scattering term sends out of a flat face, over the incident flux
    E mu_i, without the entry transmittance T_i; the model ``qg_single`` draws (view ray refracted,
    light path straight, T_o = 1 - F_r(mu_o), the exit's 1 / eta^2). Gauss-Legendre in mu_o, uniform in
    azimuth.
    At eta = 1 and g = 0: (alpha / 2) (1 - mu_i ln(1 + 1 / mu_i)). Returns (len(mu_i), 3)."""

    sigma_s, sigma_t = coefficients(sigma_a, sigma_s_prime, g)
    alpha = sigma_s / sigma_t
    x, w = np.polynomial.legendre.leggauss(n)
    mu_o, w_mu = 0.5 * (x + 1.0), 0.5 * w
    phi = (np.arange(2 * n) + 0.5) * np.pi / n
    mu_i = np.atleast_1d(np.asarray(mu_i, np.float64))
    sin_o = np.sqrt(1.0 - mu_o**2)
    mu_t = refracted_cosine(mu_o, eta)  # the refracted view ray inside
    sin_i = np.sqrt(1.0 - mu_i**2)
    # to_light . w_t, w_t the refracted view ray going in: (i, mu_o, phi)
    cos_theta = (-sin_i[:, None, None] * (sin_o / eta)[None, :, None] * np.cos(phi)[None, None, :]
                 - mu_i[:, None, None] * mu_t[None, :, None])
    p = hg_phase(cos_theta, g)
    T_o = 1.0 - fresnel_dielectric(mu_o, eta)
    integrand = (T_o * mu_o)[None, :, None] * p / (mu_i[:, None, None] + mu_t[None, :, None])
    flux = (integrand * w_mu[None, :, None]).sum(axis=1).mean(axis=1) * 2.0 * np.pi / eta**2
    return flux[:, None] * alpha[None, :]


def chandrasekhar_H(alpha: float, mu: ArrayLike, n: int = 64) -> np.ndarray:
    """Chandrasekhar's H function of isotropic scattering with albedo alpha <= 1:
    H(mu) = 1 + (alpha / 2) mu H(mu) int_0^1 H(mu') / (mu + mu') dmu', solved on Gauss-Legendre nodes by
    Newton's method (3-11 steps up to alpha = 0.99997, where the plain iteration took 2,500 and near
    alpha = 1 stopped unconverged), then evaluated at mu by the same equation (Nystrom)."""
    x, w = np.polynomial.legendre.leggauss(n)
    m, w = 0.5 * (x + 1.0), 0.5 * w
    C = 0.5 * alpha * m[:, None] * w[None, :] / (m[:, None] + m[None, :])
    h = np.ones(n)
    for _ in range(100):  # G(h) = h (1 - C h) - 1 = 0
        s = 1.0 - C @ h
        step = np.linalg.solve(np.diag(s) - h[:, None] * C, 1.0 - h * s)
        h = h + step
        if np.abs(step).max() < 1e-14 * np.abs(h).max():
            break
    mu = np.atleast_1d(np.asarray(mu, np.float64))
    return 1.0 / (1.0 - 0.5 * alpha * mu * ((w * h)[None, :] / (mu[:, None] + m[None, :])).sum(axis=1))


def plane_albedo(alpha: float, mu: ArrayLike) -> np.ndarray:
    """All the light a semi-infinite isotropic medium (index-matched) sends back of a beam at cosine mu,
    every order of scattering: 1 - H(mu) sqrt(1 - alpha) (Chandrasekhar; exact)."""
    return 1.0 - chandrasekhar_H(alpha, mu) * np.sqrt(1.0 - alpha)


def h_table(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, n: int = 33) -> np.ndarray:
    """H(mu_k) per channel at mu_k = k / (n - 1), (n, 3), for the albedo alpha' = sigma_s' / sigma_t'
    (similarity for g != 0): the table ``qg_single`` reads linearly for the local multiple scattering."""
    sigma_a = np.asarray(sigma_a, np.float64)
    sigma_s_prime = np.asarray(sigma_s_prime, np.float64)
    alpha_prime = sigma_s_prime / (sigma_a + sigma_s_prime)
    mu = np.arange(n) / (n - 1)
    return np.stack([chandrasekhar_H(a, mu) for a in alpha_prime], axis=1)


def multiple_half_space(alpha: float, mu_i: ArrayLike, mu_o: ArrayLike, eta: float = 1.0) -> np.ndarray | float:
    """L_ms / E: the radiance a semi-infinite isotropic medium sends towards mu_o after two or more
    scatterings, per unit normal irradiance of a beam at cosine mu_i; Chandrasekhar's diffuse reflection
    less its first order. Index-matched:

        L / E = alpha mu_i (H(mu_i) H(mu_o) - 1) / (4 pi (mu_i + mu_o)).

    Not Lambertian: at grazing light and grazing view it is 1.35 (alpha 0.96) to 1.7 (0.68) times the
    Lambertian radiance R_ms mu_i / pi of the same exitance, and it is flux-exact: over the hemisphere
    it sends out plane_albedo - R_1 of the light that enters. At eta != 1 (``qg_single``'s model) the
    same at the refracted cosines mu_i,t and mu_o,t, between the Fresnel transmittances and with the
    exit's 1 / eta^2: the light entering per unit area is still T_i E mu_i, so the numerator keeps mu_i,
    T_o T_i alpha mu_i (H(mu_i,t) H(mu_o,t) - 1) / (4 pi eta^2 (mu_i,t + mu_o,t)). That is the light's
    first escape: the index-matched H has no internal reflection, which sends light back in to leave
    later (``boundary_gain``: the factor the pass draws it with)."""

    mu_i = np.asarray(mu_i, np.float64)
    mu_o = np.asarray(mu_o, np.float64)
    mu_it, mu_ot = refracted_cosine(mu_i, eta), refracted_cosine(mu_o, eta)
    H_i = chandrasekhar_H(alpha, mu_it.ravel()).reshape(mu_it.shape)
    H_o = chandrasekhar_H(alpha, mu_ot.ravel()).reshape(mu_ot.shape)
    T = (1.0 - fresnel_dielectric(mu_o, eta)) * (1.0 - fresnel_dielectric(mu_i, eta)) if eta != 1.0 else 1.0
    return T * alpha * mu_i * (H_i * H_o - 1.0) / (4.0 * np.pi * eta**2 * (mu_it + mu_ot))


def exitance_loss(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float) -> np.ndarray:
    """What a lit node's diffusion exitance gives up per unit q entering once ``qg_single`` draws the
    surface's own response to the light entering it (single scattering and the local multiple
    scattering of ``multiple_half_space``), (1, 3): all of it, R, the flat-face reflectance of the
    diffusion's continuous model (``diffusion.slab_reflectance``; the graph's slab follows it within 3 %
    where its surface links are longer than a mean free path, and reflects up to 18 % more where they
    are shorter and the source sits at the inner node).

    Near where light enters, the diffusion's exitance R q stands for every order of scattering
    together (index-matched, a random walk on marble at normal incidence reflects 0.153 after one
    scattering and 0.761 after more; the diffusion 0.915, the dipole 0.914), with the wrong angular
    law: Lambertian, where Chandrasekhar's grows towards grazing light and view. The surface term
    draws that response exactly for a flat face, so B - R q leaves the light that entered elsewhere
    and crossed the medium (q = 0 where it leaves: all of the diffusion kept). Approximations: the
    table is the object's uniform material (veins and painted blur, which change kappa and mu per
    node, are not in it); at eta != 1 the surface term is the index-matched one at the refracted
    cosines, between Fresnel transmittances."""

    R = slab_reflectance(np.asarray(sigma_a, np.float64), np.asarray(sigma_s_prime, np.float64), eta)
    return R[None, :]


def uniform_light_table(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, n: int = 33) -> np.ndarray:
    """The factor w(mu_o) per channel at mu_o = j / (n - 1), (n, 3), on the Lambertian F_t / pi R q_world
    that the display draws for the world's light entering a flat face (read linearly by ``qg_display``).

    Index-matched, a half-space under uniform light L_w sends L_w (1 - sqrt(1 - alpha') H(mu_o)) towards
    mu_o, every order of scattering together (Chandrasekhar; isotropic), where the diffusion sends
    R q / pi = R L_w at every angle: w = (1 - sqrt(1 - alpha') H(mu_o)) / R, exact there (skin1: 0.99 /
    0.96 / 0.87 at normal view, 1.27-1.92 at grazing; marble 0.996 and 1.06). At eta != 1 the
    boundary reflects light back to scatter again, which evens it out: w = 1 + (w_1(mu_t) - 1) / A at the
    refracted cosine, A = (1 + F_dr) / (1 - F_dr) the diffusion's own internal reflection (the P1 radiance
    at the boundary, phi (1 + 3 mu / (2 A)), has 1 / A of the index-matched anisotropy): a model,
    continuous in eta, not judged against exact transport (the exact-transport bench is index-matched)."""

    sigma_a = np.asarray(sigma_a, np.float64)
    sigma_s_prime = np.asarray(sigma_s_prime, np.float64)
    alpha_prime = sigma_s_prime / (sigma_a + sigma_s_prime)
    R_1 = slab_reflectance(sigma_a, sigma_s_prime, 1.0)
    A = float(internal_reflection(eta))
    mu_t = refracted_cosine(np.arange(n) / (n - 1), eta)
    w_1 = np.stack([(1.0 - np.sqrt(1.0 - a) * chandrasekhar_H(a, mu_t)) / R for a, R in zip(alpha_prime, R_1)],
                   axis=1)
    return 1.0 + (w_1 - 1.0) / A

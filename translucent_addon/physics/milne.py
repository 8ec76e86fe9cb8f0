"""The angular law of the light a diffusion carries to the surface from elsewhere. Pure NumPy.

A diffusion solution gives the exitance B of a surface point; Wang et al. 2010 (Eq. 7), as the dipole
methods, draw it Lambertian, L_o = F_t / pi B. Light that has crossed the medium does not leave that way.
Far from where it entered, transport settles into the medium's diffusion mode, exp(-k tau) in optical
depth tau, with k the root of

    (alpha / (2 k)) ln((1 + k) / (1 - k)) = 1        (isotropic scattering, albedo alpha)

(k^2 -> 3 (1 - alpha) as alpha -> 1: the diffusion's sigma_tr / sigma_t), and a half-space whose light
comes from deep inside sends it out as Chandrasekhar's Milne solution,

    L(mu) proportional to H(mu) / (1 - k mu),

brighter than Lambertian towards the normal (1.22 times at normal for marble, 1.5 for albedo 0.84) and
darker at grazing (0.43 for marble). A random walk through 3-5 mm of marble and skin (its scattered
light) follows this law within a few per cent where transport is diffusive (``tests/test_physics.py``).
Where light enters, the surface term (``single_scattering``) draws the response exactly and the
diffusion gives up its own there, so what the display draws from the diffusion is this far light.

For g != 0 the law takes the reduced albedo alpha' = sigma_s' / sigma_t' (similarity, as the H table).
At eta != 1 (``outside_table``) the law's anisotropy is divided by the diffusion's internal reflection
A, taken at the refracted cosine behind F_t(mu_o), and scaled so that the light leaving over the
hemisphere is what the Lambertian F_t / pi B sends: light reflected back at the boundary and scattered
again leaves more evenly (the P1 radiance at the boundary, phi (1 + 3 mu / (2 A)), has 1 / A of the
index-matched anisotropy). This is a model, not judged against exact transport here (the exact-transport
bench is index-matched).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from .dipole import A as internal_reflection
from .fresnel import fresnel_dielectric
from .single_scattering import chandrasekhar_H, refracted_cosine

K_MAX = 0.99  # the diffusion mode's k at most (alpha 0.37): below, nothing diffuses far anyway


def diffusion_eigenvalue(alpha: float) -> float:
    """k in (0, 1): the decay exp(-k sigma_t z) of isotropic transport far from sources (the root of
    alpha artanh(k) / k = 1), at most K_MAX; 0 without absorption."""
    alpha = float(alpha)
    if not 0.0 < alpha <= 1.0:
        raise ValueError(f"albedo {alpha} must lie in (0, 1]")
    if 1.0 - alpha < 1e-9:
        return float(np.sqrt(3.0 * (1.0 - alpha)))  # alpha artanh(k) / k = alpha (1 + k^2 / 3 + ...)
    k = brentq(lambda k: alpha * np.arctanh(k) / k - 1.0, 1e-12, 1.0 - 1e-15, xtol=1e-14)
    return min(k, K_MAX)


def exit_law(alpha: float, mu) -> np.ndarray:
    """Radiance of the far light leaving an index-matched half-space at cosine mu over the Lambertian
    radiance of the same exitance: H(mu) / (1 - k mu), normalised so that 2 int_0^1 f(mu) mu dmu = 1."""
    k = diffusion_eigenvalue(alpha)
    x, w = np.polynomial.legendre.leggauss(64)
    m, w = 0.5 * (x + 1.0), 0.5 * w
    norm = 2.0 * np.sum(w * m * chandrasekhar_H(alpha, m) / (1.0 - k * m))
    mu = np.asarray(mu, np.float64)
    return (chandrasekhar_H(alpha, mu.ravel()) / (1.0 - k * mu.ravel())).reshape(mu.shape) / norm


def outside_table(law, eta: float, n: int = 33) -> np.ndarray:
    """An index-matched angular law f(mu) (a function of the inside cosine, ratio to Lambert's, shape
    only) as the factor on the Lambertian F_t(mu_o) / pi B at mu_o = j / (n - 1), (n,): at eta != 1 the
    anisotropic part is divided by the diffusion's internal reflection A = (1 + F_dr) / (1 - F_dr), as
    its own boundary flattens the outgoing radiance (P1 at the boundary: phi (1 + 3 mu / (2 A))), taken
    at the refracted cosine, and scaled so that int F_t f mu dmu = int F_t mu dmu: the law moves light
    between angles, the exitance drawn stays B."""
    A = float(internal_reflection(eta))
    x, w = np.polynomial.legendre.leggauss(64)
    m, w = 0.5 * (x + 1.0), 0.5 * w
    F_t = 1.0 - fresnel_dielectric(m, eta) if eta != 1.0 else np.ones_like(m)

    def inside(mu_o):
        return 1.0 + (law(refracted_cosine(mu_o, eta)) - 1.0) / A

    scale = np.sum(w * F_t * m) / np.sum(w * F_t * inside(m) * m)
    return scale * inside(np.arange(n) / (n - 1))


def exit_law_table(sigma_a, sigma_s_prime, eta: float, n: int = 33) -> np.ndarray:
    """The Milne law's factor per channel on the Lambertian display of the far light, (n, 3), read
    linearly by ``qg_display`` (``outside_table``)."""
    sigma_a = np.asarray(sigma_a, np.float64)
    sigma_s_prime = np.asarray(sigma_s_prime, np.float64)
    alpha_prime = sigma_s_prime / (sigma_a + sigma_s_prime)
    return np.stack([outside_table(lambda mu, a=a: exit_law(a, mu), eta, n) for a in alpha_prime], axis=1)

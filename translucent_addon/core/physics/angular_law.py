"""How the subsurface light a surface sends back depends on the angles it arrives and leaves at. Pure.

IMAGE_SPACE and TEXTURE_SPACE draw L(x_o, w_o) = F_t(w_o) / pi R(r) Phi_in (Jensen 2001 Eq. 4): the profile R is
the same for light arriving at any angle, and what leaves is Lambertian. The exact profile's R
(``exact_profile``) is tabulated for light arriving cosine-weighted, so its total is right on average; but a
half-space of exact transport sends back more of a grazing beam than of a normal one (it enters shallower), and
by reciprocity it sends its diffuse light out more at grazing angles than a Lambertian surface. For
isotropic scattering with an index-matched boundary both are Chandrasekhar's closed form: a beam at cosine mu
comes back as

    A(mu) = 1 - sqrt(1 - alpha') H(mu)            (``single_scattering.plane_albedo``)

where H is Chandrasekhar's H function. For skin's blue (alpha' 0.68) A is 0.81 of its cosine-weighted mean at
normal incidence and 1.38 at mu = 0.2; for marble (alpha' 0.999) within 1 % of it everywhere. Drawn with the
Lambertian law, skin lit and seen from the front came out 7 % too bright in blue and too dark at its rims.

The methods therefore weigh the power entering at cosine mu_i by a(mu_i) and the light leaving towards
cosine mu_o by a(mu_o), with

    a(mu) = A(mu_t) / <A(mu_t)>,   <f> = int f(mu_t) F_t(mu) mu dmu / int F_t(mu) mu dmu,

mu_t the refracted cosine (Snell) and F_t the Fresnel transmittance. The same a on both sides is
reciprocity: the light leaving towards mu_o under diffuse light is what a beam arriving from mu_o sends
back. Because <a> = 1 over the cosine-weighted light that enters, the profile's tabulated total stays what
it was under diffuse light (the world, the profile's Monte Carlo) and a beam at mu gets exactly A(mu) at
eta = 1. At eta > 1 the index-matched A at the refracted cosine is an approximation: refraction bends
every entering beam towards the normal, so the angular law is flatter (tests/test_angular_law.py
measures it against Monte Carlo with Fresnel boundaries).

What this does not carry is the part of exact transport that is not a product of a function of mu_i and one
of mu_o: single scattering's 1 / (mu_i + mu_o), which lifts grazing light seen at grazing angles (2.4 against
this law's 1.9 for skin's blue at mu_i = mu_o = 0.2). Light that travels far before it leaves also leaves
with a shape nearer Milne's H(mu_o) than A(mu_o); for the high albedos where that matters (marble) both are
near 1. The papers' dipole (profile DIPOLE) keeps its Lambertian law (``dipole.angular_table``).
"""
from __future__ import annotations

import functools

import numpy as np
from numpy.typing import ArrayLike

from .fresnel import fresnel_dielectric
from .single_scattering import chandrasekhar_H, refracted_cosine

# Table nodes: texel k at mu = (k + 0.5) / n (the illumination pass's cosine tables). IMAGE_SPACE keeps
# SAMPLES per slot in its materials block (common/structs.glsl): keep them in step.
SAMPLES = 16
ALBEDO_FLOOR = 1e-4  # below it A(mu) / <A> is its single-scattering limit to 1e-4


def nodes(n: int = SAMPLES) -> np.ndarray:
    """The table's cosines, texel centres (k + 0.5) / n."""
    return (np.arange(n) + 0.5) / n


@functools.lru_cache(maxsize=256)
def _law(alpha_prime: float, eta: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(Gauss-Legendre cosines on [0, 1], A at their refracted cosines, <A>) of one channel."""
    x, w = np.polynomial.legendre.leggauss(96)
    mu, w = 0.5 * (x + 1.0), 0.5 * w
    A = 1.0 - np.sqrt(1.0 - alpha_prime) * chandrasekhar_H(alpha_prime, refracted_cosine(mu, eta))
    weight = w * (1.0 - fresnel_dielectric(mu, eta)) * mu
    return mu, A, float((A * weight).sum() / weight.sum())


def factor(alpha_prime: float, eta: float, mu: ArrayLike) -> np.ndarray:
    """a(mu) of one channel of albedo alpha' at relative index eta, for cosines mu in [0, 1] (module docstring)."""
    mu = np.clip(np.asarray(mu, np.float64), 0.0, 1.0)
    alpha_prime = float(np.clip(alpha_prime, ALBEDO_FLOOR, 1.0))
    if alpha_prime >= 1.0:
        return np.ones_like(mu)  # a conservative half-space sends every beam back: A = 1 at every angle
    eta = float(max(eta, 1.0))
    _, _, mean = _law(round(alpha_prime, 12), round(eta, 9))
    A = 1.0 - np.sqrt(1.0 - alpha_prime) * chandrasekhar_H(alpha_prime, refracted_cosine(mu.ravel(), eta))
    return (A / mean).reshape(mu.shape)


def table(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, n: int = SAMPLES) -> np.ndarray:
    """a at ``nodes(n)`` per RGB channel, (n, 3) float64, for the reduced coefficients (per mm). Cached per
    medium: H for a high albedo takes tens of milliseconds, and every frame asks."""
    return _table(*_channels(sigma_a, sigma_s_prime), float(eta), int(n)).copy()


def _channels(sigma_a: ArrayLike, sigma_s_prime: ArrayLike) -> tuple[tuple, tuple]:
    return (tuple(float(x) for x in np.broadcast_to(np.asarray(sigma_a, np.float64), (3,))),
            tuple(float(x) for x in np.broadcast_to(np.asarray(sigma_s_prime, np.float64), (3,))))


@functools.lru_cache(maxsize=256)
def _table(sigma_a: tuple, sigma_s_prime: tuple, eta: float, n: int) -> np.ndarray:
    sigma_a, sigma_s_prime = np.array(sigma_a), np.array(sigma_s_prime)
    sigma_t = sigma_a + sigma_s_prime
    alpha_prime = np.divide(sigma_s_prime, sigma_t, out=np.zeros(3), where=sigma_t > 0)
    mu = nodes(n)
    return np.stack([factor(a, eta, mu) for a in alpha_prime], axis=1)


def lookup(table_: np.ndarray, mu: ArrayLike) -> np.ndarray:
    """CPU twin of the shaders' read (``cosine_lerp``): (..., 3) at cosines mu (...), linear between texel
    centres, clamped to the end texels."""
    n = len(table_)
    u = np.clip(np.asarray(mu, np.float64) * n - 0.5, 0.0, n - 1.0)
    k = np.minimum(np.floor(u).astype(int), n - 1)
    k1 = np.minimum(k + 1, n - 1)
    f = (u - k)[..., None]
    return (1.0 - f) * table_[k] + f * table_[k1]


# -- Light that crossed a thin part --------------------------------------------------------------------------
# Light that reaches the far face of a slab has diffused there in the medium's slowest-decaying mode,
# e^{-z / nu_0}, and leaves it as the asymptotic solution does: the radiance towards cosine mu is
# H(mu) / (1 - mu / nu_0) (the asymptotic mode's emergent law; Milne's H(mu) when nothing is absorbed),
# limb-darkened where a(mu) is limb-brightened. Measured by Monte Carlo through slabs 6 to 12 mean free
# paths thick at alpha' 0.9-0.999, that law is within 1.3 % of the light leaving from mu = 0.1 to 1
# index-matched, within 7.7 % at eta 1.3 with the refracted cosine
# (1.22-1.38 times the Lambertian radiance near the normal, 0.41-0.53 at grazing): tests/test_angular_law.py.
# IMAGE_SPACE draws the light of its thin-part pairs (``slab_through``, the same ramp) leaving by this law in
# place of a(mu_o). H is Hapke's closed form (within 0.75 % of Chandrasekhar's), evaluated in the splat shader.

K_MAX = 0.85  # the largest k = 1 / nu_0 the emergent law takes (alpha' 0.68; ``through_constants``)


def diffusion_k(alpha_prime: ArrayLike) -> np.ndarray:
    """k = 1 / nu_0, the decay of the slowest diffusion mode per mean free path: alpha' artanh(k) / k = 1
    (isotropic scattering; k ~ sqrt(3 (1 - alpha')) near alpha' = 1, k -> 1 as alpha' -> 0). Bisection."""
    alpha_prime = np.clip(np.asarray(alpha_prime, np.float64), 0.0, 1.0)
    lo, hi = np.zeros_like(alpha_prime), np.ones_like(alpha_prime)
    for _ in range(60):
        k = np.clip(0.5 * (lo + hi), 1e-300, 1.0 - 1e-15)
        below = alpha_prime * np.arctanh(k) / k < 1.0
        lo, hi = np.where(below, k, lo), np.where(below, hi, k)
    return 0.5 * (lo + hi)


def H_approx(gamma: ArrayLike, x: ArrayLike) -> np.ndarray:
    """Hapke's (2002) closed form of Chandrasekhar's H for gamma = sqrt(1 - alpha'), within 0.75 % of it:
    1 / (1 - (1 - gamma) x (r_0 + (1 - r_0 / 2 - r_0 x) ln((1 + x) / x))), r_0 = (1 - gamma) / (1 + gamma)."""
    gamma = np.asarray(gamma, np.float64)
    x = np.maximum(np.asarray(x, np.float64), 1e-6)
    r0 = (1.0 - gamma) / (1.0 + gamma)
    return 1.0 / (1.0 - (1.0 - gamma) * x * (r0 + (1.0 - 0.5 * r0 - r0 * x) * np.log((1.0 + x) / x)))


def _emergent_shape(gamma: np.ndarray, k: np.ndarray, mu_t: np.ndarray) -> np.ndarray:
    return H_approx(gamma, mu_t) / (1.0 - k * mu_t)


def through_constants(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float) -> np.ndarray:
    """(3, 3): rows gamma, k and the normalisation 1 / <H / (1 - k mu_t)> per RGB channel (the mean over light
    leaving through the Fresnel boundary, as for a), what the splat shader needs for ``through_exit``. Cached
    per medium."""
    return _through_constants(*_channels(sigma_a, sigma_s_prime), float(eta)).copy()


@functools.lru_cache(maxsize=256)
def _through_constants(sigma_a: tuple, sigma_s_prime: tuple, eta: float) -> np.ndarray:
    sigma_a, sigma_s_prime = np.array(sigma_a), np.array(sigma_s_prime)
    sigma_t = sigma_a + sigma_s_prime
    alpha_prime = np.clip(np.divide(sigma_s_prime, sigma_t, out=np.zeros(3), where=sigma_t > 0), ALBEDO_FLOOR, 1.0)
    # Below alpha' ~ 0.68 the slowest mode dies within a mean free path (k -> 1: 1 / (1 - k mu) would reach 1e14
    # at alpha' = 1e-4, inf in a shader's float) and diffusion, which the thin-part factor rests on, no longer
    # holds; such media send next to nothing through a thin part. Their law is held at skin blue's.
    gamma, k = np.sqrt(1.0 - alpha_prime), np.minimum(diffusion_k(alpha_prime), K_MAX)
    x, w = np.polynomial.legendre.leggauss(96)
    mu, w = 0.5 * (x + 1.0), 0.5 * w
    eta = float(max(eta, 1.0))
    weight = w * (1.0 - fresnel_dielectric(mu, eta)) * mu
    shape = _emergent_shape(gamma[None, :], k[None, :], refracted_cosine(mu, eta)[:, None])
    mean = (shape * weight[:, None]).sum(axis=0) / weight.sum()
    return np.stack([gamma, k, 1.0 / mean])


def through_exit(constants: np.ndarray, eta: float, mu: ArrayLike) -> np.ndarray:
    """M(mu) (..., 3): how the light that crossed a thin part leaves towards cosine mu, over the Lambertian law,
    mean 1 over the light leaving (CPU twin of ``through_exit`` in common/angular_law.glsl)."""
    gamma, k, inv_mean = constants
    mu_t = refracted_cosine(np.clip(np.asarray(mu, np.float64), 0.0, 1.0), float(max(eta, 1.0)))[..., None]
    return _emergent_shape(gamma, k, mu_t) * inv_mean


def through_exit_table(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, n: int = SAMPLES) -> np.ndarray:
    """M at ``nodes(n)`` per RGB channel (n, 3): ``through_exit`` on the angular law's grid (TEXTURE_SPACE's display
    reads it as it reads ``table``)."""
    return through_exit(through_constants(sigma_a, sigma_s_prime, eta), eta, nodes(n))


def through_exit_ratio(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, mu: ArrayLike) -> np.ndarray:
    """M(mu) / a(mu) (..., 3): what the light of a thin-part pair is weighed by where the angular law of the light
    leaving was applied to all of it (CPU twin of ``through_exit_ratio`` in common/angular_law.glsl)."""
    return (through_exit(through_constants(sigma_a, sigma_s_prime, eta), eta, mu)
            / lookup(table(sigma_a, sigma_s_prime, eta), mu))

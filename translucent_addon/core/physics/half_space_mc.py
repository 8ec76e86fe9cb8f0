"""Exact transport in a semi-infinite medium by Monte Carlo: the ground truth the profiles are tabulated
from and tested against. Pure NumPy, vectorised over photons.

The medium is isotropic scattering at the reduced coefficients (similarity: sigma_s', sigma_a), as the
Cycles twin and the dipole use them. Units are mean free paths (sigma_t' = 1), so a profile of any medium
is R(r) = sigma_t'^2 R^(r sigma_t'; alpha') (``scaled``). Light arrives at the origin from a cosine-weighted
direction: for a convex object under a distant light, the power falling on the lit side at incidence
theta is spread as cos(theta) sin(theta), the same law. It enters with the Fresnel transmittance,
refracts, scatters, is reflected internally with Fresnel's probability at the boundary, and leaves.

What is tallied is what our renderers multiply: they draw L(x_o, w_o) = F_t(w_o) / pi R(r) Phi_in (Jensen
2001 Eq. 4 with Phi_in the power entering), which sends out R(r) Phi_in (1 - F_dr,ext) per unit area. So
R(r) is the exitance per unit power entering, over the hemispherical transmittance 1 - F_dr,ext
(``fresnel.hemispherical_transmittance``); at eta = 1 simply the exitance.

Absorption is a weight alpha'^n after n scatterings, so one run at alpha' = 1 (``trace``) gives every
albedo by reweighting its photons (``profile``); ``trace`` with an albedo instead absorbs as it goes
(Russian roulette), the independent estimator the tests use.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import ArrayLike

from .fresnel import fresnel_dielectric, hemispherical_transmittance


@dataclasses.dataclass(frozen=True)
class Escapes:
    """Photons that left the medium: where (radius in mean free paths), after how many scatterings, with
    what weight (the entry and exit transmittances are in the probabilities, so weights are the albedo's)."""

    rho: np.ndarray  # (k,) exit distance from the entry point, mean free paths
    n: np.ndarray  # (k,) scatterings before leaving (>= 1)
    weight: np.ndarray  # (k,) alpha'^n for ``trace(albedo=...)``, 1 for the unabsorbed run
    albedo: np.ndarray | None  # (k,) per-photon albedo when traced with several, else None
    launched: int  # photons launched (the normalisation: every photon carries 1 / launched of the power)
    entered: float  # share of the launched power that entered the medium (1 - F_dr,ext)
    truncated: int  # photons still inside after max_scatterings
    # (k,) sin(theta_o) cos(psi) outside: the exit direction's component along the surface away from the entry
    # point (psi the azimuth from that direction), which ``lean`` averages
    outward: np.ndarray | None = None


def _horizontal(rng: np.random.Generator, mu: np.ndarray) -> np.ndarray:
    """The horizontal part (k, 2) of directions at cosines mu to the normal, uniform in azimuth."""
    phi = 2.0 * np.pi * rng.random(len(mu))
    s = np.sqrt(np.maximum(0.0, 1.0 - mu * mu))
    return np.stack([s * np.cos(phi), s * np.sin(phi)], axis=1)


def _isotropic(rng: np.random.Generator, k: int) -> tuple[np.ndarray, np.ndarray]:
    """k isotropic directions: (horizontal part, mu = cos to the inward normal)."""
    mu = 2.0 * rng.random(k) - 1.0
    return _horizontal(rng, mu), mu


def trace(photons: int, eta: float = 1.0, albedo: ArrayLike | None = None, seed: int = 0,
          max_scatterings: int = 400_000, batch: int = 400_000, incidence: float | None = None) -> Escapes:
    """Trace ``photons`` into the half-space z > 0 (sigma_t' = 1, isotropic scattering).

    albedo None: no absorption, every photon is followed until it leaves or has scattered max_scatterings
    times (``profile`` weighs it alpha'^n afterwards). albedo a scalar or one value per photon: absorbed as
    it goes (survival alpha' per scattering, Russian roulette below weight 1e-3), for an independent check.
    Photons refused at the entrance by Fresnel reflection are launched but never enter (the external
    specular reflection is not subsurface light). ``incidence``: every photon arrives at that cosine (a
    beam) instead of cosine-weighted.
    """
    rng = np.random.default_rng(seed)
    per_photon = None if albedo is None else np.broadcast_to(np.asarray(albedo, np.float64), (photons,))
    parts = []
    launched_entered = 0
    truncated = 0
    for start in range(0, photons, batch):
        k = min(batch, photons - start)
        # Cosine-weighted incidence (Malley) or a beam, refracted in; Fresnel decides whether it enters.
        mu_i = np.sqrt(rng.random(k)) if incidence is None else np.full(k, float(incidence))
        enters = rng.random(k) >= fresnel_dielectric(mu_i, eta)
        idx = np.flatnonzero(enters)
        launched_entered += len(idx)
        mu_i = mu_i[idx]
        mu = np.sqrt(1.0 - (1.0 - mu_i * mu_i) / (eta * eta))  # Snell, inward cosine
        dxy = _horizontal(rng, mu)
        xy = np.zeros((len(idx), 2))
        z = np.zeros(len(idx))
        n = np.zeros(len(idx), np.int64)
        w = np.ones(len(idx))
        a = None if per_photon is None else per_photon[start:start + k][idx]
        out_rho, out_n, out_w, out_a, out_o = [], [], [], [], []
        while len(z):
            # Free flight; a path that crosses z = 0 meets the boundary there.
            ell = -np.log1p(-rng.random(len(z)))
            z_new = z + ell * mu
            crosses = z_new < 0.0
            t = np.where(crosses, z / np.where(crosses, -mu, 1.0), ell)
            xy += dxy * t[:, None]
            z = np.where(crosses, 0.0, z_new)
            keep = np.ones(len(z), bool)
            if crosses.any():
                c = np.flatnonzero(crosses)
                # Fresnel at the inside of the boundary: reflected (the rest of the flight mirrored, which the
                # memoryless free path allows) or out.
                if eta != 1.0:
                    reflect = rng.random(len(c)) < fresnel_dielectric(-mu[c], 1.0 / eta)
                else:
                    reflect = np.zeros(len(c), bool)
                r = c[reflect]
                rest = ell[r] - t[r]
                mu[r] = -mu[r]
                xy[r] += dxy[r] * rest[:, None]
                z[r] = rest * mu[r]
                gone = c[~reflect]
                rho = np.hypot(xy[gone, 0], xy[gone, 1])
                out_rho.append(rho)
                # Snell: the horizontal part of the direction is eta times longer outside.
                out_o.append(eta * (xy[gone] * dxy[gone]).sum(axis=1) / np.maximum(rho, 1e-300))
                out_n.append(n[gone])
                out_w.append(w[gone])
                if a is not None:
                    out_a.append(a[gone])
                keep[gone] = False
            # Collide: every photon still inside scatters isotropically (those reflected at the boundary at the
            # end of their mirrored flight).
            sc = np.flatnonzero(keep)
            n[sc] += 1
            dxy[sc], mu[sc] = _isotropic(rng, len(sc))
            if a is not None:
                w[sc] *= a[sc]
                low = w < 1e-3
                if low.any():  # Russian roulette: survive with probability 10 w at weight w / (10 w)
                    survive = rng.random(len(w)) < 10.0 * w
                    dead = low & ~survive
                    w = np.where(low & survive, 0.1, w)
                    keep &= ~dead
            if n.size and n.max() >= max_scatterings:
                over = n >= max_scatterings
                truncated += int((over & keep).sum())
                keep &= ~over
            xy, dxy, z, mu, n, w = xy[keep], dxy[keep], z[keep], mu[keep], n[keep], w[keep]
            if a is not None:
                a = a[keep]
        parts.append((np.concatenate(out_rho) if out_rho else np.zeros(0),
                      np.concatenate(out_n) if out_n else np.zeros(0, np.int64),
                      np.concatenate(out_w) if out_w else np.zeros(0),
                      np.concatenate(out_a) if out_a else None,
                      np.concatenate(out_o) if out_o else np.zeros(0)))
    rho = np.concatenate([p[0] for p in parts])
    return Escapes(rho, np.concatenate([p[1] for p in parts]), np.concatenate([p[2] for p in parts]),
                   None if per_photon is None else np.concatenate([p[3] for p in parts]),
                   photons, launched_entered / photons, truncated, np.concatenate([p[4] for p in parts]))


def normalisation(escapes: Escapes, eta: float) -> float:
    """Per photon launched -> R's units: per unit power entering, over 1 - F_dr,ext (module docstring)."""
    return 1.0 / (escapes.launched * escapes.entered * hemispherical_transmittance(eta))


def total(escapes: Escapes, eta: float, albedo: float | None = None) -> float:
    """Total reflectance int R 2 pi r dr of the traced medium (or of ``albedo`` by reweighting an unabsorbed run)."""
    w = weights(escapes, albedo)
    return float(w.sum() * normalisation(escapes, eta))


def weights(escapes: Escapes, albedo: float | None = None, per_albedo: bool = False) -> np.ndarray:
    """Each escape's weight: as traced, or ``albedo``'s by reweighting an unabsorbed run, alpha'^n (``per_albedo``:
    alpha'^(n-1), over the first scattering's albedo, finite at alpha' = 0)."""
    return escapes.weight if albedo is None else np.power(albedo, escapes.n - (1 if per_albedo else 0))


def profile(escapes: Escapes, eta: float, edges: ArrayLike, albedo: float | None = None,
            per_albedo: bool = False) -> np.ndarray:
    """R^ averaged over the annuli between ``edges`` (mean free paths): per unit area, in units of sigma_t'^2.
    ``per_albedo``: R^ / alpha' (weights alpha'^(n-1)), finite at alpha' = 0 (the first order alone)."""
    edges = np.asarray(edges, np.float64)
    w = weights(escapes, albedo, per_albedo)
    power, _ = np.histogram(escapes.rho, bins=edges, weights=w)
    return power * normalisation(escapes, eta) / (np.pi * np.diff(edges**2))


def lean(escapes: Escapes, edges: ArrayLike, albedo: float | None = None, per_albedo: bool = False) -> np.ndarray:
    """beta per annulus between ``edges`` (mean free paths): how the light leaving there leans away from where it
    entered. Written L(w_o) = L_0 (1 + beta sin(theta_o) cos(psi)) about the Lambertian L_0 (psi the azimuth from
    the direction away from the entry point), the exiting power's mean of sin(theta_o) cos(psi) is beta / 4
    (int sin^2 cos^2(psi) cos dw = pi / 4 over int cos dw = pi), so beta = 4 <sin(theta_o) cos(psi)>, weighted
    as ``profile`` (or by ``albedo``'s reweighting; ``per_albedo``: alpha'^(n-1), the same ratio and defined at
    alpha' = 0, the first order's). 0 where no photon left."""
    edges = np.asarray(edges, np.float64)
    w = weights(escapes, albedo, per_albedo)
    power, _ = np.histogram(escapes.rho, bins=edges, weights=w)
    moment, _ = np.histogram(escapes.rho, bins=edges, weights=w * escapes.outward)
    return np.where(power > 0, 4.0 * moment / np.where(power > 0, power, 1.0), 0.0)

"""The exact-transport profile (core/physics/exact_profile.py) against Monte Carlo of a half-space.

The Monte Carlo itself is checked against Chandrasekhar's closed form; the table (tabulated by reweighting
one unabsorbed run per eta) against an independent absorbing run at each preset's own albedos.
"""
from __future__ import annotations

import numpy as np
import pytest

from translucent_addon.core.physics import dipole, exact_profile, half_space_mc
from translucent_addon.core.physics.fresnel import hemispherical_transmittance
from translucent_addon.core.physics.presets import load_presets
from translucent_addon.core.physics.quadrature import trapezoid
from translucent_addon.core.physics.single_scattering import plane_albedo


def spherical_albedo(alpha: float) -> float:
    """Chandrasekhar: 2 int_0^1 (1 - H(mu) sqrt(1 - alpha)) mu dmu, an isotropic half-space under diffuse light."""
    x, w = np.polynomial.legendre.leggauss(64)
    mu, w = 0.5 * (x + 1.0), 0.5 * w
    return float(2.0 * np.sum(plane_albedo(alpha, mu) * mu * w))


def _standard_error(escapes, weights) -> float:
    """Standard error of the total: photons that did not come back contribute 0."""
    n = escapes.launched
    mean = weights.sum() / n
    spread = np.sqrt(max((weights**2).sum() / n - mean**2, 0.0) / n)
    return float(spread * n * half_space_mc.normalisation(escapes, 1.0))


@pytest.mark.parametrize("alpha", [0.3, 0.8, 0.98])
def test_monte_carlo_total_is_chandrasekhars_at_eta_1(alpha):
    """Both estimators (absorbing, and unabsorbed reweighted) within 4 standard errors of the closed form,
    the standard errors under 1 % of it."""
    exact = spherical_albedo(alpha)
    absorbing = half_space_mc.trace(400_000, 1.0, albedo=alpha, seed=5)
    unabsorbed = half_space_mc.trace(60_000, 1.0, seed=6, max_scatterings=20_000)
    for e, w in ((absorbing, absorbing.weight), (unabsorbed, np.power(alpha, unabsorbed.n))):
        error = _standard_error(e, w)
        assert error < 1e-2 * exact
        assert abs(w.sum() * half_space_mc.normalisation(e, 1.0) - exact) < 4 * error


def test_monte_carlo_conserves_energy_without_absorption():
    """alpha' = 1: every photon that entered comes back out (all but those still inside at the cap)."""
    e = half_space_mc.trace(20_000, 1.3, seed=7, max_scatterings=50_000)
    left = e.truncated / (e.launched * e.entered)
    assert left < 0.02  # the heavy tail of path lengths: 1.1 % still inside after 50,000 scatterings
    assert half_space_mc.total(e, 1.3) * hemispherical_transmittance(1.3) == pytest.approx(1.0 - left, abs=1e-9)


def _media():
    """(name, channel, alpha', sigma_t') of every preset channel."""
    out = []
    for name, m in sorted(load_presets().items()):
        for c in range(3):
            st = m.sigma_a[c] + m.sigma_s_prime[c]
            out.append((name, "RGB"[c], m.sigma_s_prime[c] / st, st))
    return out


ANNULI = 6  # equal shares of the inner 95 % of the energy (each collects ~1 % MC noise)


@pytest.mark.parametrize("eta", [1.0, 1.3])
def test_table_matches_monte_carlo_for_every_preset(eta):
    """Total within 2 % and the profile within 5 % over annuli holding the inner 95 % of the light, for the
    36 channels of the 12 presets, against runs of their own seeds: the low albedos absorbing as they go
    (photons per channel so that every annulus collects about 10,000), the high ones (alpha' >= 0.9, whose
    long paths cost most) reweighting one unabsorbed run of 100,000 photons (MC noise ~1 % per annulus)."""
    media = _media()
    alphas = np.unique([a for _, _, a, _ in media])  # spectralon's three channels share alpha' = 1
    low = alphas[alphas < 0.9]
    guess = np.array([exact_profile.total_diffuse_reflectance(1.0 - a, a, eta) for a in low])
    photons = (50_000 / np.maximum(guess, 0.005)).astype(int)
    absorbing = half_space_mc.trace(int(photons.sum()), eta, albedo=np.repeat(low, photons), seed=11)
    unabsorbed = half_space_mc.trace(100_000, eta, seed=12)
    failures, worst_total, worst_annulus = [], 0.0, 0.0
    for name, channel, alpha, st in media:
        if alpha < 0.9:
            sel = absorbing.albedo == alpha
            rho, w = absorbing.rho[sel], absorbing.weight[sel]
            # Every photon of this albedo carries 1 / photons of the power; the entered share is common.
            norm = 1.0 / (photons[np.searchsorted(low, alpha)] * absorbing.entered * hemispherical_transmittance(eta))
        else:
            rho, w = unabsorbed.rho, np.power(alpha, unabsorbed.n)
            norm = half_space_mc.normalisation(unabsorbed, eta)
        mc_total = w.sum() * norm
        sa, ss = st * (1 - alpha), st * alpha
        table_total = exact_profile.total_diffuse_reflectance(sa, ss, eta)
        worst_total = max(worst_total, abs(table_total / mc_total - 1))
        if abs(table_total / mc_total - 1) > 0.02:
            failures.append(f"{name} {channel}: total {table_total:.4f} vs MC {mc_total:.4f}")
        order = np.argsort(rho)
        cumulative = np.cumsum(w[order]) / w.sum()
        edges = np.interp(np.linspace(0, 0.95, ANNULI + 1), cumulative, rho[order])
        edges[0] = 0.0
        mc_power = np.histogram(rho, edges, weights=w)[0] * norm
        r_mm = edges / st
        table_power = np.diff(exact_profile.R_d_disk(r_mm, sa, ss, eta))
        ratio = table_power / mc_power
        worst_annulus = max(worst_annulus, float(np.max(np.abs(ratio - 1))))
        if np.any(np.abs(ratio - 1) > 0.05):
            failures.append(f"{name} {channel}: annulus ratios {np.round(ratio, 3).tolist()}")
    print(f"eta {eta}: worst total {100 * worst_total:.2f} %, worst annulus {100 * worst_annulus:.2f} %")
    assert not failures, "\n".join(failures)


def test_profile_scales_with_sigma_t_and_keeps_the_dipole_interface():
    """R_d(r; sigma) = sigma_t'^2 R^(r sigma_t'): doubling both coefficients halves the lengths; the functions
    broadcast RGB against distances like the dipole's, and r_max holds 99 % of the total."""
    sa, ss = np.array([0.032, 0.17, 0.48]), np.array([0.74, 0.88, 1.01])
    r = np.linspace(0.0, 10.0, 7)[:, None]
    a = exact_profile.R_d(r, sa, ss, 1.3)
    b = exact_profile.R_d(r / 2, 2 * sa, 2 * ss, 1.3)
    assert a.shape == (7, 3) == dipole.R_d(r, sa, ss, 1.3).shape
    np.testing.assert_allclose(b, 4 * a, rtol=1e-12)
    radius = exact_profile.r_max(sa, ss, 1.3, 0.01)
    total = exact_profile.total_diffuse_reflectance(sa, ss, 1.3)
    np.testing.assert_allclose(exact_profile.R_d_disk(radius, sa, ss, 1.3), 0.99 * total, rtol=1e-6)
    # The disk integral is the integral of R_d (trapezoid on a fine grid; the peak resolved).
    rr = np.geomspace(1e-4, float(radius.max()), 20_000)[:, None]
    integral = trapezoid(exact_profile.R_d(rr, sa, ss, 1.3) * 2 * np.pi * rr, rr, axis=0)
    np.testing.assert_allclose(integral, exact_profile.R_d_disk(radius.max(), sa, ss, 1.3), rtol=0.02)


def test_methods_take_the_medium_profile_exact_by_default():
    """IMAGE_SPACE's tables and TEXTURE_SPACE's form factors read the medium's profile: exact unless DIPOLE."""
    from translucent_addon.core.frame import Medium
    from translucent_addon.techniques.image_space.model import material_tables
    from translucent_addon.techniques.texture_space.throughput import Material

    sa, ss = (0.032, 0.17, 0.48), (0.74, 0.88, 1.01)
    exact = Medium(sa, ss, 1.3, 1000.0)
    assert exact.profile == "EXACT"
    np.testing.assert_allclose(material_tables(exact, 0.5, 0.01).total,
                               exact_profile.total_diffuse_reflectance(np.array(sa), np.array(ss), 1.3), rtol=1e-12)
    np.testing.assert_allclose(material_tables(Medium(sa, ss, 1.3, 1000.0, profile="DIPOLE"), 0.5, 0.01).total,
                               dipole.total_diffuse_reflectance(np.array(sa), np.array(ss), 1.3), rtol=1e-12)
    r = np.array([0.1, 1.0, 3.0])
    np.testing.assert_allclose(Material(sa, ss, 1.3).R_d_exact(r), exact_profile.R_d(r[:, None], sa, ss, 1.3))
    np.testing.assert_allclose(Material(sa, ss, 1.3, "DIPOLE").R_d_exact(r), dipole.R_d(r[:, None], sa, ss, 1.3))

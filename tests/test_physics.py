"""Physics against closed forms and known numbers."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from translucent_addon.physics.dipole import A, R_d, dipole_parameters, total_diffuse_reflectance
from translucent_addon.physics.fresnel import F_dr, fresnel_dielectric, fresnel_schlick
from translucent_addon.physics.presets import load_presets


@pytest.mark.parametrize("name", sorted(load_presets()))
def test_integral_of_R_d_over_the_plane_is_the_total_diffuse_reflectance(name):
    """int_0^inf R_d(r) 2 pi r dr equals Jensen's closed form, to 1e-3 relative, per channel."""
    m = load_presets()[name]
    for c in range(3):
        args = (m.sigma_a[c], m.sigma_s_prime[c], m.eta)
        z_r = 1.0 / (m.sigma_a[c] + m.sigma_s_prime[c])
        # Split at a few mean free paths: the profile is sharp near 0 and has a long tail.
        f = lambda r: float(R_d(r, *args)) * 2.0 * math.pi * r  # noqa: E731
        edges = [0.0, z_r, 10 * z_r, 100 * z_r, 1e4 * z_r]
        total = sum(integrate.quad(f, a, b, limit=400, epsabs=0, epsrel=1e-10)[0] for a, b in zip(edges, edges[1:]))
        total += integrate.quad(f, edges[-1], np.inf, limit=400)[0]
        closed = float(total_diffuse_reflectance(*args))
        assert total == pytest.approx(closed, rel=1e-3), (name, "RGB"[c], total, closed)


def test_non_absorbing_medium_reflects_everything():
    """sigma_a = 0 (spectralon): alpha' = 1, sigma_tr = 0, and the total diffuse reflectance is 1."""
    assert float(total_diffuse_reflectance(0.0, 11.6, 1.3)) == pytest.approx(1.0)


def test_F_dr_uses_the_jensen_coefficient_not_shahs_typo():
    eta = 1.3
    assert float(F_dr(eta)) == pytest.approx(-1.440 / eta**2 + 0.710 / eta + 0.668 + 0.0636 * eta)
    # The fit against the hemispherical average of the exact Fresnel reflectance
    # (2 int_0^1 F(cos) cos dcos for light leaving a medium of relative index 1/eta).
    mu = np.linspace(0, 1, 200001)
    exact = 2.0 * np.trapz(fresnel_dielectric(mu, 1.0 / eta) * mu, mu)
    assert float(F_dr(eta)) == pytest.approx(exact, abs=0.01)
    assert abs(float(F_dr(eta)) - exact) < abs(float(F_dr(eta)) - 0.0636 * eta + 0.0668 * eta - exact)
    assert float(A(1.0)) == pytest.approx((1 + F_dr(1.0)) / (1 - F_dr(1.0)))


def test_dipole_parameters_of_marble():
    alpha, sigma_tr, z_r, z_v = dipole_parameters(0.0021, 2.19, 1.3)
    assert alpha == pytest.approx(2.19 / 2.1921)
    assert sigma_tr == pytest.approx(math.sqrt(3 * 0.0021 * 2.1921))
    assert z_r == pytest.approx(1 / 2.1921)
    assert z_v == pytest.approx(z_r * (1 + 4 * float(A(1.3)) / 3))


def test_exact_fresnel_known_values():
    assert float(fresnel_dielectric(1.0, 1.5)) == pytest.approx(0.04)
    assert float(fresnel_dielectric(0.0, 1.5)) == pytest.approx(1.0)
    # Brewster angle: the p-polarised part vanishes, R = r_s^2 / 2.
    theta_b = math.atan(1.5)
    cos_t = math.cos(math.pi / 2 - theta_b)
    r_s = (math.cos(theta_b) - 1.5 * cos_t) / (math.cos(theta_b) + 1.5 * cos_t)
    assert float(fresnel_dielectric(math.cos(theta_b), 1.5)) == pytest.approx(0.5 * r_s**2)
    # Total internal reflection past the critical angle from inside glass.
    assert float(fresnel_dielectric(math.cos(math.radians(45)), 1 / 1.5)) == 1.0
    assert float(fresnel_schlick(1.0, 1.5)) == pytest.approx(0.04)
    mu = np.linspace(0.2, 1, 50)
    assert np.abs(fresnel_schlick(mu, 1.5) - fresnel_dielectric(mu, 1.5)).max() < 0.02

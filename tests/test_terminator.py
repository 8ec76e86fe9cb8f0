"""core/physics/terminator.py: the lateral spread of the light entering beside a curved surface's terminator."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from translucent_addon.core.physics import dipole, terminator

# (sigma_a, sigma_s') per mm: marble's red (albedo 0.999), skin1's red and blue (Jensen et al. 2001).
MEDIA = [(0.0021, 2.19), (0.032, 0.74), (0.17, 0.88)]


@pytest.mark.parametrize("sigma_a, sigma_s_prime", MEDIA)
def test_the_clamp_adds_an_even_excess_that_peaks_at_the_terminator(sigma_a, sigma_s_prime):
    """G(s) = F(s) - max(s, 0) is even (F(s) - F(-s) = s for a symmetric kernel), non-negative, falls
    monotonically from G(0) = 1 / pi (in units of the kernel's mean radius: E|r cos phi| / 2) and is
    under 1e-3 G(0) beyond |s| = 40, where the table's coordinate has few texels left."""
    s = np.linspace(0.0, 40.0, 401)
    G = terminator.excess(s, sigma_a, sigma_s_prime, 1.3)
    np.testing.assert_allclose(terminator.excess(-s, sigma_a, sigma_s_prime, 1.3), G, atol=1e-12)
    assert G[0] == pytest.approx(1.0 / np.pi, rel=1e-9)
    assert (np.diff(G) <= 1e-13).all() and (G >= -1e-13).all()  # F(s) - s cancels to 1e-14 far out
    assert G[-1] < 1e-3 * G[0]


@pytest.mark.parametrize("sigma_a, sigma_s_prime", MEDIA)
def test_the_ramp_response_equals_the_marginal_of_the_dipole_integrated_apart(sigma_a, sigma_s_prime):
    """F(s) from the closed-form angular integral equals, within 1e-3, the same average taken another way:
    the dipole's 1-D marginal P(x) = 2 int_0^inf R_d(sqrt(x^2 + y^2)) dy by adaptive quadrature, then
    int P(x) max(0, s + x) dx / int P(x) dx."""
    eta = 1.3
    rho = terminator.kernel_mean_radius(sigma_a, sigma_s_prime, eta)
    _, sigma_tr, z_r, _ = dipole.dipole_parameters(sigma_a, sigma_s_prime, eta)
    reach = 40.0 / sigma_tr

    def marginal(x):
        f = lambda y: float(dipole.R_d(np.hypot(x, y), sigma_a, sigma_s_prime, eta))  # noqa: E731
        return 2.0 * sum(integrate.quad(f, a, b, limit=200)[0]
                         for a, b in ((0, z_r), (z_r, 10 * z_r), (10 * z_r, reach)))

    x = np.concatenate([np.geomspace(1e-3 * z_r, reach, 300)])
    x = np.concatenate([[0.0], x])
    P = np.array([marginal(v) for v in x])
    total = 2.0 * integrate.trapezoid(P, x)
    for s in (-3.0, -1.0, 0.0, 0.5, 2.0):
        # in mm: max(0, s rho + x) over the line, both halves of the even marginal
        ramp = np.maximum(0.0, s * rho + x) + np.maximum(0.0, s * rho - x)
        F = integrate.trapezoid(P * ramp, x) / total / rho
        assert terminator.ramp_response(s, sigma_a, sigma_s_prime, eta)[0] == pytest.approx(F, rel=1e-3, abs=1e-5)


def test_the_effective_cosine_is_the_flat_faces_away_from_the_terminator():
    """On a flat face (g = 0) mu_eff is max(mu_i, 0) exactly, and where the ramp stays positive under the
    kernel (mu_i = 50 g rho) within 1e-6; at the terminator it is g rho / pi, past it positive and falling;
    a bend sharper than the kernel is held at g rho = 1."""
    sigma_a, sigma_s_prime = MEDIA[1]
    rho = terminator.kernel_mean_radius(sigma_a, sigma_s_prime, 1.0)
    mu = np.array([-0.3, 0.0, 0.2, 0.9])
    np.testing.assert_array_equal(terminator.effective_cosine(mu, 0.0, sigma_a, sigma_s_prime, 1.0),
                                  np.maximum(mu, 0.0))
    g = 0.02  # per mm: a 50 mm radius with the light along the surface
    assert (terminator.effective_cosine(50 * g * rho, g, sigma_a, sigma_s_prime, 1.0)[0]
            == pytest.approx(50 * g * rho, rel=1e-6))
    assert (terminator.effective_cosine(0.0, g, sigma_a, sigma_s_prime, 1.0)[0]
            == pytest.approx(g * rho / np.pi, rel=1e-9))
    past = terminator.effective_cosine(-g * rho * np.array([0.5, 1.0, 2.0]), g, sigma_a, sigma_s_prime, 1.0)
    assert (past > 0).all() and (np.diff(past) < 0).all()
    # a bend sharper than the kernel (g rho = 5): the ramp is held at g rho = 1, mu_eff at most 1 / pi
    sharp = terminator.effective_cosine(0.0, 5.0 / rho, sigma_a, sigma_s_prime, 1.0)[0]
    assert sharp == pytest.approx(1.0 / np.pi, rel=1e-9)


def test_the_table_holds_the_excess_at_its_coordinates():
    """excess_table per channel: 0 at both ends (s = -inf, +inf), 1 / pi in the middle texel (s = 0), and
    at texel k the excess at s = (2 u - 1) / (1 - |2 u - 1|), which table_coordinate maps back to u."""
    sigma_a = np.array([m[0] for m in MEDIA])
    sigma_s_prime = np.array([m[1] for m in MEDIA])
    table = terminator.excess_table(sigma_a, sigma_s_prime, 1.0, n=65)
    assert table.shape == (65, 3)
    np.testing.assert_array_equal(table[[0, -1]], 0.0)
    np.testing.assert_allclose(table[32], 1.0 / np.pi, rtol=1e-9)
    u = 40 / 64
    s = (2 * u - 1) / (1 - abs(2 * u - 1))
    assert terminator.table_coordinate(s) == pytest.approx(u)
    for c, (a, sp) in enumerate(MEDIA):
        assert table[40, c] == pytest.approx(terminator.excess(s, a, sp, 1.0)[0], rel=1e-12)


@pytest.mark.parametrize("sigma_a, sigma_s_prime", MEDIA)
def test_the_share_beyond_a_line_is_the_slope_of_the_excess(sigma_a, sigma_s_prime):
    """beta(s), the kernel's share beyond a line s rho away, is 1 / 2 on the line, falls to 0, and equals
    -dG/ds (F'(s) = P(x > -s)): what qg_single takes from the table by a forward difference of 0.02."""
    s = np.array([0.0, 0.1, 0.3, 1.0, 3.0])
    beta = terminator.beyond_line(s, sigma_a, sigma_s_prime, 1.3)
    assert beta[0] == pytest.approx(0.5, abs=1e-9)
    assert (np.diff(beta) < 0).all() and beta[-1] < 0.02
    h = 1e-4
    slope = (terminator.excess(s, sigma_a, sigma_s_prime, 1.3)
             - terminator.excess(s + h, sigma_a, sigma_s_prime, 1.3)) / h
    np.testing.assert_allclose(beta, slope, atol=2e-3)
    coarse = (terminator.excess(s, sigma_a, sigma_s_prime, 1.3)
              - terminator.excess(s + 0.02, sigma_a, sigma_s_prime, 1.3)) / 0.02
    np.testing.assert_allclose(coarse, beta, atol=0.02)


def test_the_facet_weight_follows_the_triangle_against_the_kernel():
    """The triangle's own normal's share: all of it deep inside a triangle many kernels wide, none at its
    edges (the smooth normal there already averages the two faces), none on a mesh far finer than the
    kernel, and between for the cow's median triangle (4.3 mm edges, 1.25 mm from each edge at its
    centroid) against skin1's red kernel (rho 2.8 mm) and blue (0.9 mm): more for the narrower kernel."""
    red, blue = (0.032, 0.74), (0.48, 1.01)
    big = terminator.facet_weight([[60.0, 60.0, 60.0]], *red, 1.3)
    edge = terminator.facet_weight([[0.0, 60.0, 60.0]], *red, 1.3)
    fine = terminator.facet_weight([[0.05, 0.05, 0.05]], *red, 1.3)
    assert big[0] == pytest.approx(1.0, abs=1e-3)
    assert edge[0] == 0.0 and fine[0] == 0.0
    centroid = [[1.25, 1.25, 1.25]]
    t_red, t_blue = terminator.facet_weight(centroid, *red, 1.3)[0], terminator.facet_weight(centroid, *blue, 1.3)[0]
    assert t_red == 0.0 < t_blue < 0.95  # red's kernel reaches past the edges: within 1/2 of it inside
    wide = [[2.7, 2.7, 2.7]]  # the cow's 90th-percentile triangle (9.3 mm edges)
    assert 0.0 < terminator.facet_weight(wide, *red, 1.3)[0] < terminator.facet_weight(wide, *blue, 1.3)[0]
    # w = prod (1 - beta) taken apart
    rho = terminator.kernel_mean_radius(*blue, 1.3)
    w = (1.0 - terminator.beyond_line(np.array([1.25 / rho]), *blue, 1.3)[0]) ** 3
    assert t_blue == pytest.approx(2.0 * w - 1.0, rel=1e-9)

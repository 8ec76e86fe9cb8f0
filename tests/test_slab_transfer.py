"""Monte Carlo slab transfer functions (Chan & Wang 2005 Sec. 3.3) against closed forms.

Tolerances: Monte Carlo quantities are compared at 4 standard errors (binomial counts for
fractions, sample standard deviation for means). Thin-slab limits also allow the known
O(tau ln(1/tau)) thin-slab correction (escape attenuation, multiple scattering), stated per test.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from translucent_addon.core.physics.slab_transfer import (
    DEFAULT_TAUS,
    fit_transmission,
    gaussian_lobe,
    gaussian_lobe_norm,
    hg_backscatter_fraction,
    rotate_cosine,
    sample_henyey_greenstein,
    simulate_slab,
    transfer_table,
)


def hg_density(mu, g):
    """HG phase function as a density in mu = cos theta on [-1, 1]."""
    return 0.5 * (1.0 - g * g) / (1.0 + g * g - 2.0 * g * mu) ** 1.5


# --- Henyey-Greenstein ---------------------------------------------------------------------

@pytest.mark.parametrize("g", [-0.5, 0.0, 0.3, 0.9, 0.99])
def test_hg_samples_have_mean_cosine_g_and_the_closed_form_backscatter(g):
    n = 400_000
    mu = sample_henyey_greenstein(g, np.random.default_rng(7).random(n))
    assert np.all(np.abs(mu) <= 1.0)
    # <mu> = g, <mu^2> = (1 + 2 g^2) / 3 (Legendre moments g^l of HG).
    sd_mean = math.sqrt(((1.0 + 2.0 * g * g) / 3.0 - g * g) / n)
    assert abs(mu.mean() - g) < 4.0 * sd_mean
    p = hg_backscatter_fraction(g)
    assert abs(np.mean(mu < 0.0) - p) < 4.0 * math.sqrt(p * (1.0 - p) / n)


@pytest.mark.parametrize("g", [-0.7, 1e-3, 0.2, 0.5, 0.8, 0.95])
def test_backscatter_fraction_is_the_integral_of_the_phase_function(g):
    numeric = integrate.quad(hg_density, -1.0, 0.0, args=(g,), epsabs=0, epsrel=1e-12)[0]
    assert hg_backscatter_fraction(g) == pytest.approx(numeric, rel=1e-9)


def test_backscatter_fraction_is_continuous_at_g_zero():
    assert hg_backscatter_fraction(0.0) == 0.5
    for g in (-2e-4, -5e-5, 5e-5, 2e-4):  # across the series / closed-form switch at 1e-4
        assert hg_backscatter_fraction(g) == pytest.approx(0.5 - 0.75 * g, abs=1e-11)
    assert np.allclose(hg_backscatter_fraction(np.array([0.0, 0.5])), [0.5, 0.5 * (1.5 / math.sqrt(1.25) - 1)])


def test_rotate_cosine_is_the_z_component_of_the_full_3d_rotation():
    """Against rotating the 3-D direction vector in an orthonormal frame, for random directions."""
    rng = np.random.default_rng(3)
    n = 10_000
    uz = np.concatenate([rng.uniform(-1, 1, n - 2), [1.0, -1.0]])
    az = rng.uniform(0, 2 * np.pi, n)
    s = np.sqrt(1 - uz**2)
    ux, uy = s * np.cos(az), s * np.sin(az)
    ct, phi = rng.uniform(-1, 1, n), rng.uniform(0, 2 * np.pi, n)
    st = np.sqrt(1 - ct**2)
    # Orthonormal frame (e1, e2, u); new direction = ct u + st (cos phi e1 + sin phi e2).
    u = np.stack([ux, uy, uz], axis=1)
    helper = np.where(np.abs(uz)[:, None] < 0.9, [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    e1 = np.cross(helper, u)
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(u, e1)
    new = ct[:, None] * u + st[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    # Azimuth origin differs between frames, so compare with phi measured in this frame:
    # e1's angle to the plane of (u, z) is what rotate_cosine calls phi = 0.
    z_plane = np.array([0.0, 0.0, 1.0]) - uz[:, None] * u  # projection of z onto u's normal plane
    norm = np.linalg.norm(z_plane, axis=1)
    ok = norm > 1e-9
    ref = z_plane[ok] / norm[ok][:, None]  # direction of +z in the plane: phi_ref = 0 there
    e1o, e2o = e1[ok], e2[ok]
    phi_ref = np.arctan2(np.sum(ref * e2o, 1), np.sum(ref * e1o, 1))
    mine = rotate_cosine(uz[ok], ct[ok], phi[ok] - phi_ref)
    assert np.max(np.abs(mine - new[ok, 2])) < 1e-12
    # Along the normal the azimuth does not matter: mu' = +-cos theta.
    assert np.allclose(rotate_cosine(np.array([1.0, -1.0]), 0.3, 1.234), [0.3, -0.3], atol=1e-15)


# --- Monte Carlo slab ------------------------------------------------------------------------

@pytest.mark.parametrize("tau", [0.1, 1.0, 3.0])
def test_unscattered_fraction_is_exp_minus_tau(tau):
    n = 100_000
    s = simulate_slab(tau, 0.9, n_photons=n, seed=11)
    p = math.exp(-tau)
    assert abs(s.unscattered - p) < 4.0 * math.sqrt(p * (1.0 - p) / n)


@pytest.mark.parametrize("tau,g", [(0.05, 0.9), (1.0, 0.0), (2.0, 0.5), (6.0, 0.9), (0.0, 0.5)])
def test_energy_is_conserved_without_absorption(tau, g):
    s = simulate_slab(tau, g, n_photons=30_000, seed=2)
    assert s.unscattered + s.T_scattered + s.R == pytest.approx(1.0, abs=1e-12)
    # The histograms carry all the scattered energy; bins are 1 degree rings of the hemisphere.
    edges = np.radians(np.arange(91.0))
    ring = 2 * np.pi * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    assert np.allclose(s.theta_edges, edges, rtol=0, atol=1e-14)
    assert np.allclose(s.solid_angles, ring, rtol=1e-12) and s.solid_angles.sum() == pytest.approx(2 * np.pi)
    assert np.sum(s.transmitted * ring) == pytest.approx(s.T_scattered, abs=1e-12)
    assert np.sum(s.reflected * ring) == pytest.approx(s.R, abs=1e-12)


def test_absorption_removes_energy_but_not_the_unscattered_beam():
    clear = simulate_slab(2.0, 0.5, omega_0=1.0, n_photons=30_000, seed=4)
    murky = simulate_slab(2.0, 0.5, omega_0=0.8, n_photons=30_000, seed=4)
    assert murky.unscattered == clear.unscattered  # same first flights: extinction only
    assert murky.unscattered + murky.T_scattered + murky.R < 0.95
    assert murky.R < clear.R and murky.T_scattered < clear.T_scattered
    # Thin slab: almost all scattered light has scattered once, so it carries omega_0.
    one = simulate_slab(0.01, 0.5, omega_0=1.0, n_photons=1_000_000, seed=5)
    half = simulate_slab(0.01, 0.5, omega_0=0.5, n_photons=1_000_000, seed=5)
    ratio = (half.R + half.T_scattered) / (one.R + one.T_scattered)
    assert 0.49 < ratio <= 0.5


def test_simulation_is_deterministic_for_a_seed():
    a = simulate_slab(1.5, 0.8, omega_0=0.9, n_photons=20_000, seed=9)
    b = simulate_slab(1.5, 0.8, omega_0=0.9, n_photons=20_000, seed=9)
    c = simulate_slab(1.5, 0.8, omega_0=0.9, n_photons=20_000, seed=10)
    assert np.array_equal(a.transmitted, b.transmitted) and np.array_equal(a.reflected, b.reflected)
    assert a.R == b.R and a.unscattered == b.unscattered
    assert not np.array_equal(a.transmitted, c.transmitted)


def reference_3d(tau, g, n, seed, omega_0=1.0):
    """Independent tracker: full 3-D direction vectors (MCML rotation), analog absorption.

    Returns (R, T_scattered, mean exit cosine of the scattered transmitted photons).
    """
    rng = np.random.default_rng(seed)
    z = rng.standard_exponential(n)
    z = z[z < tau]
    u = np.zeros((z.size, 3))
    u[:, 2] = 1.0
    refl, trans, cos_sum = 0, 0, 0.0
    while z.size:
        if omega_0 < 1.0:  # each collision absorbs the photon with probability 1 - omega_0
            live = rng.random(z.size) < omega_0
            z, u = z[live], u[live]
        ct = sample_henyey_greenstein(g, rng.random(z.size))
        st = np.sqrt(1 - ct**2)
        phi = 2 * np.pi * rng.random(z.size)
        ux, uy, uz = u.T
        den = np.sqrt(np.maximum(1 - uz**2, 1e-300))
        polar = np.abs(uz) > 0.99999
        nx = np.where(polar, st * np.cos(phi),
                      st * (ux * uz * np.cos(phi) - uy * np.sin(phi)) / den + ux * ct)
        ny = np.where(polar, st * np.sin(phi),
                      st * (uy * uz * np.cos(phi) + ux * np.sin(phi)) / den + uy * ct)
        nz = np.where(polar, np.sign(uz) * ct, -st * np.cos(phi) * den + uz * ct)
        u = np.stack([nx, ny, nz], axis=1)
        u /= np.linalg.norm(u, axis=1)[:, None]
        z = z + u[:, 2] * rng.standard_exponential(z.size)
        down, up = z >= tau, z <= 0
        refl += int(up.sum())
        trans += int(down.sum())
        cos_sum += float(u[down, 2].sum())
        keep = ~(down | up)
        z, u = z[keep], u[keep]
    return refl / n, trans / n, cos_sum / max(trans, 1)


@pytest.mark.parametrize("tau,g", [(2.0, 0.8), (5.0, 0.5)])
def test_direction_tracking_matches_a_full_3d_tracker(tau, g):
    """Reducing the state to (z, mu) gives the same R, T and exit angles as 3-D vectors.

    Tolerance: 4 standard errors of the difference of two independent estimates.
    """
    n = 40_000
    r3, t3, c3 = reference_3d(tau, g, n, seed=21)
    s = simulate_slab(tau, g, n_photons=n, seed=22)
    for mine, ref in ((s.R, r3), (s.T_scattered, t3)):
        assert abs(mine - ref) < 4 * math.sqrt(2 * ref * (1 - ref) / n), (mine, ref)
    mu = np.cos(s.theta_centres)  # 1 degree bins: binned mean cosine good to ~1e-4
    c_mine = np.sum(s.transmitted * s.solid_angles * mu) / s.T_scattered
    var_mu = np.sum(s.transmitted * s.solid_angles * mu**2) / s.T_scattered - c_mine**2
    sd_c = math.sqrt(2 * var_mu / (n * t3))
    assert abs(c_mine - c3) < 4 * sd_c + 1e-3, (c_mine, c3)


def test_albedo_weighting_matches_analog_absorption():
    """Weights omega_0^n with Russian roulette agree with killing photons at random.

    Tolerance: 4 standard errors of the difference (each estimator lies in [0, 1] per photon,
    so its variance is at most p (1 - p)).
    """
    n = 40_000
    for tau, g, omega_0 in ((3.0, 0.8, 0.8), (6.0, 0.0, 0.6)):
        r3, t3, _ = reference_3d(tau, g, n, seed=31, omega_0=omega_0)
        s = simulate_slab(tau, g, omega_0=omega_0, n_photons=n, seed=32)
        for mine, ref in ((s.R, r3), (s.T_scattered, t3)):
            assert abs(mine - ref) < 4 * math.sqrt(2 * ref * (1 - ref) / n), (tau, g, mine, ref)


THIN = 0.01
THIN_N = 8_000_000  # photons: ~0.1 s, since only 1 % of them scatter
THIN_BIAS = THIN * math.log(1.0 / THIN)  # relative O(tau ln 1/tau) thin-slab correction, 4.6 %


@pytest.mark.parametrize("g", [0.0, 0.5, 0.9])
def test_thin_slab_reflection_is_tau_times_the_backscatter_fraction(g):
    """R / tau -> P(cos < 0) (single scattering) as tau -> 0.

    Tolerance: 4 binomial standard errors of R, plus THIN_BIAS * P for the thin-slab
    correction (single-scattered light loses ~3-4.4 % escaping at tau = 0.01, computed below;
    multiple scattering gives some back).
    """
    s = simulate_slab(THIN, g, n_photons=THIN_N, seed=1)
    b = hg_backscatter_fraction(g)
    sd = math.sqrt(s.R * (1.0 - s.R) / THIN_N) / THIN
    assert abs(s.R / THIN - b) < 4.0 * sd + THIN_BIAS * b, (s.R / THIN, b, sd)
    # The escape loss of single scattering that THIN_BIAS covers:
    # R_1 = int_0^1 p(-m) m / (1 + m) (1 - exp(-tau (1 + 1/m))) dm.
    r1 = integrate.quad(lambda m: hg_density(-m, g) * m / (1 + m) * -math.expm1(-THIN * (1 + 1 / m)),
                        0, 1, limit=200, points=[1e-3, 1e-2, 0.1])[0]
    assert 0.0 < b - r1 / THIN < THIN_BIAS * b


@pytest.mark.parametrize("g", [0.0, 0.5, 0.9])
def test_thin_slab_transmission_has_the_single_scattering_angular_shape(g):
    """Scattered energy in angle bands = exact single scattering (checks the per-sr binning).

    T_1(band) = int_band p(mu) (e^-tau - e^(-tau/mu)) / (1/mu - 1) dmu; tolerance 4 binomial
    standard errors + THIN_BIAS of the band's energy (multiple scattering).
    """
    s = simulate_slab(THIN, g, n_photons=THIN_N, seed=1)
    energy = s.transmitted * s.solid_angles
    centres = np.degrees(s.theta_centres)

    def single(mu):
        d = 1.0 / mu - 1.0
        k = THIN * math.exp(-THIN) if abs(d) < 1e-12 else (math.exp(-THIN) - math.exp(-THIN / mu)) / d
        return hg_density(mu, g) * k

    for a, b in ((0, 5), (5, 15), (15, 40), (40, 90)):
        mc = energy[(centres > a) & (centres < b)].sum()
        exact = integrate.quad(single, math.cos(math.radians(b)), math.cos(math.radians(a)), limit=200)[0]
        tol = 4.0 * math.sqrt(mc / THIN_N) + THIN_BIAS * exact
        assert abs(mc - exact) < tol, (g, a, b, mc, exact)


@pytest.mark.parametrize("g", [0.0, 0.5, 0.9])
def test_thin_slab_reflection_has_the_single_scattering_angular_shape(g):
    """Reflected energy in angle bands (angle to the outward normal) = single scattering.

    R_1(band) = int_band p(-m) m / (1 + m) (1 - exp(-tau (1 + 1/m))) dm; same tolerance as
    for transmission.
    """
    s = simulate_slab(THIN, g, n_photons=THIN_N, seed=1)
    energy = s.reflected * s.solid_angles
    centres = np.degrees(s.theta_centres)

    def single(m):
        return hg_density(-m, g) * m / (1 + m) * -math.expm1(-THIN * (1 + 1 / m))

    for a, b in ((0, 30), (30, 60), (60, 90)):
        mc = energy[(centres > a) & (centres < b)].sum()
        exact = integrate.quad(single, math.cos(math.radians(b)), math.cos(math.radians(a)), limit=200)[0]
        tol = 4.0 * math.sqrt(mc / THIN_N) + THIN_BIAS * exact
        assert abs(mc - exact) < tol, (g, a, b, mc, exact)


# --- Fit -------------------------------------------------------------------------------------

def test_gaussian_lobe_has_unit_hemisphere_integral():
    for tb in (0.02, 0.3, 1.0, 3.0):
        val = 2 * np.pi * integrate.quad(lambda t: math.exp(-0.5 * (t / tb) ** 2) * math.sin(t), 0, np.pi / 2,
                                         epsabs=0, epsrel=1e-12, limit=200)[0]
        assert float(gaussian_lobe_norm(tb)) == pytest.approx(val, rel=1e-10)
    # Narrow lobe: Z -> 2 pi theta_bar^2 (small-angle limit).
    assert float(gaussian_lobe_norm(1e-3)) == pytest.approx(2 * np.pi * 1e-6, rel=1e-6)


@pytest.mark.parametrize("f_t,theta_bar_deg,c_t", [(0.3, 8.0, 0.2), (0.6, 35.0, 0.0), (0.05, 3.0, 0.4)])
def test_fit_recovers_a_synthetic_curve(f_t, theta_bar_deg, c_t):
    edges = np.linspace(0, np.pi / 2, 91)
    centres = 0.5 * (edges[1:] + edges[:-1])
    omega = 2 * np.pi * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    tb = math.radians(theta_bar_deg)
    per_sr = f_t * gaussian_lobe(centres, tb) + c_t / (2 * np.pi)
    f, t, c = fit_transmission(centres, per_sr, omega)
    assert abs(f - f_t) < 1e-3 and abs(c - c_t) < 1e-3 and abs(t - tb) < 1e-3 * tb, (f, math.degrees(t), c)
    assert fit_transmission(centres, np.zeros_like(centres), omega) == (0.0, 0.0, 0.0)


def test_fit_is_the_solid_angle_weighted_least_squares_optimum():
    """On a non-Gaussian curve (thin-slab HG transmission, g = 0.8) the fit keeps the energy
    and no nearby energy-preserving (f_t, theta_bar, c_t) has a smaller sum Omega r^2."""
    edges = np.linspace(0, np.pi / 2, 91)
    centres = 0.5 * (edges[1:] + edges[:-1])
    omega = 2 * np.pi * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    per_sr = 0.3 * hg_density(np.cos(centres), 0.8) / (2 * np.pi) + 0.4 * np.cos(centres) / np.pi
    total = np.sum(per_sr * omega)
    f, t, c = fit_transmission(centres, per_sr, omega)
    assert f > 0 and c > 0
    assert f * np.sum(gaussian_lobe(centres, t) * omega) + c == pytest.approx(total, rel=1e-12)

    def cost(f_, t_):
        c_ = total - f_ * np.sum(gaussian_lobe(centres, t_) * omega)
        return np.sum(omega * (per_sr - f_ * gaussian_lobe(centres, t_) - c_ / (2 * np.pi)) ** 2)

    best = cost(f, t)
    for df in (-0.01, 0.0, 0.01):
        for dt in (0.98, 1.0, 1.02):
            if (df, dt) != (0.0, 1.0):
                assert cost(f * (1 + df), t * dt) > best


# --- Physics of the fitted table -------------------------------------------------------------

def test_theta_bar_grows_with_depth_for_forward_scattering():
    table = transfer_table(0.9, taus=[0.25, 0.5, 1.0, 2.0, 4.0, 8.0], n_photons=30_000)
    assert table.tau[0] == 0.0 and table.theta_bar[0] == table.theta_bar[1]  # prepended row
    tb = table.theta_bar[1:]
    assert np.all(np.diff(tb) > 0), np.degrees(tb)
    assert math.radians(3) < tb[0] < math.radians(10) and tb[-1] > 2 * tb[0]


@pytest.mark.parametrize("tau,g", [(0.3, 0.9), (1.0, 0.9), (4.0, 0.9), (12.0, 0.9), (1.0, 0.5), (5.0, 0.0)])
def test_fitted_energy_matches_the_scattered_transmission(tau, g):
    """f_t + c_t = T_scattered up to the bin quadrature of the lobe (well under 2 %)."""
    s = simulate_slab(tau, g, n_photons=30_000, seed=3)
    f_t, theta_bar, c_t = s.fit()
    assert f_t >= 0 and c_t >= 0 and 0 < theta_bar <= np.pi / 2
    assert f_t + c_t == pytest.approx(s.T_scattered, rel=0.02)


def test_forward_scattering_slab_keeps_transmitted_light_near_the_normal():
    """g = 0.9, tau = 1: measured ~80 % of the scattered transmission lies within 30 degrees."""
    n = 100_000
    s = simulate_slab(1.0, 0.9, n_photons=n, seed=8)
    near = s.theta_centres < math.radians(30)
    frac = float(np.sum((s.transmitted * s.solid_angles)[near]) / s.T_scattered)
    sd = math.sqrt(frac * (1 - frac) / (n * s.T_scattered))
    assert frac - 4 * sd > 0.7, frac
    # An isotropic medium spreads it far wider (~1 - cos 30 deg ~ 13 % for uniform intensity).
    iso = simulate_slab(1.0, 0.0, n_photons=n, seed=8)
    frac_iso = float(np.sum((iso.transmitted * iso.solid_angles)[near]) / iso.T_scattered)
    assert frac_iso < 0.4


@pytest.fixture(scope="module")
def default_table():
    return transfer_table(0.9)


def test_default_table_grid_and_energy(default_table):
    t = default_table
    assert np.array_equal(t.tau, DEFAULT_TAUS) and t.tau.size == 24 and t.tau[0] == 0 and t.tau[-1] == 30
    assert np.all(np.diff(t.tau) > 0)
    # omega_0 = 1: exact unscattered + fitted transmission + reflection = 1, up to the binomial
    # noise of the Monte Carlo unscattered fraction (50 000 photons) and the lobe quadrature.
    total = t.unscattered + t.f_t + t.c_t + t.c_r
    sd = np.sqrt(t.unscattered * (1 - t.unscattered) / 50_000)
    assert np.all(np.abs(total - 1) < 4 * sd + 2e-3), total
    assert np.all(np.diff(t.c_r) > 0)  # thicker slabs reflect more (Chan & Wang Fig. 11b)


def test_table_lookup_interpolates_and_clamps(default_table):
    t = default_table
    u, f, tb, c, r = t.at(np.array([0.0]))
    assert (u[0], f[0], c[0], r[0]) == (1.0, 0.0, 0.0, 0.0) and tb[0] == t.theta_bar[1]
    mid = 0.5 * (t.tau[5] + t.tau[6])
    u, f, tb, c, r = t.at(np.array([mid, 1e3, -1.0]))
    assert u[0] == pytest.approx(math.exp(-mid), rel=1e-15)
    assert f[0] == pytest.approx(0.5 * (t.f_t[5] + t.f_t[6]))
    assert tb[0] == pytest.approx(0.5 * (t.theta_bar[5] + t.theta_bar[6]))
    assert c[0] == pytest.approx(0.5 * (t.c_t[5] + t.c_t[6]))
    assert r[0] == pytest.approx(0.5 * (t.c_r[5] + t.c_r[6]))
    assert (f[1], tb[1], c[1], r[1]) == (t.f_t[-1], t.theta_bar[-1], t.c_t[-1], t.c_r[-1])
    assert (u[2], f[2], c[2], r[2]) == (1.0, 0.0, 0.0, 0.0)


def test_table_rejects_bad_grids():
    with pytest.raises(ValueError):
        transfer_table(0.9, taus=[1.0, 0.5])
    with pytest.raises(ValueError):
        transfer_table(0.9, taus=[-1.0, 1.0])

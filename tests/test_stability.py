"""Stability across the coefficients a user may enter (DESIGN.md section 6; the benchmark issue's
stability suite, extreme coefficients): every method's pure kernel, over the whole accepted domain
(``presets.validate_coefficients``: sigma_a >= 0, sigma_s' > 0, eta > 0), stays finite and within its
physical bounds. sigma_a from 0 (no absorption) to 100 / mm, sigma_s' from 1e-3 / mm (a medium
thinner in scattering than air in fog) to 1000 / mm, eta from index-matched to diamond-like.

Found by this suite: QUADGRAPH's terminator table (``core/physics/terminator.py``) was NaN at sigma_a = 0,
whose kernel has no finite mean radius (it is now taken at ``SIGMA_A_FLOOR``), and TEXTURE_SPACE's R_d
table reached 40 / sigma_tr = infinity there, so its bake kept no form factor and drew a black object
(the table now stops at ``lensch.TABLE_REACH_MAX_MM``, exact beyond)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from translucent_addon.core.physics import diffusion as df
from translucent_addon.core.physics import dipole, lut, terminator
from translucent_addon.core.physics import single_scattering as ss
from translucent_addon.techniques.texture_space import throughput as lensch

SIGMA_A = (0.0, 1e-6, 1e-3, 1.0, 100.0)
SIGMA_S_PRIME = (1e-3, 0.1, 1.0, 10.0, 1000.0)
ETA = (1.0, 1.33, 2.4)
DOMAIN = list(itertools.product(SIGMA_A, SIGMA_S_PRIME, ETA))


def _finite(*arrays) -> bool:
    return all(np.isfinite(np.asarray(a, np.float64)).all() for a in arrays)


@pytest.mark.parametrize("sigma_a,sigma_s_prime,eta", DOMAIN)
def test_dipole_and_image_space_tables_stay_finite_and_bounded(sigma_a, sigma_s_prime, eta):
    """IMAGE_SPACE and TEXTURE_SPACE: the dipole's total reflectance in [0, 1] (1 without absorption),
    a finite splat radius, finite non-negative profile tables."""
    Rd = dipole.total_diffuse_reflectance(sigma_a, sigma_s_prime, eta)
    assert 0.0 <= Rd <= 1.0 + 1e-12
    if sigma_a == 0.0:
        assert Rd == pytest.approx(1.0, abs=1e-12)
    r = float(dipole.r_max(sigma_a, sigma_s_prime, eta))
    assert np.isfinite(r) and r > 0
    t = lut.image_space_tables([sigma_a] * 3, [sigma_s_prime] * 3, eta, 1.0)
    assert _finite(t.far, t.tail, t.near) and (t.far >= 0).all() and (t.near >= 0).all()
    # TEXTURE_SPACE's tabulated profile: what the exact one gives, from 0.01 mm to 2 m.
    medium = lensch.Material((sigma_a,) * 3, (sigma_s_prime,) * 3, eta)
    radii = np.geomspace(0.01, 2000.0, 60)
    exact = medium.R_d_exact(radii)
    assert _finite(medium.R_d(radii)) and medium.R_d(radii) == pytest.approx(exact, rel=0.02, abs=1e-12 * exact.max())


@pytest.mark.parametrize("sigma_a,sigma_s_prime,eta", DOMAIN)
def test_quadgraph_kernels_stay_finite_and_bounded(sigma_a, sigma_s_prime, eta):
    """QUADGRAPH: the continuous slab conserves energy (R + T <= 1, R = 1 without absorption), the
    source's shares lie in [0, 1], the fitted link factors keep their signs, the held source's gain is
    at least 1; for surface links from 0.01 to 10 mm."""
    R = df.slab_reflectance(sigma_a, sigma_s_prime, eta)
    assert 0.0 <= R <= 1.0 + 1e-12
    if sigma_a == 0.0:
        assert R == pytest.approx(1.0, abs=1e-12)
    (R5,), (T5,) = df.slab_transfer([sigma_a], [sigma_s_prime], eta, 5.0)
    assert _finite(R5, T5) and R5 >= 0 and T5 >= 0 and R5 + T5 <= 1.0 + 1e-9
    d = np.array([0.01, 1.0, 10.0])
    kappa = np.full((3, 1), df.kappa(sigma_a, sigma_s_prime))
    mu = np.full((3, 1), sigma_a)
    w_s, w_k = df.source_split(kappa, mu, d)
    assert _finite(w_s, w_k) and (w_s >= 0).all() and (w_k >= 0).all() and (w_s + w_k <= 1.0 + 1e-9).all()
    # Continuous in sigma_a down to 0, where the shares are (d - z_0) / d and z_0 / d, summing to 1 (both were
    # 0 / 0 = 0 there once: QUADGRAPH drew spectralon black).
    w_s_near, w_k_near = df.source_split(kappa, mu + 1e-12, d)
    assert np.allclose(w_s, w_s_near, atol=1e-6) and np.allclose(w_k, w_k_near, atol=1e-6)
    if sigma_a == 0.0:
        assert np.allclose(w_s + w_k, 1.0, atol=1e-12)
    e1, e2 = df.surface_link(kappa, mu, d)
    assert _finite(e1, e2) and ((e1 > 0) & (e1 <= 1.0)).all() and (e2 >= 1.0).all()
    gain = df.held_source_gain(kappa, mu, d)
    assert _finite(gain) and (gain >= 1.0).all()


@pytest.mark.parametrize("sigma_a,sigma_s_prime", list(itertools.product(SIGMA_A, SIGMA_S_PRIME)))
def test_surface_term_tables_stay_finite_and_bounded(sigma_a, sigma_s_prime):
    """The surface term's tables (single and local multiple scattering, the world's law, the terminator
    excess G with its invariant G(0) = 1 / pi, the kernel's mean radius) are finite at every coefficient,
    sigma_a = 0 included."""
    sa, sp, eta = [sigma_a] * 3, [sigma_s_prime] * 3, 1.33
    H = ss.h_table(sa, sp)
    assert _finite(H) and (H >= 1.0 - 1e-9).all()  # Chandrasekhar's H >= 1
    assert _finite(ss.uniform_light_table(sa, sp, eta))
    loss = ss.exitance_loss(sa, sp, eta)
    assert _finite(loss) and (loss >= 0).all()
    G = terminator.excess_table(sa, sp, eta)
    assert _finite(G) and (G >= 0).all()
    centre = (len(G) - 1) // 2  # u = 1 / 2: s = 0, the terminator
    assert G[centre] == pytest.approx(np.full(3, 1.0 / np.pi), rel=0.01)
    rho = terminator.kernel_mean_radii(sa, sp, eta)
    assert _finite(rho) and (rho > 0).all()


def test_no_absorption_is_the_limit_of_little_absorption():
    """sigma_a = 0 draws what sigma_a -> 0 draws: the terminator's kernel at the floor is continuous
    with it (rho within 2 % of sigma_a = 1e-8's, whose kernel it is)."""
    rho_0 = terminator.kernel_mean_radius(0.0, 1.0, 1.33)
    rho_small = terminator.kernel_mean_radius(1e-8, 1.0, 1.33)
    assert rho_0 == pytest.approx(rho_small, rel=0.02)
    assert rho_0 > terminator.kernel_mean_radius(1e-4, 1.0, 1.33)

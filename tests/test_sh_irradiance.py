"""Spherical-harmonic transmitted irradiance of an environment (Shah 6.4.2, Eq. 6.19-6.21)."""
from __future__ import annotations

import math

import numpy as np

from translucent_addon.core.environment import sample_equirect
from translucent_addon.core.physics.fresnel import fresnel_dielectric, hemispherical_transmittance
from translucent_addon.core.physics.sh_irradiance import (
    equirect_directions,
    irradiance,
    project,
    project_equirect,
    sh_basis,
    transmittance_kernel,
)


def _sphere(n: int = 400):
    """Midpoint quadrature of the sphere: directions (N, 3) and solid angles (N,)."""
    theta = (np.arange(n) + 0.5) / n * math.pi
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * math.pi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    return d, (np.sin(t) * (math.pi / n) * (math.pi / n)).ravel()


def _brute_force_E(L, eta, normals, d, omega):
    """Eq. 6.19 by quadrature: int L(w) F_t(n . w) (n . w)^+ dw."""
    cos = np.clip(normals @ d.T, 0.0, None)
    k = (1.0 - fresnel_dielectric(cos, eta)) * cos
    return (k * omega[None]) @ L


def test_basis_is_orthonormal():
    d, omega = _sphere()
    Y = sh_basis(d)
    np.testing.assert_allclose(Y.T @ (Y * omega[:, None]), np.eye(9), atol=1e-4)


def test_kernel_without_fresnel_is_ramamoorthis_and_the_uniform_world_gives_the_closed_form():
    # eta = 1: no reflection, A = (pi, 2 pi / 3, pi / 4) (Ramamoorthi & Hanrahan 2001).
    np.testing.assert_allclose(transmittance_kernel(1.0), [math.pi, 2 * math.pi / 3, math.pi / 4], rtol=1e-6)
    # A uniform world L: E = pi L (1 - F_dr) for every normal, the base pass's closed form.
    eta = 1.3
    L = np.array([0.2, 0.5, 1.0])
    coeffs = np.zeros((9, 3))
    coeffs[0] = L * math.sqrt(4 * math.pi)
    n = np.random.default_rng(1).normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(irradiance(coeffs, transmittance_kernel(eta), n),
                               np.tile(math.pi * L * hemispherical_transmittance(eta), (50, 1)), rtol=1e-5)


def test_band_limited_environment_is_exact():
    """L made of bands 0-2 only: the SH irradiance equals Eq. 6.19 by quadrature to 1e-4."""
    d, omega = _sphere()
    L = np.stack([1.0 + 0.6 * d[:, 2] + 0.3 * d[:, 0] * d[:, 1], 0.5 + 0.4 * d[:, 0] ** 2, 0.2 - 0.1 * d[:, 1]], -1)
    eta = 1.4
    n = np.random.default_rng(2).normal(size=(40, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    got = irradiance(project(d, L, omega), transmittance_kernel(eta), n)
    np.testing.assert_allclose(got, _brute_force_E(L, eta, n, d, omega), rtol=1e-4, atol=1e-4)


def test_sky_and_ground_environment_within_the_order_two_truncation():
    """A bright sky over a dark ground (a step): the order-2 irradiance is within 4 % of the full
    integral's range (the clamped cosine's truncation error; Ramamoorthi: about 3 % at most)."""
    h, w = 64, 128
    d_img, _ = equirect_directions(h, w)
    image = np.where(d_img[..., 2:3] > 0, [[[2.0, 2.0, 2.2]]], [[[0.1, 0.08, 0.05]]])
    d, omega = _sphere(300)
    L = sample_equirect(image, d)
    n = np.random.default_rng(3).normal(size=(60, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    eta = 1.3
    exact = _brute_force_E(L, eta, n, d, omega)
    got = irradiance(project_equirect(image), transmittance_kernel(eta), n)
    assert np.abs(got - exact).max() < 0.04 * exact.max()
    # Up faces see the sky, down faces the ground.
    up = irradiance(project_equirect(image), transmittance_kernel(eta), np.array([[0, 0, 1.0], [0, 0, -1.0]]))
    assert up[0, 0] > 5 * up[1, 0]


def test_equirect_projection_matches_the_lookup_convention():
    """A light brighter along +X (the image centre in Blender's convention) lands in the x coefficient."""
    h, w = 32, 64
    d_img, omega = equirect_directions(h, w)
    assert abs(omega.sum() - 4 * math.pi) < 1e-2
    image = np.repeat(np.clip(d_img[..., :1], 0, None), 3, axis=2)
    c = project_equirect(image)
    assert c[3, 0] > 0.5 and abs(c[1, 0]) < 1e-3 and abs(c[2, 0]) < 1e-3
    # The image agrees with sample_equirect at its own pixel centres.
    np.testing.assert_allclose(sample_equirect(image, d_img), image, atol=1e-6)


def test_projection_in_blocks_of_rows_equals_the_whole():
    """Large HDRIs are projected a block of rows at a time: the same coefficients, to rounding."""
    img = np.random.default_rng(4).random((37, 74, 3))
    d, omega = equirect_directions(37, 74)
    whole = project(d, img, omega)
    np.testing.assert_allclose(project_equirect(img, rows_per_block=5), whole, rtol=1e-12, atol=1e-12)

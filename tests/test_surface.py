"""The materials' surface, pure: the Principled specular layer's maths and the per-corner surface arrays."""
from __future__ import annotations

import numpy as np
import pytest

from translucent_addon.core import surface
from translucent_addon.core.physics import microfacet
from translucent_addon.core.physics.cycles_conversion import random_walk_albedo
from translucent_addon.core.physics.fresnel import fresnel_dielectric


def _hemisphere(n: int):
    """Directions and solid angles of a midpoint grid in (mu, phi) over the upper hemisphere."""
    mu = (np.arange(n) + 0.5) / n
    phi = (np.arange(4 * n) + 0.5) / (4 * n) * 2.0 * np.pi
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - M * M)
    w = np.stack([s * np.cos(P), s * np.sin(P), M], -1).reshape(-1, 3)
    return w, np.full(len(w), 2.0 * np.pi / (4 * n * n))


@pytest.mark.parametrize("roughness", [0.3, 0.6, 1.0])
def test_ggx_distribution_is_normalised(roughness):
    """int D(h) (n . h) dw_h = 1 (Walter Eq. 4): the projected microfacet area is the macro surface's."""
    mu = (np.arange(200_000) + 0.5) / 200_000  # D depends on mu_h alone: 2 pi int D mu dmu
    total = float(2.0 * np.pi * (microfacet.ggx_D(mu, microfacet.alpha_of(roughness)) * mu).mean())
    assert total == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("mu_o,roughness", [(0.7, 0.5), (0.3, 0.8), (0.9, 0.35)])
def test_sampled_albedo_matches_brute_force_integral(mu_o, roughness):
    """E(mu_o) by half-vector sampling (``_albedo``) against int f_s mu_i dw_i on a fine direction grid:
    within 1 % (the grid's own error at these roughnesses is under 0.3 %)."""
    w, dw = _hemisphere(400)
    alpha = microfacet.alpha_of(roughness)
    o = np.array([np.sqrt(1.0 - mu_o**2), 0.0, mu_o])
    h = w + o
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    brute = float((microfacet.single_bounce(w[:, 2], mu_o, h[:, 2], h @ o, alpha, 1.5) * dw).sum())
    sampled = float(microfacet._albedo(np.array(mu_o), np.array(alpha), np.array(1.5)))
    assert sampled == pytest.approx(brute, rel=0.01)


def test_mirror_limit_is_fresnel_and_white_furnace_keeps_energy():
    """Roughness 0: the layer reflects F(mu_o, eta) (a smooth dielectric); F_0 -> 1 (a perfect mirror's Fresnel):
    multiscatter GGX reflects all light at every roughness (what the energy term is for, Turquin 2019), where one
    bounce alone loses up to ~40 % at roughness 1."""
    mu = np.array([0.95, 0.6, 0.3, 0.1])
    f0 = microfacet.f0_of(1.5)
    assert microfacet.specular_albedo(mu, 0.0, f0) == pytest.approx(fresnel_dielectric(mu, 1.5), rel=0.01)
    for r in (0.25, 0.5, 1.0):
        assert microfacet.specular_albedo(mu, r, 0.998) == pytest.approx(1.0, abs=0.02)
    single = microfacet._albedo(np.array(0.3), np.array(microfacet.alpha_of(1.0)), None)
    assert single < 0.75


def test_shipped_table_is_the_computed_one():
    """``data/specular_albedo.npz`` (scripts/tabulate_specular.py) holds E_s at its nodes: recomputed at some."""
    table = microfacet.albedo_table().reshape(microfacet.TABLE_F0, microfacet.TABLE_ROUGHNESS, microfacet.TABLE_MU)
    for m, k, j in ((1, 5, 3), (3, 16, 20), (15, 31, 31), (2, 0, 10)):
        f0 = (m / (microfacet.TABLE_F0 - 1)) ** 2
        r = k / (microfacet.TABLE_ROUGHNESS - 1)
        mu = (j + 0.5) / microfacet.TABLE_MU
        assert table[m, k, j] == pytest.approx(float(microfacet.specular_albedo(mu, r, f0)), abs=2e-4)
    # the lookup the shader copies is exact at the nodes and between them within the table's resolution
    assert microfacet.table_lookup(0.5 / 32, 5 / 31, 1 / 225) == pytest.approx(table[1, 5, 0], abs=1e-6)
    mid = float(microfacet.table_lookup(0.55, 0.45, 0.04))
    assert mid == pytest.approx(float(microfacet.specular_albedo(0.55, 0.45, 0.04)), rel=0.03)


def test_f0_follows_ior_and_ior_level():
    """Principled: F_0 = ((eta - 1) / (eta + 1))^2 x 2 level; its layer's eta gives that F_0 back."""
    assert microfacet.f0_of(1.5, 0.5) == pytest.approx(0.04)
    assert microfacet.f0_of(1.5, 1.0) == pytest.approx(0.08)
    assert microfacet.f0_of(1.5, 0.0) == 0.0
    eta = microfacet.layer_eta(0.08)
    assert ((eta - 1) / (eta + 1)) ** 2 == pytest.approx(0.08)


def test_point_light_peak_of_a_glossy_plane():
    """At the mirror configuration (h = n) the layer sends D(1) G2 F(mu_o) / (4 mu_o) x E mu_i x the energy term:
    the closed form of the peak, alpha = r^2, for normal incidence D(1) = 1 / (pi alpha^2)."""
    r, f0 = 0.4, 0.04
    alpha = r * r
    L = microfacet.point_light_radiance(1.0, 1.0, 1.0, 1.0, r, f0, 2.0)
    expected = 1.0 / (np.pi * alpha**2) * 1.0 * f0 / 4.0 * 2.0 * float(microfacet.energy_scale(1.0, alpha, f0))
    assert float(L) == pytest.approx(expected, rel=1e-3)


def test_sh_lobe_kernel_narrows_with_roughness():
    k = microfacet.sh_lobe_kernel(np.array([0.0, 0.5, 1.0]))
    assert np.allclose(k[0], 1.0, atol=1e-5)
    assert (np.diff(k[:, 2]) < 0).all() and (k[:, 0] == 1.0).all()


# -- the surface arrays -------------------------------------------------------------------------------------------
def _grid(n=4):
    """An n x n grid of quads in z = 0 as triangles, with uv = xy, and its corner vertex indices."""
    xs = np.linspace(0.0, 1.0, n + 1)
    verts = np.array([(x, y, 0.0) for y in xs for x in xs])
    tris = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            tris += [(a, a + 1, a + n + 2), (a, a + n + 2, a + n + 1)]
    corner_vert = np.array(tris).ravel()
    positions = verts[corner_vert].astype(np.float32)
    normals = np.tile([0.0, 0.0, 1.0], (len(positions), 1)).astype(np.float32)
    return positions, normals, positions[:, :2].copy(), corner_vert


def test_corner_tangents_follow_u_and_its_side():
    positions, normals, uv, corner_vert = _grid()
    t = surface.corner_tangents(positions, normals, uv, corner_vert)
    assert np.allclose(t[:, :3], [1.0, 0.0, 0.0], atol=1e-6) and (t[:, 3] == 1.0).all()
    mirrored = uv * [-1.0, 1.0]  # u runs along -x: tangent -x, bitangent (n x t = -y) opposite dP/dv (+y)
    t = surface.corner_tangents(positions, normals, mirrored, corner_vert)
    assert np.allclose(t[:, :3], [-1.0, 0.0, 0.0], atol=1e-6) and (t[:, 3] == -1.0).all()


def test_bilinear_read_repeats_and_hits_texel_centres():
    img = np.zeros((2, 4, 4), np.float32)
    img[..., 0] = np.arange(8).reshape(2, 4)
    uv = np.array([[0.125, 0.25], [0.375, 0.75], [1.125, 0.25], [0.0, 0.25]])
    got = surface.sample_bilinear(img, uv)[:, 0]
    assert np.allclose(got, [0.0, 5.0, 0.0, 1.5])  # last: halfway between texel 3 (wrapped) and texel 0


def test_surface_mean_weighs_by_area():
    positions, normals, uv, corner_vert = _grid(4)
    img = np.zeros((1, 2, 4), np.float32)
    img[0, 0, :3] = (1.0, 0.0, 0.0)  # u < 0.5 red
    img[0, 1, :3] = (0.0, 0.0, 1.0)  # u >= 0.5 blue
    mean = surface.surface_mean(img, uv, positions)
    assert mean == pytest.approx([0.5, 0.0, 0.5], abs=0.02)


def test_mapping_point_and_texture_are_inverse():
    M = surface.mapping_affine((0.25, 0.5, 0.0), 0.3, (2.0, 3.0, 1.0), "POINT")
    uv = np.array([[0.1, 0.2], [0.7, 0.4]])
    moved = surface.apply_mapping(uv, M)
    c, s = np.cos(0.3), np.sin(0.3)
    expected = np.array([[c * 2 * 0.1 - s * 3 * 0.2 + 0.25, s * 2 * 0.1 + c * 3 * 0.2 + 0.5],
                         [c * 2 * 0.7 - s * 3 * 0.4 + 0.25, s * 2 * 0.7 + c * 3 * 0.4 + 0.5]])
    assert np.allclose(moved, expected, atol=1e-6)
    back = surface.apply_mapping(moved, surface.mapping_affine((0.25, 0.5, 0.0), 0.3, (2.0, 3.0, 1.0), "TEXTURE"))
    assert np.allclose(back, uv, atol=1e-6)


def _image(colour_left, colour_right, key="checker"):
    px = np.ones((1, 2, 4), np.float32)
    px[0, 0, :3], px[0, 1, :3] = colour_left, colour_right
    return surface.ImageRef(key, px)


def test_subsurface_factors_are_rho_eff_ratios_and_lambert_ones_colour_ratios():
    """Two slots (left half, right half): a constant colour and a texture. On a subsurface object each factor is
    rho_eff(A) / rho_eff(A_ref) (Cycles' albedo for a Base Color, module doc), A_ref the medium's colour; on a
    Lambert object the colour over the one the base pass drew."""
    positions, normals, uv, corner_vert = _grid(4)
    tri_x = positions.reshape(-1, 3, 3)[:, :, 0].mean(axis=1)
    material_index = (tri_x > 0.5).astype(int)
    slots = [surface.SlotSurface((0.8, 0.5, 0.3)), surface.SlotSurface((0.5, 0.5, 0.5), _image((0.9, 0.2, 0.1),
                                                                                                (0.1, 0.6, 0.9)))]
    palette = np.array([(0.8, 0.5, 0.3), (0.5, 0.4, 0.5)])
    eta = 1.4
    s = surface.surface_of(slots, palette, material_index, {"": uv}, positions, normals, corner_vert, eta=eta,
                           reference=(0.8, 0.5, 0.3))
    left = s.albedo[material_index.repeat(3) == 0]
    assert np.allclose(left[:, :3], 1.0, atol=1e-6) and (left[:, 3] == 0).all()
    right = s.albedo[material_index.repeat(3) == 1]
    assert (right[:, 3] == 1.0).all()
    ref = random_walk_albedo(np.array([0.8, 0.5, 0.3]), eta)
    assert np.allclose(s.albedo_map.pixels[0, 0, :3], random_walk_albedo(np.array([0.9, 0.2, 0.1]), eta) / ref,
                       rtol=1e-5)
    assert s.textured and s.glossy
    lambert = surface.surface_of(slots, palette, material_index, {"": uv}, positions, normals, corner_vert, eta=None,
                                 reference=None)
    assert np.allclose(lambert.albedo_map.pixels[0, 1, :3], np.array([0.1, 0.6, 0.9]) / palette[1], rtol=1e-5)
    assert np.allclose(lambert.gloss[:, 1], 0.04, atol=1e-6)  # IOR 1.5, level 0.5


def test_missing_uv_map_is_said_and_drawn_by_the_mean():
    positions, normals, uv, corner_vert = _grid(2)
    slots = [surface.SlotSurface((0.5, 0.5, 0.5), surface.ImageRef("k", np.ones((1, 1, 4), np.float32), "Other"))]
    s = surface.surface_of(slots, np.array([(0.5, 0.5, 0.5)]), np.zeros(len(positions) // 3, int), {"": uv},
                           positions, normals, corner_vert, eta=None, reference=None)
    assert s.albedo_map is None and not s.textured
    assert any("no UV map 'Other'" in n for n in s.notes)


def test_plain_surface_changes_nothing():
    s = surface.plain(6, 0.0, 0.04, True)
    assert not s.textured and s.glossy
    assert not surface.plain(6).glossy

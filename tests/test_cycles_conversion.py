"""Conversions from our medium to Cycles, and the slab where closed form, brute force and random walk meet.

Stated tolerances (slab under a uniform white world, normal view, 16x16 px x 512 spp, noise ~0.5 %):
* Cycles random walk (converted inputs) vs the dipole closed form: 3 % per channel;
* Cycles brute force (dielectric boundary + volume, 1024 bounces) vs the dipole closed form: 12 %
  (the dipole omits single scattering and is a diffusion approximation: measured +6..8 % at
  alpha' ~ 0.95, -6 % at alpha' = 0.68, skin1 blue);
* random walk vs brute force: 12 %.
Brute force needs albedos well below 1: at alpha' > 0.99 (marble, milk) paths need more than
Cycles' 1024 bounces and the brute force is biased low.
"""
from __future__ import annotations

import numpy as np
import pytest

from translucent_addon.core.physics import cycles_conversion as conversion
from translucent_addon.core.physics.dipole import total_diffuse_reflectance
from translucent_addon.core.physics.fresnel import fresnel_dielectric, hemispherical_transmittance
from translucent_addon.core.physics.presets import load_presets


def test_albedo_fit_inverse_round_trips():
    alpha = np.array([0.2, 0.5, 0.8, 0.95, 0.99])
    for g in (0.0, 0.3):
        A = conversion.base_color_for_albedo(alpha, g)
        np.testing.assert_allclose(conversion.cycles_single_scattering_albedo(A, g), alpha, atol=1e-9)
        assert np.all(np.diff(A) > 0)


def test_random_walk_calibration_inverts_and_interpolates():
    A, rho = conversion.random_walk_calibration()[1.3]
    mid = len(A) // 2
    assert conversion.random_walk_base_color(rho[mid], 1.3) == pytest.approx(A[mid], abs=1e-9)
    # Between two tabulated indices the result lies between their answers.
    a13 = conversion.random_walk_base_color(0.4, 1.3)
    a15 = conversion.random_walk_base_color(0.4, 1.5)
    assert min(a13, a15) - 1e-12 <= conversion.random_walk_base_color(0.4, 1.4) <= max(a13, a15) + 1e-12
    assert 0.85 < conversion.random_walk_max_albedo(1.3) < 0.95


def test_volume_inputs_reproduce_our_coefficients_per_blender_unit():
    v = conversion.volume_inputs((0.01, 0.02, 0.04), (1.0, 2.0, 3.0), 1.4, 0.5, 1000.0)
    sigma_s = np.array(v.scatter_color) * v.scatter_density
    sigma_a = (1 - np.array(v.absorption_color)) * v.absorption_density
    np.testing.assert_allclose(sigma_s, np.array([1.0, 2.0, 3.0]) / 0.5 * 1000)
    np.testing.assert_allclose(sigma_a, [10.0, 20.0, 40.0])
    assert (v.ior, v.anisotropy) == (1.4, 0.5)


@pytest.mark.parametrize("g", [0.0, 0.3, 0.8])
def test_random_walk_inputs_match_diffuse_albedo_and_diffusion_length(g):
    m = load_presets()["skin1"]
    rw = conversion.random_walk_inputs(m.sigma_a, m.sigma_s_prime, m.eta, g, 1000.0)
    rho = (total_diffuse_reflectance(np.array(m.sigma_a), np.array(m.sigma_s_prime), m.eta)
           * hemispherical_transmittance(m.eta))
    np.testing.assert_allclose(rw.target_albedo, rho)
    # Cycles' medium (subsurface_random_walk_remap: sigma_t = 1 / (d (1 - g)), single-scattering albedo alpha_c,
    # phase g) has the same diffusion length 1 / sigma_tr as ours, sigma_tr = sqrt(3 sigma_a sigma_t').
    alpha_c = conversion.cycles_single_scattering_albedo(np.array(rw.base_color), g)
    sigma_t_c = 1.0 / (np.array(rw.radius) * 1000.0 * (1.0 - g))
    sigma_a_c, sigma_s_prime_c = sigma_t_c * (1 - alpha_c), sigma_t_c * alpha_c * (1 - g)
    sigma_tr_c = np.sqrt(3 * sigma_a_c * (sigma_a_c + sigma_s_prime_c))
    sigma_tr = np.sqrt(3 * np.array(m.sigma_a) * (np.array(m.sigma_a) + np.array(m.sigma_s_prime)))
    np.testing.assert_allclose(sigma_tr_c, sigma_tr, rtol=1e-9)


# -- Cycles --------------------------------------------------------------------------------
MEDIA = {
    "skin1": load_presets()["skin1"],
    "custom": load_presets()["skin1"].__class__("custom", (0.05, 0.02, 0.1), (1.0, 0.8, 1.2), 1.3),
}


def _slab_radiance(bpy, scene, material, samples):
    from blender_helpers import render

    from translucent_addon.blender import slab_scene

    slab_scene.build(scene, material)
    slab_scene.configure_cycles(scene, samples)
    return slab_scene.mean_radiance(render(scene, 16, 16))


@pytest.mark.parametrize("name", sorted(MEDIA))
def test_slab_closed_form_brute_force_and_random_walk_agree(scene, name):
    bpy = pytest.importorskip("bpy")
    from translucent_addon.blender import twin_materials

    m = MEDIA[name]
    sa, ss = np.array(m.sigma_a), np.array(m.sigma_s_prime)
    F0 = float(fresnel_dielectric(1.0, m.eta))
    closed = F0 + (1 - F0) * total_diffuse_reflectance(sa, ss, m.eta) * hemispherical_transmittance(m.eta)
    brute = _slab_radiance(bpy, scene, twin_materials.brute_force("bf", sa, ss, m.eta, 0.0, 1000.0), 512)
    bpy.ops.wm.read_homefile(use_empty=True)
    walk = _slab_radiance(bpy, bpy.context.scene, twin_materials.random_walk("rw", sa, ss, m.eta, 0.0, 1000.0), 512)
    print(name, "closed", closed, "brute", brute, "walk", walk)
    np.testing.assert_allclose(walk, closed, rtol=0.03)
    np.testing.assert_allclose(brute, closed, rtol=0.12)
    np.testing.assert_allclose(walk, brute, rtol=0.12)


def test_calibration_table_still_describes_this_cycles(scene):
    """Re-measure two points of data/cycles_random_walk_albedo.csv (2 % of the tabulated albedo)."""
    pytest.importorskip("bpy")
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "scripts" / "calibrate_random_walk.py"
    spec = importlib.util.spec_from_file_location("calibrate_random_walk", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["calibrate_random_walk"] = module
    spec.loader.exec_module(module)
    A_tab, rho_tab = conversion.random_walk_calibration()[1.3]
    for A in (0.3, 0.8):
        measured = module.measure(A, 1.3, samples=512)
        assert measured == pytest.approx(float(np.interp(A, A_tab, rho_tab)), rel=0.02)


def test_brute_force_without_surface_reflection_drops_exactly_the_reflected_world(scene):
    """Under a white world at normal view the boundary reflects F0 of it; the translucency-only brute
    force (what QUADGRAPH's RMSE is measured against) renders the rest. Same seed, 512 spp: 2 %."""
    bpy = pytest.importorskip("bpy")
    from translucent_addon.blender import twin_materials

    m = MEDIA["skin1"]
    sa, ss = np.array(m.sigma_a), np.array(m.sigma_s_prime)
    F0 = float(fresnel_dielectric(1.0, m.eta))
    full = _slab_radiance(bpy, scene, twin_materials.brute_force("bf", sa, ss, m.eta, 0.0, 1000.0), 512)
    bpy.ops.wm.read_homefile(use_empty=True)
    translucency = _slab_radiance(bpy, bpy.context.scene, twin_materials.brute_force(
        "bf", sa, ss, m.eta, 0.0, 1000.0, surface_reflection=False), 512)
    print("full", full, "translucency", translucency, "F0", F0)
    assert np.all(translucency > 0.05)
    np.testing.assert_allclose(translucency, full - F0, rtol=0.02)


@pytest.mark.parametrize("eta", [1.0, 1.3])
def test_brute_force_without_self_interreflection_keeps_light_from_entering_twice(scene, eta):
    """A wall of a thin medium between an area light and a 1 cm cube of a dense one: the cube sees the light
    only through light that left the wall and entered the cube (a camera ray crosses it unscattered with
    probability exp(-20)). With self_interreflection the camera (behind the cube) gets it, without it
    exactly nothing (the world is black)."""
    bpy = pytest.importorskip("bpy")
    from blender_helpers import add_cube, add_light, aim, render, set_world

    from translucent_addon.blender import slab_scene, twin_materials

    images = {}
    for inter in (True, False):
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = bpy.context.scene
        set_world(scene, (0.0, 0.0, 0.0))
        wall = add_cube(scene, "Wall", size=1.0, location=(0.0, 0.0, 0.0))
        wall.scale = (0.02, 0.6, 0.6)  # 2 mean free paths thick
        cube = add_cube(scene, "Cube", size=0.01, location=(0.03, 0.0, 0.0))  # 20 mean free paths
        for ob, sigma_s_prime in ((wall, 0.1), (cube, 2.0)):
            ob.data.materials.clear()
            ob.data.materials.append(twin_materials.brute_force(
                ob.name, (0.001,) * 3, (sigma_s_prime,) * 3, eta, 0.0, 1000.0, self_interreflection=inter))
        add_light(scene, "AREA", (-0.2, 0.0, 0.0), target=(0.0, 0.0, 0.0), energy=50.0, size=0.1)
        cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        cam.data.type = "ORTHO"
        cam.data.ortho_scale = 0.005  # the middle of the cube's far face
        cam.location = (0.5, 0.0, 0.0)
        aim(cam, (0.0, 0.0, 0.0))
        scene.collection.objects.link(cam)
        scene.camera = cam
        slab_scene.configure_cycles(scene, 64)
        images[inter] = slab_scene.mean_radiance(render(scene, 8, 8))
    print(eta, images)
    assert np.all(images[True] > 1e-3)
    np.testing.assert_array_equal(images[False], 0.0)


@pytest.mark.parametrize("eta", [1.0, 1.2, 1.3, 1.45, 1.5])
@pytest.mark.parametrize("g", [0.0, 0.3, -0.2])
def test_principled_to_ours_and_back_holds_within_one_percent(eta, g):
    """Principled -> ours (``medium_from_random_walk``) -> Principled (``random_walk_inputs``): Base Color and
    radius come back within 1 % (measured: 0.2 % at worst, from the calibration's interpolation) wherever
    Cycles' rendered albedo still rises with Base Color (A <= 0.9; above it renders alike, measured)."""
    A = np.array([0.02, 0.1, 0.3, 0.6, 0.8, 0.9])
    for radius_units in (0.0005, 0.01, 0.05, 1.0):
        radius = radius_units * np.array([1.0, 0.5, 0.2])
        for a in A:
            sa, ss = conversion.medium_from_random_walk((a, a, a), radius, eta, g, 1000.0)
            assert np.all(ss > 0) and np.all(sa >= 0)
            back = conversion.random_walk_inputs(sa, ss, eta, g, 1000.0)
            np.testing.assert_allclose(back.base_color, a, rtol=0.01)
            np.testing.assert_allclose(back.radius, radius, rtol=0.01)
            assert back.ior == eta and back.anisotropy == g


def test_ours_to_principled_and_back_is_exact_where_cycles_reaches_the_albedo():
    """Every measured medium whose diffuse albedo Cycles' random walk can render comes back to its
    coefficients; cream and spectralon reflect more than Cycles' walk ever does (0.897) and come back as the
    brightest medium Cycles renders, with their diffusion length."""
    for name, m in load_presets().items():
        rw = conversion.random_walk_inputs(m.sigma_a, m.sigma_s_prime, m.eta, m.g, 250.0)
        sa, ss = conversion.medium_from_random_walk(rw.base_color, rw.radius, rw.ior, rw.anisotropy, 250.0)
        if max(rw.target_albedo) < conversion.random_walk_max_albedo(m.eta):
            np.testing.assert_allclose(sa, m.sigma_a, rtol=1e-6, atol=1e-12, err_msg=name)
            np.testing.assert_allclose(ss, m.sigma_s_prime, rtol=1e-6, err_msg=name)
        else:
            assert name in {"cream", "spectralon"}
            rho = total_diffuse_reflectance(sa, ss, m.eta) * hemispherical_transmittance(m.eta)
            assert rho.max() == pytest.approx(conversion.random_walk_max_albedo(m.eta), rel=0.01)


def test_the_rendered_albedo_and_its_inverse_agree():
    """Exact on the calibration's tables; between them (eta 1.37) each direction interpolates in eta on its own
    side: 6e-5 apart in A at most."""
    for eta in (1.0, 1.3, 1.37, 1.5):
        A = np.linspace(0.0, 0.9, 46)
        rho = conversion.random_walk_albedo(A, eta)
        assert np.all(np.diff(rho) > 0) and rho[0] == 0.0
        np.testing.assert_allclose(conversion.random_walk_base_color(rho, eta), A, atol=1e-9 if eta != 1.37 else 1e-4)

"""TEXTURE_SPACE (Lensch 2002) on the GPU against its CPU twin and the dipole model reference."""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

from blender_helpers import add_camera, add_light, dipole_model_reference, render, set_world  # noqa: E402
from conftest import ext_module  # noqa: E402

RESOLUTION = 192  # atlas texels: a 5 cm ball bakes in a few seconds


def _baked_ball(scene, tr, location=(0, 0, 0.05), preset="skin1", segments=32, rings=16):
    set_world(scene, (0.02, 0.02, 0.025))
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=0.05, location=location)
    ob = bpy.context.active_object
    ob.name = "Ball"
    bpy.ops.object.shade_smooth()
    ob.translucent.preset = preset
    ob.translucent.method = "TEXTURE_SPACE"
    ob.translucent.atlas_resolution = RESOLUTION
    assert bpy.ops.translucent.bake() == {"FINISHED"}
    add_light(scene, "POINT", (0.1, 0.3, 0.25), (0, 0, 0.05), energy=20.0)
    add_camera(scene, (0.0, -0.35, 0.12), (0, 0, 0.05), lens=50)
    scene.translucent.capture_passes = True
    return ob


def _capture(tr):
    return ext_module(tr, "translucent_addon.blender.session").current().capture


def _maps(tr):
    (ts,) = _capture(tr)["texture_space"]
    return ts


def _shifted_and_plain(tr, scene, ob):
    """The illumination pass per texel with and without ``oblique_entry``'s shift (its length set to 0 for
    the second render), the texels' GPU tables, the object's medium and its shift length in world units."""
    shift = ext_module(tr, "translucent_addon.core.physics.oblique_entry")
    data = ext_module(tr, "translucent_addon.techniques.texture_space.model")
    render(scene, 64, 48)
    ts = _maps(tr)
    atlas, _ = data.load(ts["arrays"])
    x, y = atlas.texel_xy[:, 0], atlas.texel_xy[:, 1]
    shifted = ts["irradiance"][y, x, :3].astype(np.float64)
    medium_shift = shift.medium_shift_mm
    try:
        shift.medium_shift_mm = lambda medium: np.zeros(3)
        render(scene, 64, 48)
    finally:
        shift.medium_shift_mm = medium_shift
    plain = _maps(tr)["irradiance"][y, x, :3].astype(np.float64)
    t = data.gpu_tables(ts["arrays"], ob.translucent.mm_per_unit)
    medium = next(m.medium for m in _capture(tr)["frame"].meshes if m.name == ob.name)
    return t, shifted, plain, medium, shift.medium_shift_mm(medium) / medium.mm_per_unit


def _object_shape_operators(t):
    """The texels' symmetric shape operators (N, 3, 3) in object space, unpacked here independently of
    ``oblique_entry.unpacked_shape`` (diagonal, then xy, xz, yz)."""
    S = np.zeros((len(t.curvature_d), 3, 3))
    S[:, [0, 1, 2], [0, 1, 2]] = t.curvature_d
    S[:, [0, 0, 1], [1, 2, 2]] = t.curvature_o
    S[:, [1, 2, 2], [0, 0, 1]] = t.curvature_o
    return S


def test_gpu_passes_equal_the_cpu_twin_of_the_same_irradiance(tr, scene):
    """Filter (Eq. 15), gather (Eq. 10), sparse product (Eq. 11) and interpolation (Eq. 12) on the GPU
    equal texture_space_data.frame_radiosity on the captured illumination map: 1e-3 relative."""
    _baked_ball(scene, tr)
    render(scene, 64, 48)
    ts = _maps(tr)
    data = ext_module(tr, "translucent_addon.techniques.texture_space.model")
    atlas, _ = data.load(ts["arrays"])
    x, y = atlas.texel_xy[:, 0], atlas.texel_xy[:, 1]
    E = ts["irradiance"][y, x, :3]
    assert E.max() > 1.0 and np.isfinite(E).all(), "the light reaches the ball"
    local, glob, through = data.frame_radiosity(ts["arrays"], E, T_p_vertex=ts["T_p_vertex"])
    gpu_local, gpu_global, gpu_through = ts["local"][y, x, :3], ts["global"][y, x, :3], ts["through"][y, x, :3]
    assert np.all(ts["local"][y, x, 3] == 1.0)
    for gpu_values, cpu in ((gpu_local, local), (gpu_global, glob), (gpu_through, through)):
        assert cpu.max() > 0
        np.testing.assert_allclose(gpu_values, cpu, rtol=1e-3, atol=1e-4 * cpu.max())
    # Light crosses the 10 cm ball: part of the global response, not all of it.
    assert 0.0 < through.sum() < 0.5 * glob.sum()
    # The far field (cluster gather and the clusters' entries) is in what was compared: without it the twin
    # differs from the GPU well past that tolerance.
    near_only = {k: a for k, a in ts["arrays"].items() if not k.startswith(("lensch_G_", "lensch_clusters"))}
    _, glob_near, _ = data.frame_radiosity(near_only, E, T_p_vertex=ts["T_p_vertex"])
    assert not np.allclose(gpu_global, glob_near, rtol=1e-3, atol=1e-4 * glob.max())


def test_light_entering_at_an_angle_is_read_where_it_entered(tr, scene):
    """The illumination pass reads each texel's light where it entered (``oblique_entry``, as IMAGE_SPACE): the
    GPU's irradiance with the shift over the same pass without it equals ``entering_cosine`` over cos_i from the
    texels' normals and shape operators (``gpu_tables``) to 2 % on the lit ball (skin1: ell about 1 mm on a
    5 cm ball); the shift moves the light by more than that somewhere."""
    ob = _baked_ball(scene, tr)
    shift = ext_module(tr, "translucent_addon.core.physics.oblique_entry")
    t, shifted, plain, medium, ell = _shifted_and_plain(tr, scene, ob)
    M = np.array(ob.matrix_world)
    world = t.position @ M[:3, :3].T + M[:3, 3]
    normals = t.normal @ np.linalg.inv(M[:3, :3])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    S = _object_shape_operators(t)  # object space = world space here up to the translation
    light = next(np.array(o.location) for o in bpy.data.objects if o.type == "LIGHT")
    to_light = light - world
    to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
    cos_i = np.sum(to_light * normals, axis=1)
    expected = shift.entering_cosine(to_light, normals, S, ell, medium.eta) / np.maximum(cos_i, 1e-30)[:, None]
    lit = (plain > 0.05 * plain.max()).all(axis=1) & (cos_i > 0.2)
    assert lit.sum() > 500
    measured = shifted[lit] / plain[lit]
    np.testing.assert_allclose(measured, expected[lit], rtol=0.02)
    assert np.abs(measured - 1.0).max() > 0.02


def test_light_entering_a_stretched_ball_is_read_with_its_world_curvature(tr, scene):
    """A non-uniformly scaled object (a 10 mm ball stretched 3 times along z): the texels' shape operators go
    to world space as S_w = P N S N^T P / |N n| (N the normal matrix, P the world tangent plane's projector,
    ``world_shape_operator``); without P, N dN leaves the tangent plane and the shift reads the light from the
    wrong place. The GPU's irradiance with the shift over the pass without it equals ``entering_cosine`` with
    that S_w to 2 % (measured: 0.19 % at most over 7,988 lit texels, where the shift moves the light by up to
    63 %), and S_w without P differs by more than 5 % somewhere on the lit side (measured 7.0 %; the GPU
    without P failed on 10 % of the values)."""
    set_world(scene, (0.02, 0.02, 0.025))
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.005, location=(0, 0, 0))
    ob = bpy.context.active_object
    ob.name = "Ball"
    ob.scale = (1.0, 1.0, 3.0)
    bpy.ops.object.shade_smooth()
    ob.translucent.preset = "skin1"
    ob.translucent.method = "TEXTURE_SPACE"
    ob.translucent.atlas_resolution = RESOLUTION
    assert bpy.ops.translucent.bake() == {"FINISHED"}
    light = add_light(scene, "POINT", (0.02, 0.03, 0.025), (0, 0, 0), energy=2.0)
    camera = add_camera(scene, (0.0, -0.08, 0.01), (0, 0, 0), lens=50)
    camera.data.clip_start = 0.001  # 8 cm away: in view (an object the camera cannot see is not lit)
    scene.translucent.capture_passes = True
    shift = ext_module(tr, "translucent_addon.core.physics.oblique_entry")
    t, shifted, plain, medium, ell = _shifted_and_plain(tr, scene, ob)
    M = np.array(ob.matrix_world)[:3, :3]
    N = np.linalg.inv(M).T
    world = t.position @ M.T + np.array(ob.matrix_world)[:3, 3]
    Nn = t.normal @ N.T
    length = np.linalg.norm(Nn, axis=1)
    normals = Nn / length[:, None]
    unprojected = np.einsum("ij,njk,lk->nil", N, _object_shape_operators(t), N) / length[:, None, None]
    P = np.eye(3)[None] - normals[:, :, None] * normals[:, None, :]
    S_world = P @ unprojected @ P
    to_light = np.array(light.location) - world
    to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
    cos_i = np.sum(to_light * normals, axis=1)
    over = np.maximum(cos_i, 1e-30)[:, None]
    expected = shift.entering_cosine(to_light, normals, S_world, ell, medium.eta) / over
    without_P = shift.entering_cosine(to_light, normals, unprojected, ell, medium.eta) / over
    lit = (plain > 0.05 * plain.max()).all(axis=1) & (cos_i > 0.2)
    assert lit.sum() > 500
    measured = shifted[lit] / plain[lit]
    assert np.abs(without_P[lit] / expected[lit] - 1.0).max() > 0.05
    np.testing.assert_allclose(measured, expected[lit], rtol=0.02)


def test_a_facet_turned_away_from_the_light_gets_only_the_world(tr, scene):
    """On a coarse smooth ball the terminator runs inside facets: texels whose interpolated normal
    still faces the lamp but whose facet does not get the world's irradiance only (as the base
    pass, the dipole model and Cycles' shadow rays see them); texels just across, on facets facing
    the lamp at the same normal angles, are lit."""
    ob = _baked_ball(scene, tr, segments=10, rings=6)
    render(scene, 64, 48)
    ts = _maps(tr)
    data = ext_module(tr, "translucent_addon.techniques.texture_space.model")
    t = data.gpu_tables(ts["arrays"], ob.translucent.mm_per_unit)
    M = np.array(ob.matrix_world)
    p = t.position @ M[:3, :3].T + M[:3, 3]
    to_light = np.array(bpy.data.objects["POINT light"].location) - p
    to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
    cos_n = np.einsum("ij,ij->i", t.normal @ np.linalg.inv(M[:3, :3]), to_light)
    cos_g = np.einsum("ij,ij->i", t.facet @ np.linalg.inv(M[:3, :3]), to_light)
    E = ts["irradiance"][t.texel[:, 1].astype(int), t.texel[:, 0].astype(int), :3]
    world = np.median(E[cos_n < -0.3], axis=0)  # a uniform world: the same everywhere
    turned = (cos_g < -0.01) & (cos_n > 0.02)
    assert turned.sum() > 50
    np.testing.assert_allclose(E[turned], np.broadcast_to(world, E[turned].shape), rtol=1e-3)
    across = (cos_g > 0.01) & (cos_n > 0.02) & (cos_n < cos_n[turned].max())
    assert across.sum() > 50 and np.median(E[across][:, 0]) > 1.5 * world[0]


def test_cpu_product_draws_the_same_image_as_the_gpu_product(tr, scene):
    ob = _baked_ball(scene, tr)
    meta = ext_module(tr, "translucent_addon.blender.bake_files").read_meta(ob, "TEXTURE_SPACE")
    split = ext_module(tr, "translucent_addon.techniques.texture_space.model").ROW_SPLIT
    assert meta["form_factors"] > 2 * split  # row starts with a high half: the shader joins both halves
    gpu_image = render(scene, 64, 48)
    scene.translucent.texture_product = "CPU"
    cpu_image = render(scene, 64, 48)
    assert gpu_image[..., :3].max() > 0.01
    np.testing.assert_allclose(cpu_image, gpu_image, rtol=1e-4, atol=1e-6)


def test_moving_the_light_re_renders_without_a_new_bake(tr, scene):
    ob = _baked_ball(scene, tr)
    store = ext_module(tr, "translucent_addon.blender.bake_files")
    digest = store.stored_hash(ob, "TEXTURE_SPACE")
    before = render(scene, 64, 48)
    light = bpy.data.objects["POINT light"]
    light.location = (-0.3, -0.1, 0.2)
    after = render(scene, 64, 48)
    assert store.stored_hash(ob, "TEXTURE_SPACE") == digest
    assert not _capture(tr)["frame"].warnings
    ball = after[..., 3] > 0
    assert np.abs(after - before)[..., :3].max() > 0.05, "the lighting moved"
    assert np.isfinite(after).all() and ball.any()


def test_a_stale_bake_is_not_drawn_silently(tr, scene):
    ob = _baked_ball(scene, tr)
    ob.translucent.sigma_a = (0.1, 0.2, 0.3)
    render(scene, 32, 24)
    warnings = _capture(tr)["frame"].warnings
    assert any("TEXTURE_SPACE bake is stale" in w for w in warnings), warnings
    assert "texture_space" not in _capture(tr)


def test_discretisation_error_against_the_dipole_model(tr, scene):
    """Back-lit ball, atlas 192: measured 5.75 % relative RMSE (mean +0.5..2.4 %), nearly all of it on the
    lit rim. The issue's goal is 5 %: not reached yet; this guards the measured level against regressions."""
    _baked_ball(scene, tr)
    w, h = 96, 72
    img = render(scene, w, h)
    metrics = ext_module(tr, "translucent_addon.core.metrics")
    ref, mask = dipole_model_reference(tr, "Ball", w, h, lean=False)  # TEXTURE_SPACE's own model
    err = metrics.relative_rmse(img, ref, mask)
    ratio = img[mask][:, :3].sum(0) / ref[mask][:, :3].sum(0)
    print(f"TEXTURE_SPACE vs dipole model: relative RMSE {err:.4f}, mean ratio {ratio}")
    assert np.isfinite(img).all() and img[mask][:, :3].max() > 0.01
    assert np.all(np.abs(ratio - 1.0) < 0.04)
    assert err < 0.065


def test_environment_light_follows_the_sky_and_matches_the_dipole_model(tr, scene):
    """No lamp, a sky over a dark ground (an Environment Texture): the illumination pass takes the world's
    spherical-harmonics irradiance per texel (Shah Eq. 6.19), so the top of the ball is brighter than its
    bottom, and the image is within 5 % of the CPU dipole model with the same world."""
    from test_image_space import _sky_image

    from translucent_addon.blender.demo import environment_world

    ob = _baked_ball(scene, tr)
    for light in [o for o in scene.objects if o.type == "LIGHT"]:
        bpy.data.objects.remove(light)
    environment_world(scene, _sky_image())
    bpy.data.objects["Camera"].location = (0.0, -0.35, 0.05)
    w, h = 96, 72
    img = render(scene, w, h)
    metrics = ext_module(tr, "translucent_addon.core.metrics")
    ref, mask = dipole_model_reference(tr, ob.name, w, h)
    err = metrics.relative_rmse(img, ref, mask)
    rows = np.nonzero(mask.any(axis=1))[0]
    top = img[rows[-6]][mask[rows[-6]]][:, 0].mean()
    bottom = img[rows[5]][mask[rows[5]]][:, 0].mean()
    print(f"TEXTURE_SPACE under a sky: rel. RMSE {err:.4f}, top {top:.3f}, bottom {bottom:.3f}")
    assert np.isfinite(img).all()
    assert top > 2.0 * bottom
    assert err < 0.05

"""Height fields (Shah ch. 3) in the engine: the GPU search equals the NumPy twin from the same rays,
interval mapping needs fewer refinements than relief mapping, self-shadowing darkens under a low sun."""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

from blender_helpers import add_camera, add_light, diffuse_material, render, set_world  # noqa: E402
from conftest import ext_module  # noqa: E402

DEPTH = 0.06


def _height_image(height: np.ndarray):
    h, w = height.shape
    img = bpy.data.images.new("Height", w, h, float_buffer=True)
    rgba = np.repeat(height[..., None], 4, axis=-1).astype(np.float32)
    rgba[..., 3] = 1.0
    img.pixels.foreach_set(rgba.reshape(-1))
    return img


def _relief_plane(tr, scene, mode="INTERVAL", field="bumps"):
    im = ext_module(tr, "translucent_addon.techniques.relief.model")
    height = getattr(im, field)(64).astype(np.float32)
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0, 0, 0))
    ob = bpy.context.active_object
    ob.data.materials.append(diffuse_material("Stone", (0.6, 0.55, 0.5)))
    s = ob.translucent
    s.relief, s.relief_image, s.relief_depth = mode, _height_image(height), DEPTH
    s.relief_linear_steps, s.relief_iterations = 5, 10
    return ob, height, im


def _rays(tr, w, h):
    """Each pixel centre's ray from the last F12's camera, and where it meets the plane z = 0."""
    frame = ext_module(tr, "translucent_addon.blender.session").current().capture["frame"]
    a, d = ext_module(tr, "translucent_addon.core.geometry.camera").pixel_rays(frame.camera.view_proj, w, h)
    t = -a[..., 2] / d[..., 2]
    return a + t[..., None] * d, d


def test_gpu_search_equals_the_numpy_twin(tr, scene):
    """From each pixel's ray the shader finds the hit the NumPy twin finds: hit depth within 2e-3 layer
    thicknesses and the same refinement count for 97 % of the pixels, in both modes."""
    set_world(scene, (0.2, 0.2, 0.2))
    ob, height, im = _relief_plane(tr, scene)
    add_light(scene, "SUN", (0.3, -0.4, 1.0), energy=2.0)
    add_camera(scene, (0.0, -0.9, 0.8), (0.0, 0.0, 0.0), lens=50.0)
    scene.translucent.capture_passes = True
    scene.translucent.relief_output = 1
    for mode, name in ((0, "INTERVAL"), (1, "RELIEF")):
        ob.translucent.relief = name
        img = render(scene, 64, 64)
        p, d = _rays(tr, 64, 64)
        on = (np.abs(p[..., :2]) < 0.49).all(-1)
        uv0 = p[on][:, :2] + 0.5
        V = -d[on]
        dir_uv = im.view_dir_uv(V, DEPTH)
        hit = im.intersect(height, uv0, dir_uv, linear_steps=5, max_iter=10, threshold=1e-3,
                           mode="interval" if mode == 0 else "relief")
        got = img[on]
        assert np.mean(np.abs(got[:, 2] - hit.depth) < 2e-3) > 0.97, name
        assert np.mean(got[:, 3] == hit.iterations) > 0.97, name
        assert np.allclose(got[:, :2], hit.uv, atol=2e-3 * np.abs(dir_uv).max() + 1e-4)
    scene.translucent.relief_output = 0


def test_interval_mapping_needs_fewer_refinements(tr, scene):
    set_world(scene, (0.2, 0.2, 0.2))
    ob, _, _ = _relief_plane(tr, scene, field="rocks")
    add_light(scene, "SUN", (0.3, -0.4, 1.0), energy=2.0)
    add_camera(scene, (0.0, -0.9, 0.8), (0.0, 0.0, 0.0), lens=50.0)
    scene.translucent.relief_output = 1
    counts = {}
    for name in ("INTERVAL", "RELIEF"):
        ob.translucent.relief = name
        img = render(scene, 48, 48)
        counts[name] = img[..., 3][img[..., 3] > 0].mean()
    scene.translucent.relief_output = 0
    assert counts["INTERVAL"] < 0.6 * counts["RELIEF"], counts


def test_self_shadowing_and_displacement_change_the_image(tr, scene):
    """Under a low sun the height field casts shadows on itself (darker than without), and the flat plane
    (height field off) is one flat colour where the relief is not."""
    set_world(scene, (0.0, 0.0, 0.0))
    ob, _, _ = _relief_plane(tr, scene, field="bricks")
    add_light(scene, "SUN", (1.0, 0.0, 0.25), energy=3.0)
    add_camera(scene, (0.0, -0.8, 0.9), (0.0, 0.0, 0.0), lens=50.0)
    shadowed = render(scene, 64, 64)
    ob.translucent.relief_shadows = False
    lit = render(scene, 64, 64)
    ob.translucent.relief = "OFF"
    flat = render(scene, 64, 64)
    centre = (slice(20, 44), slice(20, 44))

    assert np.all(np.isfinite(shadowed)) and shadowed[centre][..., 0].max() > 0
    s_c, l_c = shadowed[centre][..., 0], lit[centre][..., 0]
    assert np.all(s_c <= l_c + 1e-6)  # shadowing only removes light
    assert s_c.mean() < 0.92 * l_c.mean() and np.mean(s_c < 0.5 * l_c) > 0.05  # the grooves beside the bricks
    assert np.ptp(flat[centre][..., 0]) < 1e-3 * flat[centre][..., 0].mean() + 1e-6
    assert np.ptp(lit[centre][..., 0]) > 0.2 * lit[centre][..., 0].mean()


def test_height_field_without_uvs_or_image_says_so(tr, scene):
    extract = ext_module(tr, "translucent_addon.blender.extract")
    set_world(scene, (0.1, 0.1, 0.1))
    me = bpy.data.meshes.new("NoUV")
    me.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    ob = bpy.data.objects.new("NoUV", me)
    scene.collection.objects.link(ob)
    ob.translucent.relief = "INTERVAL"
    add_light(scene, "SUN", (0, 0, 1), energy=1.0)
    add_camera(scene, (0.3, -1.0, 1.0), (0.3, 0.3, 0.0))
    frame = extract.frame_inputs(bpy.context.evaluated_depsgraph_get(), extract.render_camera(
        bpy.context.evaluated_depsgraph_get(), 16, 16))
    assert "'NoUV': height field has no height map; drawn flat" in frame.warnings
    ob.translucent.relief_image = _height_image(np.ones((4, 4), np.float32))
    frame = extract.frame_inputs(bpy.context.evaluated_depsgraph_get(), extract.render_camera(
        bpy.context.evaluated_depsgraph_get(), 16, 16))
    assert "'NoUV': a height field needs a UV map; drawn flat" in frame.warnings


def test_height_map_is_read_once_until_it_changes(tr, scene, tmp_path):
    """The viewport does not re-read a large height map every frame; a changed (dirty) image is read again.
    The map is saved first, as an artist's is: an image made and filled in this session stays dirty."""
    extract = ext_module(tr, "translucent_addon.blender.extract")
    heights_of = ext_module(tr, "translucent_addon.techniques.relief.model").heights_of
    img = _height_image(np.full((8, 8), 0.25, np.float32))
    img.filepath_raw = str(tmp_path / "height.exr")
    img.file_format = "OPEN_EXR"
    img.save()
    assert not img.is_dirty
    (a, digest_a), name = extract.image_data(img, heights_of)
    assert name == img.name
    assert extract.image_data(img, heights_of)[0][0] is a  # cached: the same array, not read again
    rgba = np.ones(8 * 8 * 4, np.float32)
    img.pixels.foreach_set(rgba)
    img.update()
    assert img.is_dirty
    (b, digest_b), _ = extract.image_data(img, heights_of)
    assert np.allclose(a, 0.25) and np.allclose(b, 1.0) and digest_a != digest_b

"""Grass fields (Shah ch. 4) in the engine: the operator bakes a BTF, the GPU pass equals the NumPy
twin, blades hide what they stand in front of, gaps show what is behind, crests show silhouettes."""
from __future__ import annotations

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

from blender_helpers import add_camera, add_light, add_mesh, diffuse_material, render, set_world  # noqa: E402
from conftest import ext_module  # noqa: E402

TILE, HEIGHT = 0.1, 0.045


def _grass_settings(ob, resolution="64", target=0.5):
    s = ob.translucent
    s.grass_tile, s.grass_blade_height, s.grass_blades, s.grass_seed = TILE, HEIGHT, 500, 7
    s.grass_resolution, s.grass_target_error = resolution, target
    s.grass_lod = 0.0


def _ground(scene, size=1.0, name="Ground"):
    h = size / 2
    return add_mesh(scene, name, [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], [(0, 1, 2, 3)], (0.3, 0.2, 0.1))


@pytest.fixture(scope="module")
def btf_record(installed):
    """One BTF (64 texels) baked through Add Grass Field, reused by the tests of this module."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    ob = _ground(scene)
    _grass_settings(ob)
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.translucent.add_grass_field() == {"FINISHED"}
    store = __import__(f"{installed}.translucent_addon.blender.bake_files", fromlist=["x"])
    record = store.read(ob, "GRASS")
    assert ob.translucent.grass and record is not None
    return record


def _field(tr, scene, record, ob=None):
    ob = ob or _ground(scene)
    _grass_settings(ob)
    ob.translucent.grass = True
    store = ext_module(tr, "translucent_addon.blender.bake_files")
    store.write(ob, "GRASS", record.inputs_hash, record.arrays, record.meta)
    return ob


def test_bake_records_what_it_made(btf_record):
    meta = btf_record.meta
    assert meta["images"] == 81 * 21 and meta["resolution"] == 64
    n_y, n_c = meta["counts"]
    assert 0 < n_c < n_y and meta["total_error"] <= 0.5 and meta["target_met"]
    assert btf_record.arrays["basis_Y"].shape == (64, 64, 1 + n_y)
    assert meta["storage"]["total"] < meta["uncompressed_bytes"]


def test_grass_pass_equals_its_numpy_twin(tr, scene, btf_record):
    """Flat field under a sun, black world: every blade pixel equals E * BTF(uv, w_v, w_l) of the twin
    (three nearest views and lights, hit-weighted wrapped bilinear) within 1 % for 98 % of the pixels
    that both call blade pixels; the two agree on which pixels are gaps for 99 %."""
    set_world(scene, (0.0, 0.0, 0.0))
    _field(tr, scene, btf_record)
    sun = add_light(scene, "SUN", (0.4, -0.3, 1.0), energy=3.0)
    add_camera(scene, (0.0, -0.45, 0.3), (0.0, 0.0, 0.0), lens=50.0)
    scene.translucent.capture_passes = True
    img = render(scene, 64, 64)
    frame = ext_module(tr, "translucent_addon.blender.session").current().capture["frame"]
    grass_btf = ext_module(tr, "translucent_addon.techniques.grass.bake")
    grass_data = ext_module(tr, "translucent_addon.techniques.grass.model")
    cb = grass_btf.from_arrays(btf_record.arrays, btf_record.meta)
    camera = ext_module(tr, "translucent_addon.core.geometry.camera")
    origin, d = camera.pixel_rays(frame.camera.view_proj, frame.camera.width, frame.camera.height)
    h = cb.height * TILE
    t = (h - origin[..., 2]) / d[..., 2]
    shell = origin + t[..., None] * d
    inside = (t > 0) & (np.abs(shell[..., :2]) < 0.5).all(-1)
    uv = shell[inside][:, :2] / TILE
    to_eye = -d[inside]
    to_light = np.array(sun.matrix_world.to_quaternion() @ __import__("mathutils").Vector((0, 0, 1)))
    rgb, cov, _ = grass_data.shade(cb, uv, to_eye, to_light)
    expected = 3.0 * rgb  # the sun's irradiance facing it, no shadows in this scene
    got = img[inside][:, :3]
    sure = np.abs(cov - 0.5) > 0.05
    blade_cpu = cov >= 0.5
    # A gap shows the ground, lit by the base pass; a blade pixel shows the BTF.
    ground = 0.3 * 3.0 * to_light[2] / math.pi
    blade_gpu = np.abs(got[:, 0] - ground) > 1e-3 * ground
    assert np.mean(blade_gpu[sure] == blade_cpu[sure]) > 0.99
    both = sure & blade_cpu & blade_gpu
    assert both.sum() > 0.3 * inside.sum()
    rel = np.abs(got[both] - expected[both]).max(axis=1) / np.maximum(expected[both].max(axis=1), 1e-6)
    assert np.mean(rel < 0.01) > 0.98, np.percentile(rel, [50, 90, 99])


def test_blades_hide_a_sunk_ball_and_gaps_show_it(tr, scene, btf_record):
    """A red ball half sunk in the field: blades in front of its lower part hide much of it, gaps
    between them still show some of it, and its top (above the blades) is untouched."""
    set_world(scene, (0.2, 0.2, 0.2))
    ground = _ground(scene)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.05, location=(0, 0, 0), segments=48, ring_count=24)
    ball = bpy.context.active_object
    ball.data.materials.append(diffuse_material("Red", (0.8, 0.02, 0.02)))
    add_light(scene, "SUN", (0.3, -0.5, 1.0), energy=3.0)
    add_camera(scene, (0.0, -0.3, 0.25), (0.0, 0.0, 0.0), lens=70.0)

    def red_mask():
        img = render(scene, 96, 96)
        return (img[..., 0] > 2.0 * img[..., 1] + 0.02) & (img[..., 0] > 0.05)

    bare = red_mask()
    _field(tr, scene, btf_record, ground)
    grassy = red_mask()

    assert bare.sum() > 300
    rows = np.nonzero(bare.any(axis=1))[0]
    low = np.zeros_like(bare)
    low[rows[0]:rows[0] + (rows[-1] - rows[0]) // 3] = True  # lowest third of the ball on screen
    top = np.zeros_like(bare)
    top[rows[-1] - (rows[-1] - rows[0]) // 6:] = True  # its top sixth, above the blades
    assert (grassy & low).sum() < 0.6 * (bare & low).sum()  # hidden by blades
    assert (grassy & low).sum() > 0.02 * (bare & low).sum()  # seen through gaps
    assert (grassy & top).sum() >= 0.9 * (bare & top).sum()


def test_crest_shows_a_grass_silhouette(tr, scene, btf_record):
    """A round hill seen along its crest against a blue sky: the layer stands above the soil's outline,
    and along its top some pixels are grass and some are sky (gaps), where the bare hill shows only sky."""
    set_world(scene, (0.1, 0.2, 0.8))
    bpy.ops.mesh.primitive_cylinder_add(radius=0.3, depth=1.0, vertices=96, location=(0, 0, -0.25),
                                        rotation=(0.0, math.pi / 2, 0.0))
    hill = bpy.context.active_object
    bpy.ops.object.transform_apply(location=False, rotation=True, scale=False)
    add_light(scene, "SUN", (0.2, -0.4, 1.0), energy=3.0)
    add_camera(scene, (0.0, -2.0, 0.07), (0.0, 0.0, 0.07), lens=400.0)
    bare = render(scene, 128, 96)
    _field(tr, scene, btf_record, hill)
    grassy = render(scene, 128, 96)
    sky = lambda img: (img[..., 2] > 0.5 * 0.8) & (img[..., 1] < 0.5 * img[..., 2])  # noqa: E731
    cols = slice(16, 112)
    soil_top = np.nonzero((~sky(bare)[:, cols]).any(axis=1))[0][-1]
    layer_top = np.nonzero((~sky(grassy)[:, cols]).any(axis=1))[0][-1]
    assert layer_top > soil_top + 10  # the layer stands on the hill (45 mm are about 32 pixels here)
    band = slice(layer_top - 3, layer_top + 1)
    assert sky(bare)[band, cols].all()
    share_sky = sky(grassy)[band, cols].mean()
    assert 0.05 < share_sky < 0.95, share_sky
    # The ground's curvature lets rays leave the layer before their blade (grass/btf.glsl): the top row is
    # mostly sky (measured 0.70; 0.42 from the depth maps' gaps alone).
    assert sky(grassy)[layer_top, cols].mean() > 0.55


def test_grass_without_a_current_btf_says_so(tr, scene):
    set_world(scene, (0.1, 0.1, 0.1))
    ob = _ground(scene)
    _grass_settings(ob)
    ob.translucent.grass = True
    add_light(scene, "SUN", (0.0, 0.0, 1.0), energy=1.0)
    add_camera(scene, (0.0, -1.0, 0.5), (0.0, 0.0, 0.0))
    extract = ext_module(tr, "translucent_addon.blender.extract")

    def grass_and_warnings():
        depsgraph = bpy.context.evaluated_depsgraph_get()
        frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, 16, 16))
        ground = next(m for m in frame.meshes if m.name == "Ground")
        return ground.extras.get("GRASS"), [w for w in frame.warnings if "grass" in w]

    assert grass_and_warnings() == (None, ["'Ground': grass BTF is missing; no grass drawn. Press Bake Grass BTF"])
    ob.translucent.grass_blade_height = 0.09
    assert grass_and_warnings() == (None, [
        "'Ground': blade height must be 5-60 % of the tile (is 90 %): taller blades reach beyond the tiles the BTF "
        "renders around each tile; no grass drawn. Press Bake Grass BTF"])
    bpy.context.view_layer.objects.active = ob
    with pytest.raises(RuntimeError, match="blade height must be 5-60 % of the tile"):
        bpy.ops.translucent.bake_grass_btf()

"""Inward-wound meshes: each closed part is turned outward by its signed volume, in every method, bake and twin."""
from __future__ import annotations

import numpy as np
import pytest

from translucent_addon.core.geometry.orientation import orient_outward, outward_normals, turned


def _ball(centre=(0.0, 0.0, 0.0), radius=1.0, levels=2):
    from test_quadgraph import icosphere

    v, f = icosphere(levels, radius)
    return v + np.asarray(centre), f


def test_an_outward_ball_is_kept_and_an_inward_one_is_turned():
    v, f = _ball()
    kept = orient_outward(v, f)
    assert (kept.parts, kept.turned) == (1, 0) and not kept.flip.any()
    turned = orient_outward(v, f[:, ::-1])
    assert (turned.parts, turned.turned) == (1, 1) and turned.flip.all()
    assert "'Ball': the mesh is wound inward" in turned.message("Ball")
    assert kept.message("Ball") is None


def test_each_part_is_decided_on_its_own_and_open_sheets_are_left_alone():
    """Two balls far from the origin (one inward) and a plane: only the inward ball turns, whatever the origin."""
    v1, f1 = _ball((10.0, 0.0, 0.0))
    v2, f2 = _ball((-10.0, 5.0, 0.0), radius=0.3)
    plane_v = np.array([[0, 0, 3], [1, 0, 3], [1, 1, 3], [0, 1, 3]], float)
    plane_f = np.array([[0, 1, 2], [0, 2, 3]])
    v = np.concatenate([v1, v2, plane_v])
    f = np.concatenate([f1, f2[:, ::-1] + len(v1), plane_f[:, ::-1] + len(v1) + len(v2)])
    o = orient_outward(v, f)
    assert (o.parts, o.turned) == (2, 1)
    assert not o.flip[: len(f1)].any() and o.flip[len(f1): len(f1) + len(f2)].all()
    assert not o.flip[len(f1) + len(f2):].any(), "a sheet has no inside: its winding is kept"
    assert "1 of its 2 closed parts are wound inward" in o.message("Pair")


def test_turning_reorders_corners_and_points_computed_normals_out():
    v, f = _ball()
    inward = f[:, ::-1]
    corners = v[inward]  # (T, 3, 3)
    facet_in = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals = np.repeat((facet_in / np.linalg.norm(facet_in, axis=1, keepdims=True))[:, None], 3, axis=1)
    o = orient_outward(v, inward)
    turned_corners = turned(o.flip, corners)
    n = outward_normals(turned_corners, turned(o.flip, normals), o.flip)
    centroid_dir = turned_corners.mean(axis=1)
    assert np.all(np.einsum("tij,tj->ti", n, centroid_dir) > 0), "every corner normal points away from the centre"
    custom_out = -normals  # custom normals that already point out are kept
    kept = outward_normals(turned_corners, custom_out, o.flip)
    np.testing.assert_array_equal(kept, custom_out)


@pytest.fixture
def _bpy():
    return pytest.importorskip("bpy")


def _scene_with_ball(tr, scene, method):
    import bpy as b
    from blender_helpers import add_camera, add_light, set_world
    from conftest import ext_module

    set_world(scene, (0.03, 0.03, 0.035))
    b.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=0.04, location=(0, 0, 0.05))
    ob = b.context.active_object
    ob.name = "Ball"
    b.ops.object.shade_smooth()
    ob.translucent.preset = "skin1"
    ob.translucent.method = method
    if method == "TEXTURE_SPACE":
        ob.translucent.atlas_resolution = 128
    if method == "GEOCUBE":  # it refracts the world: a gradient to see through, a small cube map
        h, w = 32, 64
        sky = np.linspace(0.05, 1.0, h)[:, None, None] * np.linspace([1.0, 0.6, 0.3], [0.3, 0.6, 1.0], w)[None]
        ext_module(tr, "translucent_addon.blender.demo").environment_world(scene, sky)
        ob.translucent.geocube_resolution = 32
    scene.render.film_transparent = True  # the ball's pixels: alpha 1
    add_light(scene, "POINT", (0.12, -0.2, 0.2), (0, 0, 0.05), energy=20.0)
    add_camera(scene, (0.0, -0.3, 0.1), (0, 0, 0.05), lens=50)
    return ob


def _reverse(ob):
    import bmesh

    bm = bmesh.new()
    bm.from_mesh(ob.data)
    bmesh.ops.reverse_faces(bm, faces=list(bm.faces))
    bm.to_mesh(ob.data)
    bm.free()
    ob.data.update()


# QUADGRAPH's fTetWild meshes the turned surface anew and is not reproducible (test_quadgraph_gpu: 6 %).
TOLERANCE = {"OFF": 0.005, "IMAGE_SPACE": 0.01, "TEXTURE_SPACE": 0.01, "QUADGRAPH": 0.04, "GEOCUBE": 0.01}


@pytest.mark.parametrize("method", list(TOLERANCE))
def test_an_inward_wound_ball_renders_as_the_outward_one(_bpy, tr, scene, method):
    from blender_helpers import render
    from conftest import ext_module

    ob = _scene_with_ball(tr, scene, method)
    bake = _bpy.ops.translucent.bake
    if method not in ("OFF", "IMAGE_SPACE"):
        assert bake() == {"FINISHED"}
    outward = render(scene, 64, 64)
    _reverse(ob)
    extract = ext_module(tr, "translucent_addon.blender.extract")
    depsgraph = _bpy.context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, 16, 16))
    assert any("'Ball': the mesh is wound inward" in w for w in frame.warnings), frame.warnings
    assert ext_module(tr, "translucent_addon.blender.session").current().turned["Ball"] == 1, "the object panel says so"
    if method not in ("OFF", "IMAGE_SPACE"):
        assert bake() == {"FINISHED"}
    inward = render(scene, 64, 64)
    assert np.isfinite(inward).all()
    obj = outward[..., 3] > 0.999
    assert obj.sum() > 200, "the ball covers the image's middle"
    mean_out, mean_in = outward[obj, :3].mean(axis=0), inward[obj, :3].mean(axis=0)
    np.testing.assert_allclose(mean_in, mean_out, rtol=TOLERANCE[method])
    rmse = np.sqrt(np.mean((inward[obj, :3] - outward[obj, :3]) ** 2)) / outward[obj, :3].mean()
    assert rmse < 4 * TOLERANCE[method], rmse


def test_the_cycles_twin_of_an_inward_ball_is_the_outward_twin(_bpy, tr, scene):
    """Compare's Cycles twin renders the outward copy (the volume behind inward faces was black)."""
    from blender_helpers import render
    from conftest import ext_module

    runner = ext_module(tr, "translucent_addon.blender.compare_runner")
    ob = _scene_with_ball(tr, scene, "IMAGE_SPACE")
    options = runner.cycles_options(8, 16)

    def cycles():
        with runner.twin_materials_applied([ob], "brute_force"), runner.engine_setup(scene, "CYCLES", **options):
            return render(scene, 32, 32)

    outward = cycles()
    _reverse(ob)
    inward = cycles()
    assert ob.data.polygons[0].normal.dot(ob.data.polygons[0].center) < 0, "the mesh is restored"
    obj = outward[..., 3] > 0.999
    assert obj.sum() > 50
    np.testing.assert_allclose(inward[obj, :3].mean(axis=0), outward[obj, :3].mean(axis=0), rtol=0.05)

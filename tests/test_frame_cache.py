"""Frames that touch only what changed (issue 36): the mesh cache is never stale, in F12 and in the viewport's
code path (``engine.Viewport``: ``view_update`` / ``view_draw``), driven headless into an offscreen target."""
from __future__ import annotations

import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

from blender_helpers import (  # noqa: E402
    add_camera,
    add_light,
    add_mesh,
    add_plane,
    diffuse_material,
    render,
    set_world,
)
from conftest import ROOT, ext_module  # noqa: E402

sys.path.insert(0, str(ROOT / "scripts"))
import viewport_probe  # noqa: E402

SIZE = 48


def _scene(scene, method="OFF"):
    set_world(scene, (0.05, 0.05, 0.06))
    add_plane(scene)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=0.8, location=(0, 0, 0.9))
    ball = bpy.context.object
    ball.name = "Ball"
    ball.data.materials.append(diffuse_material("BallColour", (0.8, 0.5, 0.3)))
    ball.translucent.method = method
    ball.translucent.mm_per_unit = 20.0
    add_light(scene, "POINT", (2.0, -2.0, 3.0), energy=400.0)
    add_camera(scene, (0, -5, 2), (0, 0, 0.8), lens=50)
    return ball


def _fresh(tr, scene) -> np.ndarray:
    """The frame with every cache dropped: what the cached frame must equal."""
    ext_module(tr, "translucent_addon.blender.session").current().clear()
    return render(scene, SIZE, SIZE)


def _changed_and_current(tr, scene, before: np.ndarray) -> np.ndarray:
    cached = render(scene, SIZE, SIZE)
    fresh = _fresh(tr, scene)
    assert np.isfinite(cached).all()
    assert np.abs(fresh - before).max() > 1e-3, "the edit is in sight"
    np.testing.assert_allclose(cached, fresh, rtol=0, atol=1e-5,
                               err_msg="the cached frame equals one drawn with no cache")
    return cached


def _edit_vertex(ob):
    nearest = min(ob.data.vertices, key=lambda v: v.co.y)  # the one facing the camera
    nearest.co.y -= 0.6
    nearest.co.z += 0.3
    ob.data.update()


def _edit_modifier(ob):
    ob.modifiers.new("wave", "DISPLACE").strength = 0.3


def _edit_material(ob):
    bsdf = next(n for n in ob.data.materials[0].node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (0.2, 0.6, 0.9, 1.0)


def _edit_scale(ob):
    ob.scale = (1.0, 1.0, 0.6)


def _edit_shading(ob):
    for p in ob.data.polygons:
        p.use_smooth = True
    ob.data.update()


@pytest.mark.parametrize("edit", [_edit_vertex, _edit_modifier, _edit_material, _edit_scale, _edit_shading],
                         ids=["mesh", "modifier", "material", "scale", "smooth shading"])
def test_each_edit_shows_in_the_next_f12_frame(tr, scene, edit):
    ball = _scene(scene)
    before = render(scene, SIZE, SIZE)
    edit(ball)
    _changed_and_current(tr, scene, before)


def test_a_preset_change_shows_in_the_next_frame(tr, scene):
    ball = _scene(scene, "IMAGE_SPACE")
    ball.translucent.preset = "marble"
    before = render(scene, SIZE, SIZE)
    ball.translucent.preset = "ketchup"
    _changed_and_current(tr, scene, before)


def test_an_unchanged_mesh_is_not_read_again_and_a_deforming_one_is(tr, scene):
    """Moving the light keeps the meshes' arrays (nothing is re-read, re-hashed or uploaded: the same key);
    a shape-key edit (deformation) makes new positions and normals under the same topology."""
    ball = _scene(scene)
    extract = ext_module(tr, "translucent_addon.blender.extract")
    depsgraph = bpy.context.evaluated_depsgraph_get()

    def frame():
        return extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, SIZE, SIZE))

    first = next(m for m in frame().meshes if m.name == "Ball")
    scene.objects["POINT light"].location.x += 1.0
    depsgraph.update()
    second = next(m for m in frame().meshes if m.name == "Ball")
    assert second.key == first.key and second.positions is first.positions
    source = ext_module(tr, "translucent_addon.blender.mesh_read").geometry_source(ball)  # its mesh's, shared
    read = ext_module(tr, "translucent_addon.blender.session").current().reads.cache[("VIEWPORT", source)]

    ball.shape_key_add(name="Basis")
    key = ball.shape_key_add(name="Squash")
    key.data[5].co.z += 0.3
    key.value = 1.0
    depsgraph.update()
    third = next(m for m in frame().meshes if m.name == "Ball")
    moved = ext_module(tr, "translucent_addon.blender.session").current().reads.cache[("VIEWPORT", source)]
    assert third.key != first.key and not np.array_equal(third.positions, first.positions)
    assert moved is not read and moved.tri_loops is read.tri_loops, "the topology is kept, not read again"


def test_bake_status_is_hashed_once_per_change(tr, scene, monkeypatch):
    """The sidebar and every frame ask for a bake's status: the inputs are hashed again only when the mesh or
    a setting changed."""
    ball = _scene(scene, "TEXTURE_SPACE")
    ball.translucent.atlas_resolution = 96
    bpy.context.view_layer.objects.active = ball
    ball.select_set(True)
    assert bpy.ops.translucent.bake() == {"FINISHED"}
    inputs = ext_module(tr, "translucent_addon.blender.bake_inputs")
    store = ext_module(tr, "translucent_addon.core.bake_store")
    calls = []
    real = store.inputs_hash
    monkeypatch.setattr(store, "inputs_hash", lambda *a: calls.append(1) or real(*a))

    def status():
        return inputs.bake_status(ball.evaluated_get(bpy.context.evaluated_depsgraph_get()))

    assert status() == "OK"
    n = len(calls)
    assert status() == "OK" and status() == "OK"
    assert len(calls) == n, "an unchanged object is not hashed again"
    ball.translucent.mm_per_unit = 25.0
    assert status() == "STALE"
    ball.translucent.mm_per_unit = 20.0
    _edit_vertex(ball)
    assert status() == "STALE"
    assert len(calls) > n


# -- the viewport's code path, headless (scripts/viewport_probe.py) ---------------------------------------
@pytest.fixture
def probe(tr):
    cls = viewport_probe.engine_class(ext_module(tr, "translucent_addon.blender.engine"),
                                      ext_module(tr, "translucent_addon.blender.extract"),
                                      ext_module(tr, "translucent_addon.gpu.targets"))
    bpy.utils.register_class(cls)
    viewport_probe.PROBE.clear()
    yield cls
    bpy.utils.unregister_class(cls)
    viewport_probe.PROBE.clear()


def _viewport_frame(scene, updates=()) -> np.ndarray:
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    return viewport_probe.frame(scene, lambda sc: render(sc, SIZE, SIZE), updates)


def test_the_viewport_path_draws_the_f12_frame_and_follows_updates(tr, scene, probe):
    """The viewport's path draws what F12 draws (its RGBA16F target: within half-float rounding); an edit the
    depsgraph reports shows in the next viewport frame; a material edit (an update of the material, not the
    object) does too."""
    ball = _scene(scene, "IMAGE_SPACE")
    f12 = render(scene, SIZE, SIZE)
    view = _viewport_frame(scene)
    # IMAGE_SPACE's samples follow each path's own frame sequence: equal in the mean, not per pixel.
    assert np.isfinite(view).all() and view[..., :3].max() > 0.1
    assert np.abs(view - f12)[..., :3].mean() < 0.02 * f12[..., :3].mean()
    ball.translucent.method = "OFF"  # the rest compares pixels: no sampling
    view = _viewport_frame(scene)
    np.testing.assert_allclose(view, render(scene, SIZE, SIZE), rtol=2e-3, atol=2e-4)

    _edit_vertex(ball)
    edited = _viewport_frame(scene, [viewport_probe.update_of(ball)])
    assert np.abs(edited - view).max() > 1e-3
    np.testing.assert_allclose(edited, render(scene, SIZE, SIZE), rtol=2e-3, atol=2e-4)

    _edit_material(ball)
    recoloured = _viewport_frame(scene)
    assert np.abs(recoloured - edited).max() > 1e-3
    np.testing.assert_allclose(recoloured, render(scene, SIZE, SIZE), rtol=2e-3, atol=2e-4)


# What Blender's depsgraph reports for each edit: a geometry update of the object for mesh and modifier edits,
# a transform update for the scale, nothing of the object for a material (the material is updated).
VIEWPORT_EDITS = [(_edit_vertex, "geometry"), (_edit_modifier, "geometry"), (_edit_material, None),
                  (_edit_scale, "transform"), (_edit_shading, "geometry")]


@pytest.mark.parametrize("edit, update", VIEWPORT_EDITS, ids=["mesh", "modifier", "material", "scale", "smooth"])
def test_each_edit_shows_in_the_next_viewport_frame(tr, scene, probe, edit, update):
    ball = _scene(scene)
    before = _viewport_frame(scene)
    edit(ball)
    updates = [] if update is None else [viewport_probe.update_of(ball, geometry=update == "geometry",
                                                                  transform=update == "transform")]
    after = _viewport_frame(scene, updates)
    f12 = render(scene, SIZE, SIZE)
    assert np.abs(f12 - before).max() > 1e-3, "the edit is in sight"
    np.testing.assert_allclose(after, f12, rtol=2e-3, atol=2e-4)


def test_a_preset_change_shows_in_the_next_viewport_frame(tr, scene, probe):
    """A setting of the object (no geometry update): the medium is read from the settings every frame."""
    ball = _scene(scene, "IMAGE_SPACE")
    ball.translucent.preset = "marble"
    before = _viewport_frame(scene)
    ball.translucent.preset = "ketchup"
    after = _viewport_frame(scene)
    f12 = render(scene, SIZE, SIZE)
    change = np.abs(f12 - before)[..., :3].mean()
    assert change > 0.01 * f12[..., :3].mean(), "the preset changes the picture"
    # IMAGE_SPACE's own sample sequence per path: the viewport equals F12 in the mean, far closer than the change.
    assert np.abs(after - f12)[..., :3].mean() < 0.25 * change


def test_the_viewport_reads_only_the_objects_an_update_names(tr, scene, probe):
    """Between updates, an object no update named is not read (its ``DrawnMesh`` is reused as it is); one
    that is named is read and compared."""
    ball = _scene(scene)
    _viewport_frame(scene)
    reads = []
    session = ext_module(tr, "translucent_addon.blender.session").current()
    real = session.reads.read
    source = ext_module(tr, "translucent_addon.blender.mesh_read").geometry_source  # its mesh's, or its own name
    name_of = {source(ob): ob.name for ob in scene.objects}
    session.reads.read = lambda mesh, key: reads.append(name_of.get(key[1], key[1])) or real(mesh, key)
    try:
        _viewport_frame(scene)
        assert reads == [], "nothing changed: no mesh read"
        _viewport_frame(scene, [viewport_probe.update_of(ball)])
        assert reads == ["Ball"]
    finally:
        session.reads.read = real
    add_mesh(scene, "Tri", [(0, 0, 2), (1, 0, 2), (0, 1, 2)], [(0, 1, 2)])
    reads.clear()
    name_of.update({source(ob): ob.name for ob in scene.objects})
    session.reads.read = lambda mesh, key: reads.append(name_of.get(key[1], key[1])) or real(mesh, key)
    try:  # an update of the scene (a frame change, a new object): every mesh is read and compared
        assert np.isfinite(_viewport_frame(scene, [viewport_probe.update_of(scene)])).all()
    finally:
        session.reads.read = real
    assert sorted(reads) == ["Ball", "Ground", "Tri"]


def test_two_sessions_keep_their_own_caches_side_by_side(tr, scene):
    """The Blender layer's caches have one owner, handed down (issue 54): two sessions read the same scene into
    their own caches; clearing one leaves the other, which draws its next frame from what it kept; the GPU
    resources swapped for a block build their own programs and give the process's back after."""
    session_mod = ext_module(tr, "translucent_addon.blender.session")
    extract = ext_module(tr, "translucent_addon.blender.extract")
    resources = ext_module(tr, "translucent_addon.gpu.resources")
    _scene(scene)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = extract.render_camera(depsgraph, SIZE, SIZE)
    a, b = session_mod.Session(), session_mod.Session()
    ball_a = next(m for m in extract.frame_inputs(depsgraph, camera, session=a).meshes if m.name == "Ball")
    ball_b = next(m for m in extract.frame_inputs(depsgraph, camera, session=b).meshes if m.name == "Ball")
    assert ball_a.key != ball_b.key, "each session names its own GPU arrays"
    np.testing.assert_array_equal(ball_a.positions, ball_b.positions)
    assert set(a.drawn) == set(b.drawn) and a.reads.cache.keys() == b.reads.cache.keys()
    source = ext_module(tr, "translucent_addon.blender.mesh_read").geometry_source(scene.objects["Ball"])
    assert a.drawn[("VIEWPORT", source)] is not b.drawn[("VIEWPORT", source)]
    a.clear()
    assert not a.drawn and not a.reads.cache and b.drawn
    again = next(m for m in extract.frame_inputs(depsgraph, camera, session=b).meshes if m.name == "Ball")
    assert again.key == ball_b.key and again.positions is ball_b.positions, "b kept its arrays"
    assert session_mod.current() is not a and session_mod.current() is not b

    process = resources.current()
    plain = render(scene, SIZE, SIZE)
    own = resources.GpuResources(specs=process.specs)
    with resources.use(own):
        np.testing.assert_array_equal(render(scene, SIZE, SIZE), plain)
        assert "base_lighting" in own.programs
    assert resources.current() is process and own.programs["base_lighting"] is not process.programs.get(
        "base_lighting")

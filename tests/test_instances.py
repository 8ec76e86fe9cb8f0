"""Scenes of many: duplicates, instances and many translucent objects in one frame (issue 57).

Every kind of instance (linked duplicates, a collection instance, geometry nodes' instances of an object and of its
geometry) draws its object's method and medium, equal to the same scene made of real copies; instances of one bake
share its GPU data and keep only their own light maps; geometry that geometry nodes made is drawn from its
material's medium with the scene's method; IMAGE_SPACE draws any number of objects.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from blender_helpers import add_camera, add_light, diffuse_material, render, scatter_on_points, set_world
from conftest import ext_module

bpy = pytest.importorskip("bpy")

POINTS = ((-0.25, 0.0, 0.0), (0.0, 0.12, 0.05), (0.25, -0.05, 0.0))  # where the three instances stand
SIZE = 64


def _select(ob):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def _grape(scene, method: str):
    """A baked 10 cm ball (its bake packed into the file, so a full copy carries its own), out of the render."""
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.1, location=(0, 0, 0))
    grape = bpy.context.object
    grape.name = "Grape"
    grape.translucent.method = method
    grape.translucent.mm_per_unit = 100.0
    if method == "TEXTURE_SPACE":
        grape.translucent.atlas_resolution = 64
    if method != "IMAGE_SPACE":
        scene.translucent.bake_storage = "PACKED"
        _select(grape)
        assert bpy.ops.translucent.bake() == {"FINISHED"}
    grape.hide_render = True
    return grape


def _instancer(scene, source, as_instance: bool):
    """Geometry nodes putting ``source`` on each of POINTS (``blender_helpers.scatter_on_points``)."""
    return scatter_on_points(scene, POINTS, source, as_instance)


def _stage(scene):
    set_world(scene, (0.05, 0.06, 0.08))
    add_light(scene, "POINT", (0.4, -0.8, 0.7), energy=60.0)
    add_camera(scene, (0.0, -1.4, 0.5), (0.0, 0.0, 0.02), lens=50)


def _warm(scene):
    render(scene, SIZE, SIZE)  # the first frame uploads and starts cold
    return render(scene, SIZE, SIZE)


def _frame_meshes(tr, scene):
    extract = ext_module(tr, "translucent_addon.blender.extract")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, SIZE, SIZE)).meshes


@pytest.mark.parametrize("method", ["IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE"])
def test_every_kind_of_instance_draws_as_the_same_scene_of_real_copies(tr, scene, method):
    """Geometry nodes' instances of an object's geometry were drawn opaque and matte (their temporary object stands
    for the modifier's object, whose method is OFF). Now each kind of instance draws the object's method: the
    image equals that of full copies (own mesh, own bake) to 1e-5, and instances of one bake share one GPU entry."""
    _stage(scene)
    grape = _grape(scene, method)
    images = {}
    scatter = _instancer(scene, grape, as_instance=False)
    images["geometry nodes, geometry"] = _warm(scene)
    scatter.modifiers[0].node_group.nodes["Object Info"].inputs["As Instance"].default_value = True
    images["geometry nodes, as instance"] = _warm(scene)
    scatter.hide_render = True
    collection = bpy.data.collections.new("Grapes")  # not in the scene: its grape is drawn through the instances
    collection.objects.link(grape)
    scene.collection.objects.unlink(grape)
    grape.hide_render = False
    empties = []
    for p in POINTS:
        empty = bpy.data.objects.new("Bunch", None)
        empty.instance_type, empty.instance_collection, empty.location = "COLLECTION", collection, p
        scene.collection.objects.link(empty)
        empties.append(empty)
    images["collection instances"] = _warm(scene)
    for empty in empties:
        empty.hide_render = True
    scene.collection.objects.link(grape)
    grape.hide_render = True
    duplicates = []
    for p in POINTS:
        twin = grape.copy()  # Alt+D: the mesh and its bake shared
        twin.location, twin.hide_render = p, False
        scene.collection.objects.link(twin)
        duplicates.append(twin)
    images["linked duplicates"] = _warm(scene)
    held = ext_module(tr, "translucent_addon.gpu.resources").current()
    entries = [key for key in held.bakes if key.startswith(f"{method}#")]
    if method != "IMAGE_SPACE":
        assert len(entries) == 1, f"three duplicates of one bake hold one GPU entry: {entries}"
    if method == "TEXTURE_SPACE":
        assert len(held.bakes[entries[0]]._irradiance) == 3, "and a light map each"
    for twin in duplicates:
        twin.data = grape.data.copy()  # full copies: their own mesh, carrying their own packed bake
    meshes = _frame_meshes(tr, scene)  # the viewport's: the (render-hidden) grape too
    assert len({m.key for m in meshes if m.method == method and m.name != "Grape"}) == 3
    images["real copies"] = reference = _warm(scene)
    assert reference[..., :3].mean() > 0.01
    for label, image in images.items():
        np.testing.assert_allclose(image, reference, atol=1e-5, err_msg=f"{method}: {label}")


def test_geometry_nodes_geometry_is_drawn_from_its_material_with_the_scene_method(tr, scene):
    """Geometry made in a node tree has no object to take a method from: the scene's *Generated geometry* method
    draws it where its material holds a subsurface medium, equal to an object of that material drawn with that
    method; set to Off, it is drawn opaque."""
    _stage(scene)
    skin = diffuse_material("Skin", (0.8, 0.5, 0.4))
    bsdf = next(n for n in skin.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Radius"].default_value = (1.0, 0.5, 0.25)
    bsdf.inputs["Subsurface Scale"].default_value = 0.02
    scatter = _instancer(scene, skin, as_instance=False)
    assert scene.translucent.instance_method == "IMAGE_SPACE"
    drawn = [m for m in _frame_meshes(tr, scene) if m.name.startswith("Scatter")]
    assert len(drawn) == 3 and {m.method for m in drawn} == {"IMAGE_SPACE"}
    generated = _warm(scene)
    scene.translucent.instance_method = "OFF"
    assert {m.method for m in _frame_meshes(tr, scene) if m.name.startswith("Scatter")} == {"OFF"}
    opaque = _warm(scene)
    assert np.abs(generated - opaque).max() > 0.01
    # The same balls as objects with that material and IMAGE_SPACE.
    scatter.hide_render = True
    for p in POINTS:
        bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.1, location=p)
        ball = bpy.context.object
        ball.data.materials.append(skin)
        ball.translucent.method = "IMAGE_SPACE"
    np.testing.assert_allclose(generated, _warm(scene), atol=1e-5)


def test_two_hundred_image_space_objects_are_drawn_as_in_groups_of_twenty(tr, scene):
    """IMAGE_SPACE drew subsurface light for at most 32 objects a frame. 200 balls of one medium are now all drawn in
    one frame, each within 2 % (relative RMSE over its pixels) of the same balls drawn twenty at a time (the others
    opaque: they still cast their shadows; the sampling grids follow the objects drawn, hence not equal)."""
    set_world(scene, (0.02, 0.02, 0.03))
    add_light(scene, "SUN", (1.0, -2.0, 3.0), energy=3.0)
    add_camera(scene, (0.0, -2.2, 1.7), (0.0, 0.0, 0.0), lens=40)
    balls = []
    for k in range(200):
        bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.045,
                                              location=((k % 20 - 9.5) * 0.1, (k // 20 - 4.5) * 0.1, 0.0))
        ball = bpy.context.object
        ball.name = f"Ball{k:03d}"
        ball.translucent.method = "IMAGE_SPACE"
        ball.translucent.mm_per_unit = 100.0
        balls.append(ball)
    scene.translucent.capture_passes = True
    width, height = 160, 120
    whole = render(scene, width, height)
    session = ext_module(tr, "translucent_addon.blender.session").current()
    capture = session.capture
    plan, meshes = capture["plan"], capture["frame"].meshes
    assert len(plan.tag_of) == 200 and not [w for w in session.warnings if "IMAGE_SPACE" in w]
    name_of_tag = {tag: meshes[k].name for k, tag in plan.tag_of.items()}
    tags = np.rint(capture["gbuffer"][..., 3]).astype(int)
    group = np.full(tags.shape, -1)
    for tag, name in name_of_tag.items():
        group[tags == tag] = int(name[4:]) // 20
    scene.translucent.capture_passes = False
    composed = np.zeros_like(whole)
    for g in range(10):
        for k, ball in enumerate(balls):
            ball.translucent.method = "IMAGE_SPACE" if k // 20 == g else "OFF"
        part = render(scene, width, height)
        composed[group == g] = part[group == g]
    covered = group >= 0
    assert covered.sum() > 2000 and len(np.unique(group[covered])) == 10
    a, b = whole[covered][:, :3], composed[covered][:, :3]
    rel = math.sqrt(float(((a - b) ** 2).mean()) / float((b ** 2).mean()))
    print(f"200 balls in one frame against groups of 20: relative RMSE {rel:.4f}")
    assert rel <= 0.02


def test_particle_instances_are_drawn_with_their_object_s_method(tr, scene):
    """Particles rendered as an object: each is an instance of it, drawn with its method and medium."""
    _stage(scene)
    grape = _grape(scene, "IMAGE_SPACE")
    mesh = bpy.data.meshes.new("Emitter")
    mesh.from_pydata(POINTS, [], [])
    emitter = bpy.data.objects.new("Emitter", mesh)
    scene.collection.objects.link(emitter)
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    settings = emitter.particle_systems[0].settings
    settings.count, settings.emit_from, settings.use_emit_random = 3, "VERT", False
    settings.frame_start = settings.frame_end = 1
    settings.physics_type, settings.render_type, settings.instance_object = "NO", "OBJECT", grape
    scene.frame_set(1)
    grape.location.z = -5.0  # the object itself (the viewport's depsgraph draws it) stands apart
    drawn = [m for m in _frame_meshes(tr, scene) if m.name == "Grape" and m.model[2, 3] > -1.0]
    assert len(drawn) == 3 and {m.method for m in drawn} == {"IMAGE_SPACE"}
    assert all(m.medium is not None for m in drawn)
    centres = sorted(tuple(np.round(m.model[:3, 3], 4)) for m in drawn)
    assert centres == sorted(tuple(np.round(p, 4)) for p in POINTS)


@pytest.mark.parametrize("method", ["TEXTURE_SPACE", "QUADGRAPH"])
def test_instances_the_camera_cannot_see_are_not_lit(tr, scene, method):
    """A crowd running out of the frame: instances whose box lies outside the view are not lit, gathered or solved
    (TEXTURE_SPACE and QUADGRAPH light reaches no pixel outside the object's own), and the image is that of the
    scene without them to 1e-5."""
    _stage(scene)
    grape = _grape(scene, method)
    grape.hide_render = False
    seen = _warm(scene)
    away = grape.copy()
    away.location = (0.0, -3.0, 0.5)  # behind the camera (at y -1.4, looking along +y)
    scene.collection.objects.link(away)
    assert len([m for m in _frame_meshes(tr, scene) if m.method == method]) == 2
    np.testing.assert_allclose(_warm(scene), seen, atol=1e-5)
    held = ext_module(tr, "translucent_addon.gpu.resources").current()
    entry = next(res for key, res in held.bakes.items() if key.startswith(f"{method}#"))
    lit = entry._irradiance if method == "TEXTURE_SPACE" else entry._lit
    assert len(lit) == 1, "one instance lit: the one in view"
    away.location = (0.3, 0.0, 0.0)  # in view: lit too
    _warm(scene)
    assert len(lit) == 2

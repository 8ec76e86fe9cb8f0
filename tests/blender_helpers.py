"""Scene building and rendering helpers for the Blender tests."""
from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Vector


def set_world(scene, color) -> None:
    from translucent_addon.blender.demo import uniform_world

    uniform_world(scene, tuple(color))


def diffuse_material(name, color, gloss: bool = False):
    """A Principled BSDF of this Base Color: Lambert (IOR Level 0: no specular layer) unless ``gloss``."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    if not gloss:
        bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return mat


def add_mesh(scene, name, verts, faces, color=None, location=(0, 0, 0)):
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    if color is not None:
        me.materials.append(diffuse_material(name, color))
    scene.collection.objects.link(ob)
    return ob


def add_cube(scene, name="Cube", size=1.0, location=(0, 0, 0.5), color=(0.8, 0.3, 0.2)):
    h = size / 2
    verts = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return add_mesh(scene, name, verts, faces, color, location)


def add_plane(scene, name="Ground", size=6.0, color=(0.6, 0.6, 0.6)):
    h = size / 2
    return add_mesh(scene, name, [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], [(0, 1, 2, 3)], color)


def aim(ob, target) -> None:
    ob.rotation_euler = (Vector(target) - ob.location).to_track_quat("-Z", "Y").to_euler()


def add_light(scene, kind, location, target=(0, 0, 0), energy=100.0, **settings):
    light = bpy.data.lights.new(f"{kind} light", kind)
    light.energy = energy
    for key, value in settings.items():
        setattr(light, key, value)
    ob = bpy.data.objects.new(light.name, light)
    ob.location = location
    aim(ob, target)
    scene.collection.objects.link(ob)
    return ob


def add_camera(scene, location, target, lens=35.0):
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = lens
    cam.location = location
    aim(cam, target)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam


def render(scene, width=96, height=96) -> np.ndarray:
    """F12 through the scene's engine; linear RGBA (height, width, 4), row 0 at the bottom."""
    from translucent_addon.blender.compare_runner import render_pixels

    return render_pixels(scene, width, height)[0]


def scatter_on_points(scene, points, source, as_instance: bool = False):
    """A mesh of ``points`` whose geometry nodes put ``source`` on each point: an object through Object Info (*As
    Instance* or its geometry), or a material, for an ico sphere made in the tree (geometry no object owns)."""
    mesh = bpy.data.meshes.new("Points")
    mesh.from_pydata([tuple(p) for p in points], [], [])
    ob = bpy.data.objects.new("Scatter", mesh)
    scene.collection.objects.link(ob)
    tree = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes = tree.nodes
    group_in, group_out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    on_points = nodes.new("GeometryNodeInstanceOnPoints")
    if isinstance(source, bpy.types.Object):
        info = nodes.new("GeometryNodeObjectInfo")
        info.inputs["Object"].default_value = source
        info.inputs["As Instance"].default_value = as_instance
        tree.links.new(info.outputs["Geometry"], on_points.inputs["Instance"])
    else:
        sphere = nodes.new("GeometryNodeMeshIcoSphere")
        sphere.inputs["Radius"].default_value = 0.1
        sphere.inputs["Subdivisions"].default_value = 2
        material = nodes.new("GeometryNodeSetMaterial")
        material.inputs["Material"].default_value = source
        tree.links.new(sphere.outputs["Mesh"], material.inputs["Geometry"])
        tree.links.new(material.outputs["Geometry"], on_points.inputs["Instance"])
    tree.links.new(group_in.outputs[0], on_points.inputs["Points"])
    tree.links.new(on_points.outputs[0], group_out.inputs[0])
    ob.modifiers.new("Scatter", "NODES").node_group = tree
    return ob


def lit_cube_scene(scene):
    """A cube on a plane under a sun, a point light and a spot, seen from above at an angle."""
    set_world(scene, (0.05, 0.06, 0.08))
    add_plane(scene)
    add_cube(scene)
    add_light(scene, "SUN", (3, -2, 5), energy=2.0)
    add_light(scene, "POINT", (-2.0, -1.5, 2.5), energy=300.0)
    add_light(scene, "SPOT", (1.5, 2.5, 3.0), energy=400.0, spot_size=math.radians(60), spot_blend=0.2)
    add_camera(scene, (4.0, -5.0, 4.0), (0, 0, 0.3))
    return scene


def dipole_model_reference(tr, name: str, width: int, height: int, samples: int = 60_000, lean=True):
    """The CPU dipole model of the current scene with object ``name`` translucent, and the mask of
    that object's interior pixels: (image, mask). Light entering at an angle is read where it entered, as both
    IMAGE_SPACE and TEXTURE_SPACE draw it; ``lean``: IMAGE_SPACE's model, the light leaving leans away from where
    it entered (False: TEXTURE_SPACE's)."""
    from conftest import ext_module

    extract = ext_module(tr, "translucent_addon.blender.extract")
    model = ext_module(tr, "translucent_addon.core.reference.dipole_model")
    runner = ext_module(tr, "translucent_addon.blender.compare_runner")
    lambert = ext_module(tr, "translucent_addon.core.reference.lambert")
    tracer_mod = ext_module(tr, "translucent_addon.blender.bvh_tracer")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, width, height))
    tracer = tracer_mod.BVHTracer(lambert.scene_triangles(frame)[0])
    medium = next(m.medium for m in frame.meshes if m.name == name)
    ref = model.render_dipole(frame, {name: medium}, samples=samples, tracer=tracer, lean=lean)
    return ref, runner.interior(runner._mask(frame, tracer, {name}))

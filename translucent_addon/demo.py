"""The bundled default scene: a back-lit marble Stanford bunny on a ground plane."""
from __future__ import annotations

import math
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

from .geometry.mesh_io import load_npz
from .props import apply_preset

MESH_DIR = Path(__file__).resolve().parent / "data" / "meshes"


def mesh_from_arrays(name: str, vertices: np.ndarray, triangles: np.ndarray) -> bpy.types.Mesh:
    """A Blender mesh from vertex and triangle arrays, by bulk foreach_set."""
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(vertices))
    me.vertices.foreach_set("co", np.ascontiguousarray(vertices, np.float32).reshape(-1))
    me.loops.add(3 * len(triangles))
    me.loops.foreach_set("vertex_index", np.ascontiguousarray(triangles, np.int32).reshape(-1))
    me.polygons.add(len(triangles))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(triangles), 3, dtype=np.int32))
    me.update(calc_edges=True)
    me.validate(clean_customdata=False)
    return me


def bundled_mesh(name: str) -> bpy.types.Mesh:
    """One of the meshes shipped in data/meshes (bunny, spot, cow, teapot)."""
    vertices, triangles = load_npz(MESH_DIR / f"{name}.npz")
    return mesh_from_arrays(name, vertices, triangles)


def _material(name: str, color) -> bpy.types.Material:
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    mat.diffuse_color = (*color, 1.0)
    return mat


def _aim(ob, target: Vector) -> None:
    ob.rotation_euler = (target - ob.location).to_track_quat("-Z", "Y").to_euler()


def build_default_scene(scene: bpy.types.Scene | None = None) -> bpy.types.Scene:
    """Fill a scene (a new one by default) with the demo and make it use our engine."""
    scene = scene or bpy.data.scenes.new("Translucent Demo")
    coll = scene.collection

    bunny = bpy.data.objects.new("Bunny", bundled_mesh("bunny"))
    bunny.rotation_euler = (math.pi / 2, 0.0, 0.0)  # the scan is Y-up, Blender is Z-up
    coll.objects.link(bunny)
    bunny.data.shade_smooth()
    bunny.data.materials.append(_material("Marble", (0.83, 0.79, 0.75)))
    settings = bunny.translucent
    settings.preset = "marble"
    apply_preset(settings, "marble")
    settings.mm_per_unit = 1000.0  # the scan is in metres: 15 cm tall
    # Stand it on z = 0, centred on the origin.
    corners = np.array([bunny.matrix_basis @ Vector(c) for c in bunny.bound_box])
    bunny.location = (-corners[:, 0].mean(), -corners[:, 1].mean(), -corners[:, 2].min())
    centre = Vector((0.0, 0.0, float(np.ptp(corners[:, 2])) * 0.5))

    ground = bpy.data.objects.new("Ground", bpy.data.meshes.new("Ground"))
    ground.data.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    ground.data.materials.append(_material("Ground", (0.35, 0.35, 0.37)))
    coll.objects.link(ground)

    back = bpy.data.objects.new("Back Light", bpy.data.lights.new("Back Light", "SPOT"))
    back.data.energy = 60.0
    back.data.spot_size = math.radians(50)
    back.data.spot_blend = 0.3
    back.location = (-0.08, 0.45, 0.32)
    _aim(back, centre)
    coll.objects.link(back)

    fill = bpy.data.objects.new("Fill Light", bpy.data.lights.new("Fill Light", "AREA"))
    fill.data.energy = 2.5
    fill.data.size = 0.3
    fill.location = (0.45, -0.35, 0.35)
    _aim(fill, centre)
    coll.objects.link(fill)

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 50
    cam.location = (0.12, -0.62, 0.2)
    _aim(cam, centre)
    coll.objects.link(cam)
    scene.camera = cam

    world = bpy.data.worlds.new("Translucent World")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    bg = next(n for n in world.node_tree.nodes if n.type == "BACKGROUND")
    bg.inputs["Color"].default_value = (0.05, 0.055, 0.07, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    world.color = (0.05, 0.055, 0.07)
    scene.world = world

    scene.render.engine = "TRANSLUCENT_RT"
    scene.render.resolution_x, scene.render.resolution_y = 640, 480
    scene.render.resolution_percentage = 100
    return scene

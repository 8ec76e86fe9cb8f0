"""The bundled scenes: the default back-lit marble bunny and the benchmark set."""
from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Vector

from .. import techniques
from ..core.data import DATA
from ..core.geometry.mesh_io import load_npz, load_npz_uv
from .props import apply_preset

MESH_DIR = DATA / "meshes"


def mesh_from_arrays(name: str, vertices: np.ndarray, triangles: np.ndarray,
                     uv: np.ndarray | None = None) -> bpy.types.Mesh:
    """A Blender mesh from vertex and triangle arrays (and (T, 3, 2) corner UVs), by bulk foreach_set."""
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(vertices))
    me.vertices.foreach_set("co", np.ascontiguousarray(vertices, np.float32).reshape(-1))
    me.loops.add(3 * len(triangles))
    me.loops.foreach_set("vertex_index", np.ascontiguousarray(triangles, np.int32).reshape(-1))
    me.polygons.add(len(triangles))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(triangles), 3, dtype=np.int32))
    if uv is not None:  # before validate: the loops are the triangles' corners in order
        me.uv_layers.new(name="UVMap").data.foreach_set("uv", np.ascontiguousarray(uv, np.float32).reshape(-1))
    me.update(calc_edges=True)
    me.validate(clean_customdata=False)
    return me


def bundled_mesh(name: str) -> bpy.types.Mesh:
    """One of the meshes shipped in data/meshes (bunny, spot, cow, teapot), with its UV map where it has one."""
    vertices, triangles = load_npz(MESH_DIR / f"{name}.npz")
    return mesh_from_arrays(name, vertices, triangles, load_npz_uv(MESH_DIR / f"{name}.npz"))


def _material(name: str, color) -> bpy.types.Material:
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    mat.diffuse_color = (*color, 1.0)
    return mat


def uniform_world(scene, color, name: str = "World") -> bpy.types.World:
    """Give the scene a new world of one uniform colour (Background node and viewport colour)."""
    world = bpy.data.worlds.new(name)
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    bg = next(n for n in world.node_tree.nodes if n.type == "BACKGROUND")
    bg.inputs["Color"].default_value = (*color, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    world.color = color
    scene.world = world
    return world


def environment_world(scene, image: np.ndarray, name: str = "Environment") -> bpy.types.World:
    """Give the scene a new world lit by an equirectangular radiance image ((H, W, 3) linear, row 0 at
    the bottom), packed into the file: Environment Texture -> Background (what GEOCUBE refracts)."""
    h, w = image.shape[:2]
    rgba = np.concatenate([np.asarray(image, np.float32)[..., :3], np.ones((h, w, 1), np.float32)], axis=2)
    im = bpy.data.images.new(name, w, h, float_buffer=True, alpha=True)
    im.pixels.foreach_set(rgba.ravel())
    im.pack()
    world = bpy.data.worlds.new(name)
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    tree = world.node_tree
    tex = tree.nodes.new("ShaderNodeTexEnvironment")
    tex.image = im
    bg = next(n for n in tree.nodes if n.type == "BACKGROUND")
    tree.links.new(tex.outputs["Color"], bg.inputs["Color"])
    scene.world = world
    return world


def _aim(ob, target: Vector) -> None:
    ob.rotation_euler = (target - ob.location).to_track_quat("-Z", "Y").to_euler()


# The scene set of DESIGN.md section 5 that exists so far: mesh, preset, size (largest extent, m), key light.
SCENES = {
    "bunny_backlit": dict(mesh="bunny", preset="marble", size=0.15, key="BACK"),
    "bunny_frontlit": dict(mesh="bunny", preset="marble", size=0.15, key="FRONT"),
    "cow_backlit": dict(mesh="cow", preset="skin1", size=0.25, key="BACK"),
    "spot_frontlit": dict(mesh="spot", preset="potato", size=0.15, key="FRONT"),
    # Where translucency matters most (issue 35): light through thin limbs, and skin at life size.
    "figure_backlit": dict(mesh="cow", preset="marble", size=0.10, key="BACK"),
    "skin_frontlit": dict(mesh="spot", preset="skin1", size=0.25, key="FRONT"),
}


def build_scene(name: str, scene: bpy.types.Scene | None = None) -> bpy.types.Scene:
    """One scene of the set: the mesh on a ground plane, a key spot (behind or in front), a fill, a camera."""
    spec = SCENES[name]
    scene = scene or bpy.data.scenes.new(f"Translucent {name}")
    coll = scene.collection
    size = spec["size"]

    ob = bpy.data.objects.new(spec["mesh"].capitalize(), bundled_mesh(spec["mesh"]))
    ob.rotation_euler = (math.pi / 2, 0.0, 0.0)  # the meshes are Y-up, Blender is Z-up
    coll.objects.link(ob)
    ob.data.shade_smooth()
    ob.data.materials.append(_material(spec["preset"].capitalize(), (0.83, 0.79, 0.75)))
    extent = np.ptp(np.array([Vector(c) for c in ob.bound_box]), axis=0).max()
    ob.scale = (size / extent,) * 3
    settings = ob.translucent
    settings.preset = spec["preset"]
    apply_preset(settings, spec["preset"])
    settings.scattering_scale = 1.0  # as measured, in the scene's metres
    settings.method = techniques.default_method()
    # Stand it on z = 0, centred on the origin.
    corners = np.array([ob.matrix_basis @ Vector(c) for c in ob.bound_box])
    ob.location = (-corners[:, 0].mean(), -corners[:, 1].mean(), -corners[:, 2].min())
    height = float(np.ptp(corners[:, 2]))
    centre = Vector((0.0, 0.0, height * 0.5))

    ground = bpy.data.objects.new("Ground", bpy.data.meshes.new("Ground"))
    g = 7.0 * size
    ground.data.from_pydata([(-g, -g, 0), (g, -g, 0), (g, g, 0), (-g, g, 0)], [], [(0, 1, 2, 3)])
    ground.data.materials.append(_material("Ground", (0.35, 0.35, 0.37)))
    coll.objects.link(ground)

    k = size / 0.15  # light distances scale with the object; powers with their square
    back = spec["key"] == "BACK"
    key = bpy.data.objects.new("Key Light", bpy.data.lights.new("Key Light", "SPOT"))
    key.data.energy = (80.0 if back else 60.0) * k * k
    key.data.spot_size = math.radians(50)
    key.data.spot_blend = 0.3
    key.data.shadow_soft_size = 0.005 * k
    key.location = (Vector((0.0, 0.35, 0.22)) if back else Vector((-0.35, -0.4, 0.4))) * k
    _aim(key, centre)
    coll.objects.link(key)

    fill = bpy.data.objects.new("Fill Light", bpy.data.lights.new("Fill Light", "AREA"))
    fill.data.energy = (0.6 if back else 2.5) * k * k  # dim when back-lit, so that light shows through
    fill.data.size = 0.3 * k
    fill.location = Vector((0.45, -0.35, 0.35)) * k
    _aim(fill, centre)
    coll.objects.link(fill)

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 50
    cam.location = Vector((0.12, -0.62, 0.2)) * k
    _aim(cam, centre)
    coll.objects.link(cam)
    scene.camera = cam

    uniform_world(scene, (0.05, 0.055, 0.07), "Translucent World")

    scene.render.engine = "TRANSLUCENT_RT"
    scene.render.resolution_x, scene.render.resolution_y = 640, 480
    scene.render.resolution_percentage = 100
    return scene


def build_default_scene(scene: bpy.types.Scene | None = None) -> bpy.types.Scene:
    """The bundled default scene: a back-lit marble Stanford bunny (15 cm) on a ground plane."""
    scene = build_scene("bunny_backlit", scene or bpy.data.scenes.new("Translucent Demo"))
    return scene


def glass_material(name: str, ior: float) -> bpy.types.Material:
    """A clear Glass BSDF (what Cycles renders for a caustics caster)."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    glass = tree.nodes.new("ShaderNodeBsdfGlass")
    glass.inputs["IOR"].default_value = ior
    glass.inputs["Roughness"].default_value = 0.0
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(glass.outputs["BSDF"], out.inputs["Surface"])
    mat.diffuse_color = (0.9, 0.95, 1.0, 0.3)
    return mat


def build_caustics_scene(scene: bpy.types.Scene | None = None, caster: str = "sphere", light: str = "POINT",
                         ior: float = 1.5) -> bpy.types.Scene:
    """A glass caster (a 5 cm radius ball 10 cm over the floor, or the bunny) over a white floor under
    one small light straight above: the caustics scene of the bench (Shah Fig. 5.6, 5.9). Cycles' shadow
    caustics (MNEE) are switched on for the same objects, so that "Compare with Cycles" sees caustics."""
    scene = scene or bpy.data.scenes.new("Translucent Caustics")
    coll = scene.collection
    if caster == "sphere":
        me = bpy.data.meshes.new("Glass ball")
        ob = bpy.data.objects.new("Glass ball", me)
        import bmesh

        bm = bmesh.new()
        bmesh.ops.create_uvsphere(bm, u_segments=96, v_segments=48, radius=0.05)
        bm.to_mesh(me)
        bm.free()
        ob.location = (0.0, 0.0, 0.1)
    else:
        ob = bpy.data.objects.new("Glass bunny", bundled_mesh("bunny"))
        ob.rotation_euler = (math.pi / 2, 0.0, 0.0)
        extent = np.ptp(np.array([Vector(c) for c in ob.bound_box]), axis=0).max()
        ob.scale = (0.1 / extent,) * 3
        corners = np.array([ob.matrix_basis @ Vector(c) for c in ob.bound_box])
        ob.location = (-corners[:, 0].mean(), -corners[:, 1].mean(), 0.05 - corners[:, 2].min())
    ob.data.shade_smooth()
    ob.data.materials.append(glass_material("Caustic glass", ior))
    coll.objects.link(ob)
    t = ob.translucent
    t.scattering_scale = 1.0
    t.caustics_caster = "REFRACTIVE"
    t.caustics_ior = ior
    ob.cycles.is_caustics_caster = True

    floor = bpy.data.objects.new("Floor", bpy.data.meshes.new("Floor"))
    g = 0.2
    floor.data.from_pydata([(-g, -g, 0), (g, -g, 0), (g, g, 0), (-g, g, 0)], [], [(0, 1, 2, 3)])
    floor.data.materials.append(_material("Floor", (0.8, 0.8, 0.8)))
    coll.objects.link(floor)
    floor.cycles.is_caustics_receiver = True

    if light == "SUN":
        lamp = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
        lamp.data.energy = 3.0
        lamp.data.angle = math.radians(0.5)
        lamp.location = (0.0, 0.0, 0.5)
    else:
        lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
        lamp.data.energy = 10.0
        lamp.data.shadow_soft_size = 0.002
        lamp.location = (0.0, 0.0, 0.5)
    lamp.data.cycles.is_caustics_light = True
    _aim(lamp, Vector((0.0, 0.0, 0.0)))
    coll.objects.link(lamp)

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 50
    cam.location = (0.0, -0.3, 0.3)
    _aim(cam, Vector((0.0, 0.0, 0.0)))
    coll.objects.link(cam)
    scene.camera = cam
    uniform_world(scene, (0.0, 0.0, 0.0), "Dark")
    scene.render.engine = "TRANSLUCENT_RT"
    scene.render.resolution_x = scene.render.resolution_y = 512
    scene.render.resolution_percentage = 100
    return scene

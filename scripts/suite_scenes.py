"""The generalisation suite's scenes (issue 56): drawn with a fixed seed, built in Blender, rendered exactly.

A scene is a ``Spec``: a shape (the bundled bunny, cow and spot, or one generated here: capsule, torus, slab,
leaf, ear, a figure on four legs, a mushroom of a thick cap on a thin stem), its size (largest extent, 1 cm to 1 m),
its medium (one of the 12 measured presets, or a Principled BSDF converted as Cycles' random walk reads it), one
light (point, spot, area or sun) from the front, the side, the back or at the rim, and the index of refraction
(1.0, index-matched, or 1.3-1.4 behind a Glass boundary, which Cycles' brute force converges for only under area
lights: such scenes get an area light). No floor, a dim uniform world, a 50 mm camera framing the object.

``draw(seed, count)`` draws the specs (pure, no Blender); ``build(spec)`` makes the scene in the current file
(Blender). The exact reference is Cycles' brute force of the scene's volume (``compare_runner``'s twin material,
``self_interreflection=False``: the transport every method models), as ``bench_exact`` renders it.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

SHAPES = ("bunny", "cow", "spot", "capsule", "torus", "slab", "leaf", "ear", "quadruped", "mushroom")
BUNDLED = ("bunny", "cow", "spot")
FLAT = ("leaf", "ear", "slab")  # seen face-on rather than edge-on: within 45 degrees of the camera
PRESETS = ("apple", "chicken1", "chicken2", "cream", "ketchup", "marble", "potato", "skimmilk", "skin1", "skin2",
           "spectralon", "wholemilk")
LIGHTS = ("POINT", "SPOT", "AREA", "SUN")
DIRECTIONS = ("FRONT", "SIDE", "BACK", "RIM")
# Each direction as (azimuth from the camera's side, elevation), degrees: the camera looks from azimuth 0.
DIRECTION_ANGLES = {"FRONT": (35.0, 30.0), "SIDE": (95.0, 15.0), "BACK": (180.0, 20.0), "RIM": (145.0, 45.0)}
# Principled conversions: Base Color and Subsurface Radius pairs an artist reaches for (skin, wax, jade, milk,
# a leaf), the Subsurface Scale drawn per scene.
PRINCIPLED_LOOKS = (((0.80, 0.55, 0.45), (1.0, 0.2, 0.1)), ((0.90, 0.85, 0.70), (1.0, 0.8, 0.5)),
                    ((0.35, 0.75, 0.45), (0.3, 1.0, 0.5)), ((0.95, 0.95, 0.93), (1.0, 1.0, 1.0)),
                    ((0.45, 0.70, 0.20), (0.5, 1.0, 0.3)))
WORLD = (0.01, 0.011, 0.013)
# The largest object a preset may make, in its reduced mean free paths (size x the largest sigma_s'): Cycles' brute
# force follows each path up to 1024 bounces, and crossing a body of N mean free paths takes about N^2 of them: a
# 16 cm spectralon slab (3,200) kept one seed of the reference running past ten minutes, and its light would be cut.
MAX_SIZE_MFP = 500.0


# The presets' sigma_s' (mm^-1, data/materials_jensen2001.csv), for the size cap.
PRESET_SIGMA_S_PRIME = {"apple": (2.29, 2.39, 1.97), "chicken1": (0.15, 0.21, 0.38), "chicken2": (0.19, 0.25, 0.32),
                        "cream": (7.38, 5.47, 3.15), "ketchup": (0.18, 0.07, 0.03), "marble": (2.19, 2.62, 3.00),
                        "potato": (0.68, 0.70, 0.55), "skimmilk": (0.70, 1.22, 1.90), "skin1": (0.74, 0.88, 1.01),
                        "skin2": (1.09, 1.59, 1.79), "spectralon": (11.6, 20.4, 14.9),
                        "wholemilk": (2.55, 3.21, 3.77)}


@dataclasses.dataclass(frozen=True)
class Spec:
    """One scene of the suite."""

    name: str
    shape: str
    size: float  # largest extent, metres
    medium: str  # a preset's name, or "principled:<look index>"
    light: str  # POINT, SPOT, AREA or SUN
    direction: str  # FRONT, SIDE, BACK or RIM
    eta: float
    subsurface_scale: float = 0.0  # Principled conversions: Subsurface Scale in metres (0 for presets)
    yaw: float = 0.0  # the object's turn about the vertical, degrees
    half: str = "A"  # A: the half a fitted term may be fitted on; B: held out
    detail: float = 1.0  # generated shapes' polygon size multiplier (the tests' scenes: 2, for quick bakes)

    @property
    def principled(self) -> bool:
        return self.medium.startswith("principled:")


def draw(seed: int = 56, count: int = 24) -> list[Spec]:
    """``count`` scenes drawn with ``seed``: every shape, light and direction appears (cycled through shuffled
    orders, so no two factors stay locked together), sizes log-uniform in 1 cm - 1 m, media from the 12 presets
    and five Principled looks, a third of the scenes at an index of 1.3-1.4. Alternate scenes form the two
    halves (A, fitted; B, held out)."""
    rng = np.random.default_rng(seed)

    def cycled(items):
        order = []
        while len(order) < count:
            order.extend(rng.permutation(len(items)).tolist())
        return [items[i] for i in order[:count]]

    shapes, lights, directions = cycled(SHAPES), cycled(LIGHTS), cycled(DIRECTIONS)
    media = cycled(PRESETS + tuple(f"principled:{i}" for i in range(len(PRINCIPLED_LOOKS))))
    refracting = set(rng.permutation(count)[:count // 3].tolist())
    specs = []
    for i in range(count):
        size = float(np.exp(rng.uniform(np.log(0.01), np.log(1.0))))
        yaw = float(rng.uniform(0.0, 360.0))
        medium, eta, light = media[i], 1.0, lights[i]
        if i in refracting:
            eta = float(rng.choice((1.3, 1.33, 1.4)))
            light = "AREA"  # Cycles' brute force behind Glass converges under area lights only
            if medium.startswith("principled:"):
                medium = PRESETS[int(rng.integers(len(PRESETS)))]  # the Principled's own gloss is not the reference's
            if medium == "spectralon":
                # Nothing absorbed and Glass all round: every path of the brute force runs to Cycles' 1,024 bounces
                # (one seed of a 2.5 cm slab past nine minutes) and its light is cut there.
                medium = "skin1"
        scale = float(np.exp(rng.uniform(np.log(0.1), np.log(1.0)))) * size if medium.startswith("principled:") \
            else 0.0
        if not medium.startswith("principled:"):
            size = min(size, MAX_SIZE_MFP / (1000.0 * max(PRESET_SIGMA_S_PRIME[medium])))
        specs.append(Spec(f"s{i:02d}_{shapes[i]}_{directions[i].lower()}", shapes[i], round(size, 4), medium, light,
                          directions[i], eta, round(scale, 5), round(yaw, 1), "AB"[i % 2]))
    return specs


# -- generated shapes (pure: vertices, triangles) ------------------------------------------------------------
def torus(major: float = 1.0, minor: float = 0.35, u: int = 96, v: int = 48):
    """A torus around z."""
    a, b = np.meshgrid(np.linspace(0, 2 * np.pi, u, endpoint=False), np.linspace(0, 2 * np.pi, v, endpoint=False),
                       indexing="ij")
    r = major + minor * np.cos(b)
    vertices = np.stack([r * np.cos(a), r * np.sin(a), minor * np.sin(b)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(u), np.arange(v), indexing="ij")
    p00, p10, p01, p11 = i * v + j, (i + 1) % u * v + j, i * v + (j + 1) % v, (i + 1) % u * v + (j + 1) % v
    triangles = np.concatenate([np.stack([p00, p10, p11], -1).reshape(-1, 3),
                                np.stack([p00, p11, p01], -1).reshape(-1, 3)])
    return vertices.astype(np.float32), triangles.astype(np.int32)


# Metaball shapes: (type, centre, radius, (size_x, size_y, size_z), rotation about z in degrees). At the threshold
# of 0.6 an element's surface lies at about 0.4 of its radius (Blender's field falls as (1 - (d / R)^2)^3).
METABALLS = {
    "capsule": [("CAPSULE", (0, 0, 0), 0.9, (0.7, 0, 0), 0.0)],
    "slab": [("CUBE", (0, 0, 0), 0.3, (0.9, 0.6, 0.1), 0.0)],
    "leaf": [("ELLIPSOID", (0, 0, 0), 1.0, (1.0, 0.45, 0.05), 0.0)],
    "ear": [("ELLIPSOID", (0.55 * math.cos(t), 0.55 * math.sin(t) * 1.4, 0.0), 1.0, (0.34, 0.2, 0.06),
             math.degrees(t) + 90.0) for t in np.linspace(-1.9, 1.9, 13)]
    + [("ELLIPSOID", (0.15, 0.0, 0.0), 1.0, (0.45, 0.5, 0.05), 0.0)],  # the bowl inside the rim
    "quadruped": [("CAPSULE", (0, 0, 0.55), 0.5, (0.45, 0, 0), 0.0),  # body
                  *[("CAPSULE", (x, y, 0.25), 0.15, (0.0, 0, 0.28), 0.0) for x in (-0.4, 0.4) for y in (-0.13, 0.13)],
                  ("CAPSULE", (0.62, 0, 0.75), 0.22, (0.15, 0, 0), 0.0),  # neck
                  ("BALL", (0.8, 0, 0.85), 0.4, (0, 0, 0), 0.0),  # head
                  ("CAPSULE", (-0.72, 0, 0.62), 0.09, (0.2, 0, 0), 0.0)],  # tail
    "mushroom": [("ELLIPSOID", (0, 0, 0.9), 1.25, (1.0, 1.0, 0.45), 0.0),  # cap
                 ("CAPSULE", (0, 0, 0.45), 0.2, (0.0, 0, 0.4), 0.0)],  # stem
}
# Polygonisation cell per shape (metaball units): thin shapes finer.
METABALL_RESOLUTION = {"leaf": 0.012, "ear": 0.01, "quadruped": 0.02}


# The exact-transport tests' scenes (tests/test_exact_transport.py, 64x64, references in tests/data/exact/):
# a back-lit figure on thin legs, front-lit skin, and a body behind a refracting boundary.
TEST_SCENES = (
    Spec("backlit_figure", "quadruped", 0.1, "marble", "SPOT", "BACK", 1.0, yaw=20.0, detail=2.0),
    Spec("frontlit_skin", "spot", 0.2, "skin1", "POINT", "FRONT", 1.0, yaw=200.0),
    Spec("refracting_torus", "torus", 0.05, "potato", "AREA", "SIDE", 1.3, yaw=30.0, detail=2.0),
)


def build(spec: Spec, package: str, scene=None):
    """The scene of ``spec`` in the current file, with the extension ``package`` enabled: (scene, object).
    Blender-facing."""
    import importlib

    import bpy
    from mathutils import Euler, Vector

    demo = importlib.import_module(f"{package}.translucent_addon.blender.demo")
    props = importlib.import_module(f"{package}.translucent_addon.blender.props")
    scene = scene or bpy.context.scene
    coll = scene.collection
    ob = bpy.data.objects.new(spec.shape.capitalize(), _mesh(spec.shape, demo, spec.detail))
    coll.objects.link(ob)
    # Y-up meshes stand up; flat shapes stand on edge, their face half-turned to the camera; then the drawn turn.
    tilt = math.pi / 2 if spec.shape in BUNDLED else math.radians(70.0) if spec.shape in FLAT else 0.0
    yaw = math.radians(spec.yaw) if spec.shape not in FLAT else math.radians(spec.yaw % 90.0 - 45.0)
    ob.rotation_euler = Euler((tilt, 0.0, yaw), "XYZ")
    ob.data.shade_smooth()
    bpy.context.view_layer.update()
    extent = np.ptp(np.array([ob.matrix_world @ Vector(c) for c in ob.bound_box]), axis=0).max()
    ob.scale = (spec.size / extent,) * 3
    bpy.context.view_layer.update()
    corners = np.array([ob.matrix_world @ Vector(c) for c in ob.bound_box])
    ob.location = (-corners[:, 0].mean(), -corners[:, 1].mean(), -corners[:, 2].min())
    height = float(np.ptp(corners[:, 2]))
    centre = Vector((0.0, 0.0, height * 0.5))

    settings = ob.translucent
    if spec.principled:
        colour, radius = PRINCIPLED_LOOKS[int(spec.medium.split(":")[1])]
        mat = bpy.data.materials.new("Principled look")
        if bpy.app.version < (5, 0, 0):
            mat.use_nodes = True
        bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
        bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
        bsdf.inputs["Subsurface Weight"].default_value = 1.0
        bsdf.inputs["Subsurface Radius"].default_value = radius
        bsdf.inputs["Subsurface Scale"].default_value = spec.subsurface_scale
        bsdf.inputs["IOR"].default_value = spec.eta
        ob.data.materials.append(mat)
    else:
        settings.preset = spec.medium
        props.apply_preset(settings, spec.medium)
        settings.scattering_scale = 1.0
        settings.eta = spec.eta
    settings.method = "IMAGE_SPACE"

    radius = 2.5 * spec.size
    azimuth, elevation = (math.radians(a) for a in DIRECTION_ANGLES[spec.direction])
    camera_dir = Vector((0.0, -1.0, 0.0))
    d = Euler((0.0, 0.0, azimuth)).to_matrix() @ camera_dir
    d = (d * math.cos(elevation) + Vector((0, 0, math.sin(elevation)))).normalized()
    light = bpy.data.lights.new("Key Light", spec.light)
    # Irradiance at the object of about 3 W/m^2 whatever its size: P / (4 pi r^2) for a point, P / (pi r^2) on axis
    # for an area light, the sun's strength itself.
    if spec.light == "SUN":
        light.energy = 3.0
        light.angle = math.radians(2.0)
    elif spec.light == "AREA":
        light.energy = 3.0 * math.pi * radius ** 2
        # Large: behind Glass, Cycles' brute force reaches the light only by a path leaving the medium towards it.
        light.size = 1.2 * spec.size
    else:
        light.energy = 3.0 * 4.0 * math.pi * radius ** 2
        light.shadow_soft_size = 0.02 * spec.size
        if spec.light == "SPOT":
            light.spot_size = math.radians(40.0)
            light.spot_blend = 0.3
    key = bpy.data.objects.new("Key Light", light)
    key.location = centre + d * radius
    key.rotation_euler = (centre - key.location).to_track_quat("-Z", "Y").to_euler()
    coll.objects.link(key)

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 50.0
    cam.data.sensor_width = 36.0
    # Framed: the bounding box's sphere spans the 36 mm sensor's width.
    half = 0.5 * float(np.linalg.norm(np.ptp(corners, axis=0)))
    distance = half / (18.0 / 50.0)
    view = Vector((0.25, -1.0, 0.3)).normalized()
    cam.location = centre + view * distance
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.clip_start = distance * 0.01
    cam.data.clip_end = distance * 10.0
    coll.objects.link(cam)
    scene.camera = cam
    demo.uniform_world(scene, WORLD, "Suite World")
    scene.render.engine = "TRANSLUCENT_RT"
    return scene, ob


def _mesh(shape: str, demo, detail: float = 1.0):
    """The Blender mesh of a shape: bundled, parametric, or a metaball figure's surface."""
    import bpy

    if shape in BUNDLED:
        return demo.bundled_mesh(shape)
    if shape == "torus":
        return demo.mesh_from_arrays("torus", *torus(u=int(96 / detail), v=int(48 / detail)))
    mb = bpy.data.metaballs.new(shape)
    mb.resolution = mb.render_resolution = METABALL_RESOLUTION.get(shape, 0.03) * detail
    mb.threshold = 0.6
    for kind, centre, radius, (sx, sy, sz), rot in METABALLS[shape]:
        e = mb.elements.new(type=kind)
        e.co = centre
        e.radius = radius
        e.size_x, e.size_y, e.size_z = max(sx, 1e-3), max(sy, 1e-3), max(sz, 1e-3)
        e.rotation = _quat_z(rot)
    holder = bpy.data.objects.new(f"{shape} metaball", mb)
    bpy.context.scene.collection.objects.link(holder)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = bpy.data.meshes.new_from_object(holder.evaluated_get(depsgraph), depsgraph=depsgraph)
    bpy.data.objects.remove(holder)
    bpy.data.metaballs.remove(mb)
    mesh.name = shape
    return mesh


def _quat_z(degrees: float):
    h = math.radians(degrees) * 0.5
    return (math.cos(h), 0.0, 0.0, math.sin(h))

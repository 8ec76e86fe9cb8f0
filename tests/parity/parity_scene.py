"""The image-parity scene: every method, caustics, grass, a height field, a paint layer and world light in one
.blend, baked once on the reference Blender, then rendered view by view on every Blender and GPU backend.

Run with a Python that has bpy (a zip-only venv: bpy, pytest and nothing else); the extension is installed from
the built zip into a temporary user folder, as a user installs it:

    python parity_scene.py build  ZIP OUT.blend           bake every station, save (bakes beside the .blend)
    python parity_scene.py render ZIP IN.blend VIEW OUT.npy   F12 of one station's camera, linear RGBA float32
    python parity_scene.py views                          the station names, one a line

Each render runs in its own process (tests/zip_only/test_parity.py): a backend that crashes costs that one case.
"""
from __future__ import annotations

import atexit
import math
import os
import shutil
import sys
import tempfile

# Blender's user folders in a temporary place before bpy starts: the installed zip touches nothing of the user's.
# Removed at exit with the extension installed there (79 MB a process: 40 processes a `make test-zip`).
_USER = tempfile.mkdtemp(prefix="translucent-parity-user-")
atexit.register(shutil.rmtree, _USER, True)
for _var in ("BLENDER_USER_CONFIG", "BLENDER_USER_SCRIPTS", "BLENDER_USER_DATAFILES", "BLENDER_USER_EXTENSIONS"):
    os.environ[_var] = os.path.join(_USER, _var.split("_")[-1].lower())

WIDTH, HEIGHT = 64, 48
SPACING = 1.5  # metres between stations: one station's light and shadow do not reach the next one's camera
# Station name: what it shows. The order is the x position of the station. ``hold_out``: two tori (genus 1, a shape
# no test or bench tunes on), one TEXTURE_SPACE and one QUADGRAPH, baked like the rest.
STATIONS = ("image_space", "texture_space", "quadgraph", "geocube", "caustics", "grass", "height_field", "hold_out")
REPO_MODULE = "translucent_parity"


def install(zip_path: str):
    """Install and enable the zip in a temporary repository; returns the extension's package."""
    import importlib

    import bpy

    repos = bpy.context.preferences.extensions.repos
    folder = tempfile.mkdtemp(prefix="translucent-parity-repo-")
    atexit.register(shutil.rmtree, folder, True)
    repo = repos.new(name="Translucent parity", module=REPO_MODULE, custom_directory=folder)
    repo.use_custom_directory = True
    result = bpy.ops.extensions.package_install_files(filepath=zip_path, repo=REPO_MODULE, enable_on_install=True)
    if result != {"FINISHED"}:
        raise SystemExit(f"installing {zip_path} failed: {result}")
    return importlib.import_module(f"bl_ext.{REPO_MODULE}.translucent")


def _module(tr, name: str):
    import importlib

    return importlib.import_module(f"{tr.__name__}.{name}")


def _aim(ob, target) -> None:
    from mathutils import Vector

    ob.rotation_euler = (Vector(target) - ob.location).to_track_quat("-Z", "Y").to_euler()


def _camera(scene, name: str, x: float, location, target, lens: float = 50.0):
    import bpy

    cam = bpy.data.objects.new(name, bpy.data.cameras.new(name))
    cam.data.lens = lens
    cam.location = (x + location[0], location[1], location[2])
    _aim(cam, (x + target[0], target[1], target[2]))
    scene.collection.objects.link(cam)
    return cam


def _ball(name: str, x: float, preset: str, method: str, radius: float = 0.02):
    import bpy

    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=radius, location=(x, 0.0, radius))
    ball = bpy.context.active_object
    ball.name = name
    bpy.ops.object.shade_smooth()
    ball.translucent.preset = preset
    ball.translucent.method = method
    return ball


def _bake(ball) -> None:
    import bpy

    bpy.context.view_layer.objects.active = ball
    for ob in bpy.context.selected_objects:
        ob.select_set(False)
    ball.select_set(True)
    if bpy.ops.translucent.apply_quality(tier="DRAFT") != {"FINISHED"}:
        raise SystemExit(f"{ball.name}: Draft quality failed")
    if bpy.ops.translucent.bake() != {"FINISHED"}:
        raise SystemExit(f"{ball.name}: bake failed")


def build(zip_path: str, blend_path: str) -> None:
    import bpy
    import numpy as np

    tr = install(zip_path)
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "TRANSLUCENT_RT"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = WIDTH, HEIGHT, 100
    demo = _module(tr, "translucent_addon.blender.demo")
    demo.uniform_world(scene, (0.05, 0.06, 0.08))  # world light reaches every station
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(SPACING * (len(STATIONS) - 1) / 2, 0.0, 0.0))
    floor = bpy.context.active_object
    floor.name = "Floor"
    floor.scale = (SPACING * len(STATIONS), 2.0, 1.0)
    floor.data.materials.append(demo._material("Floor", (0.5, 0.5, 0.5)))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 1.0
    sun.location = (0.0, 0.0, 1.0)
    sun.rotation_euler = (math.radians(40), 0.0, math.radians(-30))
    scene.collection.objects.link(sun)

    views = {}
    for k, station in enumerate(STATIONS):
        x = SPACING * k
        if station == "image_space":
            ball = _ball("ImageSpace", x, "skin1", "IMAGE_SPACE")
            bpy.context.view_layer.objects.active = ball
            if bpy.ops.translucent.add_paint_layer(layer="translucent_glow", enter_paint_mode=False) != {"FINISHED"}:
                raise SystemExit("paint layer failed")
            half = [v.index for v in ball.data.vertices if v.co.x > 0.0]
            ball.vertex_groups["translucent_glow"].add(half, 1.0, "REPLACE")
        elif station == "texture_space":
            _bake(_ball("TextureSpace", x, "marble", "TEXTURE_SPACE"))
        elif station == "quadgraph":
            _bake(_ball("QuadGraph", x, "skin1", "QUADGRAPH"))
        elif station == "geocube":
            _bake(_ball("GeoCube", x, "skin1", "GEOCUBE"))
        elif station == "caustics":
            ball = _ball("CausticCaster", x, "skin1", "OFF", radius=0.03)
            ball.location.z = 0.08
            ball.translucent.caustics_caster = "REFRACTIVE"
            spot = bpy.data.objects.new("CausticSpot", bpy.data.lights.new("CausticSpot", "SPOT"))
            spot.data.energy, spot.data.spot_size = 20.0, math.radians(40)
            spot.location = (x, 0.0, 0.4)
            scene.collection.objects.link(spot)
        elif station == "grass":
            ground = demo.mesh_from_arrays("GrassGround", np.array(
                [(-0.3, -0.3, 0.001), (0.3, -0.3, 0.001), (0.3, 0.3, 0.001), (-0.3, 0.3, 0.001)], np.float32) +
                np.array([x, 0.0, 0.0], np.float32), np.array([(0, 1, 2), (0, 2, 3)]))
            ob = bpy.data.objects.new("GrassField", ground)
            scene.collection.objects.link(ob)
            s = ob.translucent
            s.grass_tile, s.grass_blade_height, s.grass_blades, s.grass_seed = 0.1, 0.045, 300, 7
            s.grass_resolution, s.grass_target_error = "64", 0.5
            bpy.context.view_layer.objects.active = ob
            if bpy.ops.translucent.add_grass_field() != {"FINISHED"}:
                raise SystemExit("grass bake failed")
        elif station == "hold_out":
            for dx, method, preset in ((-0.035, "TEXTURE_SPACE", "ketchup"), (0.035, "QUADGRAPH", "marble")):
                bpy.ops.mesh.primitive_torus_add(major_radius=0.025, minor_radius=0.009, major_segments=32,
                                                 minor_segments=12, location=(x + dx, 0.0, 0.009))
                torus = bpy.context.active_object
                torus.name = f"HoldOut{method.title().replace('_', '')}"
                bpy.ops.object.shade_smooth()
                torus.translucent.preset = preset
                torus.translucent.method = method
                _bake(torus)
        elif station == "height_field":
            im = _module(tr, "translucent_addon.techniques.relief.model")
            height = im.bumps(64).astype(np.float32)
            img = bpy.data.images.new("Height", 64, 64, float_buffer=True)
            rgba = np.repeat(height[..., None], 4, axis=-1)
            rgba[..., 3] = 1.0
            img.pixels.foreach_set(rgba.reshape(-1))
            img.pack()
            bpy.ops.mesh.primitive_plane_add(size=0.4, location=(x, 0.0, 0.04))  # above the floor by its depth
            ob = bpy.context.active_object
            ob.name = "HeightField"
            ob.data.materials.append(demo._material("Stone", (0.6, 0.55, 0.5)))
            s = ob.translucent
            s.relief, s.relief_image, s.relief_depth = "INTERVAL", img, 0.03
            s.relief_linear_steps, s.relief_iterations = 5, 10
        loc, target = {"grass": ((0.0, -0.6, 0.45), (0.0, 0.0, 0.0)),
                       "height_field": ((0.0, -0.3, 0.25), (0.0, 0.0, 0.0)),
                       "hold_out": ((0.0, -0.25, 0.15), (0.0, 0.0, 0.0))}.get(station, ((0.0, -0.22, 0.1),
                                                                                          (0.0, 0.0, 0.03)))
        views[station] = _camera(scene, f"View_{station}", x, loc, target)
    scene.camera = views[STATIONS[0]]
    bpy.ops.wm.save_as_mainfile(filepath=blend_path)
    print(f"parity scene: {len(STATIONS)} stations saved to {blend_path}")


def render(zip_path: str, blend_path: str, view: str, out_path: str) -> None:
    import bpy
    import gpu
    import numpy as np

    tr = install(zip_path)
    bpy.ops.wm.open_mainfile(filepath=blend_path)
    scene = bpy.context.scene
    scene.camera = bpy.data.objects[f"View_{view}"]
    runner = _module(tr, "translucent_addon.blender.compare_runner")
    image, _ = runner.render_pixels(scene, WIDTH, HEIGHT)
    np.save(out_path, image.astype(np.float32))
    print(f"parity render: {view} on Blender {bpy.app.version_string}, {gpu.platform.backend_type_get()}")


def main(argv) -> None:
    if argv[:1] == ["views"]:
        print("\n".join(STATIONS))
    elif argv[:1] == ["build"] and len(argv) == 3:
        build(argv[1], argv[2])
    elif argv[:1] == ["render"] and len(argv) == 5:
        render(*argv[1:])
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])

"""A fresh Blender for test_farm.py, as a render node runs one:

    python farm_child.py SCRIPTS_DIR render BLEND OUT.npy SIZE
    python farm_child.py SCRIPTS_DIR bake_all BLEND

``render`` opens BLEND and renders a SIZE x SIZE frame into OUT.npy (with *Fail on undrawable objects* on, as by
default, a lost object fails it). ``bake_all`` is the README's render-node command, ``blender -b BLEND
--python-exit-code 1 --python-expr "import bpy; bpy.ops.translucent.bake_all(); bpy.ops.wm.save_mainfile()"``: an
exception (a bake that failed) ends the process with exit code 1.
"""
import sys

sys.path.insert(0, sys.argv[1])
import blender_env  # noqa: E402

PACKAGE = blender_env.start()

import importlib  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

mode, blend = sys.argv[2], sys.argv[3]
bpy.ops.wm.open_mainfile(filepath=blend)
if mode == "render":
    render_pixels = importlib.import_module(PACKAGE + ".translucent_addon.blender.compare_runner").render_pixels
    scene = bpy.context.scene
    assert scene.translucent.fail_on_lost_objects
    size = int(sys.argv[5])
    np.save(sys.argv[4], render_pixels(scene, size, size)[0])
else:
    exec("import bpy; bpy.ops.translucent.bake_all(); bpy.ops.wm.save_mainfile()")
print("child done", flush=True)

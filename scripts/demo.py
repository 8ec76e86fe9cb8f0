"""`make demo`: render the bundled default scene (a back-lit marble bunny) with TRANSLUCENT_RT.

Installs the extension from this checkout into a temporary Blender user folder
(so nothing touches ~/.config), builds the scene, renders it with F12 and writes
out/demo.exr (linear float), out/demo.png (display-referred) and out/demo.blend.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", default="out")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    args = parser.parse_args()
    out = (ROOT / args.output).resolve()
    out.mkdir(parents=True, exist_ok=True)

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import blender_env

    blender_env.start()
    import bpy
    from bl_ext.checkout_repo.translucent.translucent_addon.blender.demo import build_default_scene

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = build_default_scene(bpy.context.scene)
    scene.render.resolution_x, scene.render.resolution_y = args.width, args.height
    bpy.ops.wm.save_as_mainfile(filepath=str(out / "demo.blend"))
    for fmt, name in (("OPEN_EXR", "demo.exr"), ("PNG", "demo.png")):
        scene.render.image_settings.file_format = fmt
        scene.render.filepath = str(out / name)
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        print(f"wrote {out / name} ({args.width}x{args.height}, {time.perf_counter() - t0:.2f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

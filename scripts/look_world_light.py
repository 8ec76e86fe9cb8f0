"""IMAGE_SPACE under world light (Shah 6.4.2): the marble bunny with no lamp, lit only by a sky over a
dark ground (an Environment Texture), with the world depth peeled (4 layers) and taken over a locally
flat surface (0 layers), against the CPU dipole model of the same spherical-harmonics irradiance.

Writes bench/results/image_space_world/*.png and world_light.json (relative RMSE, seconds).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def sky_image(h: int = 64, w: int = 128) -> np.ndarray:
    """A warm sky brightening towards the zenith over a dark blue ground, row 0 at the bottom."""
    lat = (np.arange(h) + 0.5) / h * np.pi - np.pi / 2
    up = np.clip(np.sin(lat), 0, None)[:, None, None]
    img = np.where(lat[:, None, None] > 0, [[[1.5, 1.2, 0.8]]], [[[0.05, 0.05, 0.1]]]) * (0.5 + up)
    return np.broadcast_to(img, (h, w, 3)).astype(np.float32)


def main() -> int:
    package = blender_env.start()
    import importlib

    import bpy

    def mod(name):
        return importlib.import_module(f"{package}.translucent_addon.{name}")

    demo, runner = mod("blender.demo"), mod("blender.compare_runner")
    report, metrics = mod("core.report.report"), mod("core.metrics")
    out = ROOT / "bench" / "results" / "image_space_world"
    out.mkdir(parents=True, exist_ok=True)
    size = int(sys.argv[1]) if len(sys.argv) > 1 else 256
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = demo.build_scene("bunny_backlit", bpy.context.scene)
    for ob in list(scene.objects):
        if ob.type == "LIGHT":
            bpy.data.objects.remove(ob)
    demo.environment_world(scene, sky_image())
    scene.render.resolution_x = scene.render.resolution_y = size
    subject = bpy.data.objects["Bunny"]
    width, height, mask, model, model_seconds = runner._model_setup(scene, [subject], 200_000, ROOT / "bench" / "cache",
                                                                     print)
    report.save_image_png(out / "dipole_model.png", model)
    rows = []
    for layers in (4, 0):
        scene.translucent.splat_world_layers = layers
        with runner.engine_setup(scene, "TRANSLUCENT_RT"):
            img, seconds = runner.render_pixels(scene, width, height)
        err = metrics.relative_rmse(img, model, mask)
        rows.append({"world_layers": layers, "seconds": round(seconds, 2), "rel_rmse_vs_model": round(err, 4)})
        report.save_image_png(out / f"image_space_layers_{layers}.png", img)
        report.save_error_png(out / f"image_space_layers_{layers}_error.png", img, model, mask)
        print(rows[-1], flush=True)
    (out / "world_light.json").write_text(json.dumps({"size": [width, height], "model_seconds": model_seconds,
                                                      "rows": rows}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""QUADGRAPH on spot, the cow and a torus knot (issue 6: render them and look for artefacts).

Bakes each at K = 1 and renders it at 320 x 240 with TRANSLUCENT_RT; the torus knot (a (2, 3) knot
swept by a circle, genus 1 and knotted, so the surface passes close to itself) stands in the bunny
scene's place in marble. Writes bench/results/quadgraph/shapes/*.png and shapes.json.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def torus_knot(p: int = 2, q: int = 3, segments: int = 384, sides: int = 20, tube: float = 0.35):
    """Vertices and triangles of a (p, q) torus knot tube (closed, watertight, wound outward)."""
    t = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    r = 2.0 + np.cos(q * t)
    c = np.stack([r * np.cos(p * t), r * np.sin(p * t), -np.sin(q * t)], axis=1)
    tangent = np.roll(c, -1, axis=0) - np.roll(c, 1, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = np.cross(tangent, [0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    binormal = np.cross(tangent, normal)
    a = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    ring = np.cos(a)[None, :, None] * normal[:, None, :] + np.sin(a)[None, :, None] * binormal[:, None, :]
    verts = (c[:, None, :] + tube * ring).reshape(-1, 3)
    i = np.arange(segments)[:, None]
    j = np.arange(sides)[None, :]
    v00 = i * sides + j
    v10 = ((i + 1) % segments) * sides + j
    v01 = i * sides + (j + 1) % sides
    v11 = ((i + 1) % segments) * sides + (j + 1) % sides
    tris = np.concatenate([np.stack([v00, v11, v10], -1).reshape(-1, 3), np.stack([v00, v01, v11], -1).reshape(-1, 3)])
    return verts, tris


def main() -> int:
    package = blender_env.start()
    import importlib

    import bpy

    demo = importlib.import_module(f"{package}.translucent_addon.blender.demo")
    runner = importlib.import_module(f"{package}.translucent_addon.blender.compare_runner")
    report = importlib.import_module(f"{package}.translucent_addon.core.report.report")
    out = ROOT / "bench" / "results" / "quadgraph" / "shapes"
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in ("spot_frontlit", "cow_backlit", "torus_knot"):
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = demo.build_scene("bunny_backlit" if name == "torus_knot" else name, bpy.context.scene)
        subject = bpy.data.objects["Bunny" if name == "torus_knot" else demo.SCENES[name]["mesh"].capitalize()]
        if name == "torus_knot":
            v, t = torus_knot()
            mesh = demo.mesh_from_arrays("Torus knot", v, t)
            mesh.materials.append(subject.data.materials[0])
            subject.data = mesh
            subject.data.shade_smooth()
            subject.rotation_euler = (0.0, 0.0, 0.0)
            subject.scale = (0.15 / 6.7,) * 3
            subject.location.z = 0.075
        subject.translucent.method = "QUADGRAPH"
        subject.translucent.quadgraph_K = 1.0
        bake_seconds, (meta,) = runner.bake_objects([subject], "QUADGRAPH", progress=lambda text: print(text))
        with runner.engine_setup(scene, "TRANSLUCENT_RT"):
            runner.render_pixels(scene, 320, 240)
            img, sec = runner.render_pixels(scene, 320, 240)
        report.save_image_png(out / f"{name}.png", img)
        rows.append({"scene": name, "triangles": len(subject.data.polygons), "bake_seconds": round(bake_seconds, 2),
                     "surface_nodes": meta["surface_nodes"], "inner_nodes": meta["inner_nodes"], "seconds": sec,
                     "finite": bool(np.isfinite(img).all()), "max": float(img[..., :3].max())})
        print(rows[-1], flush=True)
    (out / "shapes.json").write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Stability suite of the benchmark: where each method fails, with numbers (the benchmark issue).

Each case against exact transport: Cycles' brute force (a homogeneous volume in the mesh) with the medium
index-matched (eta = 1) and the floor taken out, as in bench_quadgraph (Cycles then samples the lights
from inside the volume and converges; a glass boundary leaves fireflies). Beside our subsurface methods
(IMAGE_SPACE, TEXTURE_SPACE at atlas 256, QUADGRAPH at K = 1): EEVEE at 16 samples and Cycles' random
walk at 256 spp, the two a user would otherwise reach for. The cases:

- a thin feature: a 2 mm skin plate, back-lit (light crosses it; the graph and the proxy are coarser
  than the plate, the dipole assumes a half-space);
- high curvature: an 8 mm marble ball, front-lit (marble's diffusion length, 8 mm in red, is the ball's
  size: every flat-surface kernel is stretched over its curve);
- not star-shaped: a marble torus knot, back-lit (a surface that passes behind itself);
- a tiny object: the marble bunny at 6 mm (smaller than the diffusion length: a glowing bead);
- a huge object: the marble bunny at 3 m (400 diffusion lengths: nearly opaque, detail in mm);
- fast light motion: the back-lit bunny with its key turning 0.5 degrees per frame over 8 frames; the
  flicker is the image's second difference in time over its mean (a smooth change leaves about 0;
  jumps between frames, as from light-view samples snapping to a grid, do not). No reference needed.

Extreme coefficients are in the tests (``tests/test_stability.py``, ``tests/test_stability_render.py``).
Writes bench/results/stability/ (summary.md, results.json, an image per case and series).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402
from look_quadgraph import torus_knot  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
METHODS = ("IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH")
TEXTURE_SPACE_ATLAS = 256
QUADGRAPH_K = 1.0
FLICKER_FRAMES = 8
FLICKER_STEP_DEG = 0.5
REFERENCE_SAMPLES = 1024  # Cycles' brute force, index-matched


def box(size_x: float, size_y: float, size_z: float):
    """A closed box centred on x and y, standing on z = 0, wound outward."""
    v = np.array([[x, y, z] for x in (-size_x / 2, size_x / 2) for y in (-size_y / 2, size_y / 2)
                  for z in (0.0, size_z)])
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
                  [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return v, f


def ico_sphere(subdivisions: int = 4):
    """A unit ico-sphere (vertices, triangles), wound outward."""
    t = (1 + 5**0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
         (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
         (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    v = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(subdivisions):
        cache, out = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = v[a] + v[b]
                v.append(m / np.linalg.norm(m))
                cache[key] = len(v) - 1
            return cache[key]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            out += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = out
    return np.array(v), np.array(f)


# name: (scene of demo.SCENES to stage it in, its size in m, a generated mesh or None, preset, key light)
CASES = {
    "thin plate 2 mm": ("bunny_backlit", 0.06, lambda: box(1.0, 2.0 / 60.0, 1.0), "skin1"),
    "ball 8 mm": ("bunny_frontlit", 0.008, lambda: ico_sphere(4), "marble"),
    "torus knot": ("bunny_backlit", 0.15, lambda: torus_knot(), "marble"),
    "bunny 6 mm": ("bunny_backlit", 0.006, None, "marble"),
    "bunny 3 m": ("bunny_backlit", 3.0, None, "marble"),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "stability"))
    parser.add_argument("--cache", default=str(ROOT / "bench" / "cache"))
    parser.add_argument("--width", type=int, default=128)
    parser.add_argument("--height", type=int, default=96)
    parser.add_argument("--cases", nargs="*", default=list(CASES) + ["flicker"])
    args = parser.parse_args()

    package = blender_env.start()
    import importlib

    import bpy

    mod = {name: importlib.import_module(f"{package}.translucent_addon.{name}") for name in (
        "blender.demo", "blender.compare_runner", "core.reference.cache", "core.metrics", "core.report.report",
        "blender.extract", "blender.bvh_tracer", "blender.props")}
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    rows, flicker = [], []
    t_start = time.perf_counter()
    for case in args.cases:
        if case == "flicker":
            flicker = flicker_case(args, mod, bpy, out)
        else:
            rows += accuracy_case(case, args, mod, bpy, out)
    machine = {**mod["blender.compare_runner"].machine_description(), "blender": bpy.app.version_string,
               "total_seconds": round(time.perf_counter() - t_start, 1)}
    (out / "results.json").write_text(json.dumps({"machine": machine, "rows": rows, "flicker": flicker}, indent=2))
    (out / "summary.md").write_text(summary(rows, flicker, machine, args))
    print(f"wrote {out / 'summary.md'}")
    return 0


def stage(case: str, mod, bpy):
    """The case's scene: a scene of the set, its object resized (lights and camera follow) or replaced by
    a generated mesh, the camera's clipping scaled with it."""
    base, size, make_mesh, preset = CASES[case]
    demo = mod["blender.demo"]
    bpy.ops.wm.read_homefile(use_empty=True)
    saved = dict(demo.SCENES[base])
    demo.SCENES[base] = {**saved, "size": size, "preset": preset}
    try:
        scene = demo.build_scene(base, bpy.context.scene)
    finally:
        demo.SCENES[base] = saved
    subject = bpy.data.objects[saved["mesh"].capitalize()]
    if make_mesh is not None:
        v, t = make_mesh()
        v = np.asarray(v, np.float64)
        v = (v - [*(v[:, :2].min(0) + v[:, :2].max(0)) / 2, v[:, 2].min()]) / np.ptp(v, axis=0).max()
        mesh = demo.mesh_from_arrays(case, v, t)
        mesh.materials.append(subject.data.materials[0])
        subject.data = mesh
        if case != "thin plate 2 mm":  # the plate keeps its flat faces and sharp edges
            subject.data.shade_smooth()
        subject.rotation_euler = (0.0, 0.0, 0.0)
        subject.scale = (size,) * 3
        subject.location = (0.0, 0.0, 0.0)
    scene.camera.data.clip_start = min(0.1, 0.02 * size)
    scene.camera.data.clip_end = max(100.0, 50.0 * size)
    scene.collection.objects.unlink(bpy.data.objects["Ground"])  # exact transport: nothing but the object
    subject.translucent.eta = 1.0
    bpy.context.view_layer.update()
    return scene, subject


def draw(scene, subject, method: str, runner, w: int, h: int) -> tuple[np.ndarray, float, float]:
    """(image, seconds per frame, bake seconds) of one of our methods."""
    subject.translucent.method = method
    subject.translucent.atlas_resolution = TEXTURE_SPACE_ATLAS
    subject.translucent.quadgraph_K = QUADGRAPH_K
    bake = 0.0
    if method != "IMAGE_SPACE":
        bake, _ = runner.bake_objects([subject], method, progress=lambda text: print("   ", text, flush=True))
    with runner.engine_setup(scene, "TRANSLUCENT_RT"):
        runner.render_pixels(scene, w, h)  # uploads
        image, sec = runner.render_pixels(scene, w, h)
    return image, sec, bake


def accuracy_case(case: str, args, mod, bpy, out: Path) -> list[dict]:
    runner, cache, metrics, report = (mod[k] for k in ("blender.compare_runner", "core.reference.cache", "core.metrics",
                                                         "core.report.report"))
    extract, bvh = mod["blender.extract"], mod["blender.bvh_tracer"]
    print(f"== {case}", flush=True)
    scene, subject = stage(case, mod, bpy)
    w, h = args.width, args.height
    scene.render.resolution_x, scene.render.resolution_y = w, h
    settings = runner.CompareSettings()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, w, h))
    mask = runner.interior(runner._mask(frame, bvh.BVHTracer(runner.scene_triangles(frame)[0]), {subject.name}))
    desc = {**runner.scene_description(depsgraph, frame, [subject]), "engine": "CYCLES", "kind": "brute_force",
            "samples": REFERENCE_SAMPLES, "bounces": settings.cycles_bounces, "self_interreflection": True}
    hit = cache.load(Path(args.cache), desc)
    if hit is None:
        print(f"   Cycles brute force {REFERENCE_SAMPLES} spp (eta 1) ...", flush=True)
        with runner.twin_materials_applied([subject], "brute_force"), \
                runner.engine_setup(scene, "CYCLES", **runner.cycles_options(REFERENCE_SAMPLES,
                                                                             settings.cycles_bounces)):
            image, sec = runner.render_pixels(scene, w, h)
        cache.store(Path(args.cache), desc, image, sec)
        hit = (image, sec)
    ref = hit[0]
    slug = "".join(c if c.isalnum() else "_" for c in case).lower()
    report.save_image_png(out / f"{slug}_cycles_reference.png", ref)
    rows = []

    def measure(label, image, sec, bake=0.0, error=""):
        if error:
            row = {"case": case, "method": label, "error": error}
        else:
            finite = bool(np.isfinite(image).all())
            img = np.nan_to_num(image)
            lum = metrics.luminance(img)[mask]
            row = {"case": case, "method": label, "seconds": round(sec, 3), "bake_seconds": round(bake, 2),
                   "finite": finite, "mask_pixels": int(mask.sum()),
                   "black_fraction": float((lum <= 1e-3 * max(float(metrics.luminance(ref)[mask].mean()), 1e-12))
                                           .mean()),
                   "median": metrics.median_relative_error(img, ref, mask),
                   "rel_rmse": metrics.relative_rmse(img, ref, mask),
                   "mean_ratio": [float(v) for v in img[mask][:, :3].mean(0) / np.maximum(ref[mask][:, :3].mean(0),
                                                                                            1e-12)]}
            report.save_image_png(out / f"{slug}_{label.lower().replace(' ', '_')}.png", img)
            report.save_error_png(out / f"{slug}_{label.lower().replace(' ', '_')}_error.png", img, ref, mask)
        rows.append(row)
        print(f"   {label}: {row}", flush=True)

    for method in METHODS:
        try:
            image, sec, bake = draw(scene, subject, method, runner, w, h)
            measure(method, image, sec, bake)
        except Exception as exc:  # a failure is a result here: the suite reports it and goes on
            measure(method, None, 0.0, error=f"{type(exc).__name__}: {exc}")
    subject.translucent.method = "IMAGE_SPACE"
    with runner.twin_materials_applied([subject], "random_walk"), \
            runner.engine_setup(scene, "BLENDER_EEVEE", **runner.eevee_options(16)):
        image, sec = runner.render_pixels(scene, w, h)
    measure("EEVEE 16", image, sec)
    with runner.twin_materials_applied([subject], "random_walk"), \
            runner.engine_setup(scene, "CYCLES", **runner.cycles_options(256, settings.cycles_bounces)):
        image, sec = runner.render_pixels(scene, w, h)
    measure("Cycles random walk 256", image, sec)
    return rows


def flicker_case(args, mod, bpy, out: Path) -> list[dict]:
    """The back-lit bunny with its key light turned FLICKER_STEP_DEG per frame about the vertical axis
    through the bunny: per method, the mean over frames of RMS(f[t+1] - 2 f[t] + f[t-1]) / mean(f) over
    the object's pixels (the second difference: a smooth change of light gives almost 0), and the same
    for the first difference (how much the light's motion changes the image at all)."""
    runner, metrics = mod["blender.compare_runner"], mod["core.metrics"]
    demo, extract, bvh = mod["blender.demo"], mod["blender.extract"], mod["blender.bvh_tracer"]
    print("== flicker", flush=True)
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = demo.build_scene("bunny_backlit", bpy.context.scene)
    w, h = args.width, args.height
    scene.render.resolution_x, scene.render.resolution_y = w, h
    subject = bpy.data.objects["Bunny"]
    key = bpy.data.objects["Key Light"]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, w, h))
    mask = runner.interior(runner._mask(frame, bvh.BVHTracer(runner.scene_triangles(frame)[0]), {subject.name}))
    from mathutils import Matrix

    start = key.matrix_world.copy()
    rows = []
    for method in METHODS + ("EEVEE 16",):
        frames = []
        if method != "EEVEE 16":
            subject.translucent.method = method
            subject.translucent.atlas_resolution = TEXTURE_SPACE_ATLAS
            subject.translucent.quadgraph_K = QUADGRAPH_K
            if method != "IMAGE_SPACE":
                runner.bake_objects([subject], method)
        for n in range(FLICKER_FRAMES):
            key.matrix_world = Matrix.Rotation(math.radians(FLICKER_STEP_DEG * n), 4, "Z") @ start
            if method == "EEVEE 16":
                with runner.twin_materials_applied([subject], "random_walk"), \
                        runner.engine_setup(scene, "BLENDER_EEVEE", **runner.eevee_options(16)):
                    image, _ = runner.render_pixels(scene, w, h)
            else:
                with runner.engine_setup(scene, "TRANSLUCENT_RT"):
                    image, _ = runner.render_pixels(scene, w, h)
            frames.append(metrics.luminance(np.nan_to_num(image))[mask])
        key.matrix_world = start
        f = np.stack(frames)
        mean = float(f.mean())
        d1 = np.sqrt((np.diff(f, axis=0) ** 2).mean(axis=1)).mean() / mean
        d2 = np.sqrt((np.diff(f, n=2, axis=0) ** 2).mean(axis=1)).mean() / mean
        # The object's mean: a shadow edge crossing pixels averages out there, a jump of the whole does not.
        m = f.mean(axis=1)
        g1 = float(np.abs(np.diff(m)).mean() / mean)
        g2 = float(np.abs(np.diff(m, n=2)).mean() / mean)
        rows.append({"method": method, "first_difference": float(d1), "second_difference": float(d2),
                     "ratio": float(d2 / max(d1, 1e-12)), "mean_first_difference": g1, "mean_second_difference": g2,
                     "frame_means": [float(v) for v in m]})
        print(f"   {method}: {rows[-1]}", flush=True)
    return rows


def summary(rows, flicker, machine, args) -> str:
    lines = [
        "# Stability: where each method fails",
        "",
        f"Machine: {machine.get('cpu', '?')}, {machine.get('cores', '?')} cores; Blender {machine['blender']}; "
        f"{args.width}x{args.height} px; whole run {machine['total_seconds']} s (our engine and EEVEE on Mesa "
        f"llvmpipe). Each case against exact transport (Cycles' brute force, {REFERENCE_SAMPLES} spp, the medium "
        "index-matched and the floor taken out): the median "
        "relative error over the object's pixels (robust to the reference's fireflies), the relative RMSE, "
        "the mean per channel over the reference's, and the share of the object drawn black (below 1e-3 of the "
        f"reference's mean). TEXTURE_SPACE at atlas {TEXTURE_SPACE_ATLAS}, QUADGRAPH at K = {QUADGRAPH_K:g}.",
        "",
        "| case | method | median | rel. RMSE | mean ratio (r, g, b) | black | finite | s/frame | bake s |",
        "|---|---|---:|---:|---|---:|---|---:|---:|",
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['case']} | {r['method']} | fails: {r['error']} | | | | | | |")
            continue
        ratio = ", ".join(f"{v:.2f}" for v in r["mean_ratio"])
        lines.append(f"| {r['case']} | {r['method']} | {r['median']:.3f} | {r['rel_rmse']:.3f} | {ratio} | "
                     f"{r['black_fraction']:.3f} | {'yes' if r['finite'] else 'NO'} | {r['seconds']:.2f} | "
                     f"{r['bake_seconds']:.1f} |")
    if flicker:
        lines += ["", f"## Fast light motion: the back-lit bunny's key turned {FLICKER_STEP_DEG} degrees per frame, "
                      f"{FLICKER_FRAMES} frames", "",
                  "RMS of the image's first and second differences in time over its mean (object pixels), and "
                  "the same for the object's mean brightness. A smooth response to the moving light has a second "
                  "difference much below its first; flicker (values jumping between frames) brings them together. "
                  "Per pixel, a shadow edge crossing a pixel is a step too, so the mean's differences are the "
                  "cleaner measure of flicker.", "",
                  "| method | first difference | second difference | second / first | the mean's first "
                  "difference | the mean's second difference |", "|---|---:|---:|---:|---:|---:|"]
        for r in flicker:
            lines.append(f"| {r['method']} | {r['first_difference']:.4f} | {r['second_difference']:.4f} | "
                         f"{r['ratio']:.2f} | {r['mean_first_difference']:.4f} | {r['mean_second_difference']:.4f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())

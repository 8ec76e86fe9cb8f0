"""The artist's material against Cycles: `make bench-material`.

An asset of our own making: the bundled spot (Keenan Crane, CC0) with its UV map, a generated albedo texture
(cream with dark patches and fine speckle), a generated tangent-space normal map of small bumps, a Principled BSDF
at Subsurface Weight 1, roughness 0.4, IOR 1.4, front-lit by an area light under a dim world, 256 x 256. The
reference is Cycles rendering that same material (random walk, 512 samples, the pixel filter at 0.01 px as ours
samples pixel centres); it is the reference an artist compares with (front-lit, textured: exact transport does not
apply). Per subsurface method: the relative RMSE over 4 x 4-pixel blocks, the correlation of the high-passed
luminance (the texture's and the bumps' detail: the image less its Gaussian blur of 2 px), the per-channel mean,
the F12 time (second frame). Then the demo scene's frame with the surface layer and without it (the frame before
this layer existed: its gloss and colour passes skipped), in one run. Writes bench/results/material/.

    python scripts/bench_material.py [--samples 512] [--size 256]
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import statistics
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
METHODS = ("IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH")
BLOCK = 4


def albedo_texture(n: int = 512, seed: int = 5) -> np.ndarray:
    """(n, n, 3) linear albedo: cream with dark patches (low-frequency noise thresholded softly) and speckle."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n, 0:n] / n
    low = sum(np.sin(2 * np.pi * (fx * x + fy * y) + p) for fx, fy, p in rng.uniform((-4, -4, 0), (4, 4, 6.3), (6, 3)))
    patch = 1.0 / (1.0 + np.exp(-4.0 * (low - 0.8)))
    cream, dark = np.array([0.82, 0.72, 0.6]), np.array([0.16, 0.1, 0.08])
    speckle = 1.0 + 0.12 * rng.standard_normal((n, n, 1))
    return np.clip((cream * (1 - patch[..., None]) + dark * patch[..., None]) * speckle, 0.0, 1.0)


def normal_texture(n: int = 256, seed: int = 9, strength: float = 2.0) -> np.ndarray:
    """(n, n, 3) tangent-space normals of small bumps (a smooth random height field), encoded 0.5 + 0.5 n."""
    rng = np.random.default_rng(seed)
    h = rng.standard_normal((n, n))
    k = np.fft.fftfreq(n)
    K = np.sqrt(k[:, None] ** 2 + k[None, :] ** 2)
    h = np.real(np.fft.ifft2(np.fft.fft2(h) * np.exp(-(K / 0.04) ** 2)))
    h /= np.abs(h).max()
    dv, du = np.gradient(h)
    nrm = np.dstack([-strength * du * n / 32, -strength * dv * n / 32, np.ones_like(h)])
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    return 0.5 + 0.5 * nrm


def image(bpy, name: str, pixels: np.ndarray, non_color: bool = False):
    h, w = pixels.shape[:2]
    img = bpy.data.images.new(name, w, h, float_buffer=True)
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = pixels
    img.pixels.foreach_set(rgba.ravel())
    img.pack()  # kept in the file, in case the scene is saved for a look in Blender
    return img


def build(bpy, demo, size: float):
    """The textured spot, its material, an area light, a dim world and a camera; returns (scene, object)."""
    scene = bpy.context.scene
    demo.uniform_world(scene, (0.04, 0.04, 0.05))
    ob = bpy.data.objects.new("Spot", demo.bundled_mesh("spot"))
    ob.rotation_euler = (math.pi / 2, 0.0, math.radians(-35.0))
    scene.collection.objects.link(ob)
    for p in ob.data.polygons:
        p.use_smooth = True
    mat = bpy.data.materials.new("Spot Skin")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Radius"].default_value = (1.0, 0.45, 0.25)
    bsdf.inputs["Subsurface Scale"].default_value = 0.04 * size
    bsdf.inputs["Roughness"].default_value = 0.4
    bsdf.inputs["IOR"].default_value = 1.4
    colour = tree.nodes.new("ShaderNodeTexImage")
    colour.image = image(bpy, "Spot Albedo", albedo_texture())
    tree.links.new(colour.outputs["Color"], bsdf.inputs["Base Color"])
    bumps = tree.nodes.new("ShaderNodeTexImage")
    bumps.image = image(bpy, "Spot Bumps", normal_texture(), non_color=True)
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    normal_map.inputs["Strength"].default_value = 1.0
    tree.links.new(bumps.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    ob.data.materials.append(mat)
    light = bpy.data.lights.new("Key", "AREA")
    light.size = 0.6 * size
    light.energy = 60.0 * size * size
    key = bpy.data.objects.new("Key Light", light)
    key.location = (0.6 * size, -2.2 * size, 1.2 * size)
    scene.collection.objects.link(key)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.2 * size, -3.6 * size, 0.45 * size)
    scene.collection.objects.link(cam)
    scene.camera = cam
    from mathutils import Vector

    for o, target in ((key, Vector((0, 0, 0))), (cam, Vector((0, 0, 0)))):
        o.rotation_euler = (target - o.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 50.0
    scene.render.film_transparent = True
    return scene, ob


def two_slots(bpy, runner, size: int) -> list[dict]:
    """A sphere of two Principled materials (left and right halves) against the sphere with each alone, per method:
    each half's mean over the other's, away from the seam."""
    import bmesh
    from mathutils import Vector

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "TRANSLUCENT_RT"
    world = bpy.data.worlds.new("World")
    world.color = (0.1, 0.1, 0.1)
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 2.0
    sun.location = (0.5, -3.0, 2.0)
    sun.rotation_euler = (Vector((0, 0, 0)) - sun.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -4.0, 0.0)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    mats = []
    for name, colour in (("A", (0.85, 0.45, 0.3)), ("B", (0.3, 0.6, 0.85))):
        mat = bpy.data.materials.new(name)
        if bpy.app.version < (5, 0, 0):
            mat.use_nodes = True
        bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
        bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
        bsdf.inputs["Subsurface Weight"].default_value = 1.0
        bsdf.inputs["Subsurface Radius"].default_value = (0.1, 0.05, 0.03)
        mats.append(mat)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=64, v_segments=32, radius=1.0)
    for f in bm.faces:
        f.smooth = True
    me = bpy.data.meshes.new("Ball")
    bm.to_mesh(me)
    bm.free()
    ob = bpy.data.objects.new("Ball", me)
    scene.collection.objects.link(ob)
    rows = []
    cols = np.arange(size)
    for method in METHODS:
        ob.translucent.method = method
        images = {}
        for label, slots in (("both", mats), ("A", mats[:1]), ("B", mats[1:])):
            me.materials.clear()
            for mat in slots:
                me.materials.append(mat)
            for poly in me.polygons:
                poly.material_index = int(poly.center.x > 0.0) if len(slots) == 2 else 0
            me.update()
            if method != "IMAGE_SPACE":
                runner.bake_objects([ob], method, progress=lambda *_: None)
            images[label] = runner.render_pixels(scene, size, size)[0][..., :3]
        inside = images["both"].sum(-1) > 0.05 * images["both"].sum(-1).max()
        row = {"method": method}
        for label, side in (("A", cols < size // 2 - size // 10), ("B", cols > size // 2 + size // 10)):
            keep = inside & side[None, :]
            row[label] = [round(float(x), 4) for x in images["both"][keep].mean(0) / images[label][keep].mean(0)]
        rows.append(row)
        print(row, flush=True)
    return rows


def high_pass(lum: np.ndarray, sigma: float = 2.0) -> np.ndarray:
    """lum less its Gaussian blur (separable, reflect padding)."""
    r = int(3 * sigma)
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    pad = np.pad(lum, r, mode="reflect")
    blur = np.apply_along_axis(lambda v: np.convolve(v, k, "valid"), 0, pad)
    blur = np.apply_along_axis(lambda v: np.convolve(v, k, "valid"), 1, blur)
    return lum - blur


def eroded(mask: np.ndarray, steps: int) -> np.ndarray:
    m = mask.copy()
    for _ in range(steps):
        m[1:-1, 1:-1] &= m[:-2, 1:-1] & m[2:, 1:-1] & m[1:-1, :-2] & m[1:-1, 2:]
        m[[0, -1]] = False
        m[:, [0, -1]] = False
    return m


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--samples", type=int, default=512)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "material"))
    args = parser.parse_args()
    package = blender_env.start()
    import bpy

    def mod(name):
        return sys.modules[f"{package}.translucent_addon.{name}"]

    import importlib

    demo = importlib.import_module(f"{package}.translucent_addon.blender.demo")
    runner = importlib.import_module(f"{package}.translucent_addon.blender.compare_runner")
    metrics = importlib.import_module(f"{package}.translucent_addon.core.metrics")
    png = importlib.import_module(f"{package}.translucent_addon.core.report.png")
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    w = h = args.size
    bpy.ops.wm.read_homefile(use_empty=True)
    scene, ob = build(bpy, demo, 1.0)
    scene.render.engine = "TRANSLUCENT_RT"

    # The reference, cached by what makes it.
    cache = ROOT / "bench" / "cache"
    cache.mkdir(parents=True, exist_ok=True)
    import inspect

    source = "".join(inspect.getsource(f) for f in (build, albedo_texture, normal_texture, image)).encode() \
        + bpy.app.version_string.encode() + f"{args.samples} {w}".encode()
    cached = cache / f"material_{hashlib.blake2b(source, digest_size=8).hexdigest()}.npy"
    if cached.exists():
        reference, cycles_seconds = np.load(cached), float("nan")
    else:
        with runner.engine_setup(scene, "CYCLES", samples=args.samples, use_denoising=False, filter_width=0.01,
                                 use_adaptive_sampling=False):
            reference, cycles_seconds = runner.render_pixels(scene, w, h)
        np.save(cached, reference)
    mask = eroded(reference[..., 3] > 0.99, 1)
    ref_hp = high_pass(metrics.luminance(reference[..., :3]))
    inner = eroded(mask, 3)
    rows = []
    images = {"Cycles": reference}
    for method in METHODS:
        ob.translucent.method = method
        bake_seconds = 0.0
        if method != "IMAGE_SPACE":
            bake_seconds, _ = runner.bake_objects([ob], method, progress=lambda *_: None)
        runner.render_pixels(scene, w, h)
        img, seconds = runner.render_pixels(scene, w, h)
        images[method] = img
        hp = high_pass(metrics.luminance(img[..., :3]))
        corr = float(np.corrcoef(hp[inner], ref_hp[inner])[0, 1])
        means = img[..., :3][mask].mean(0) / reference[..., :3][mask].mean(0)
        rows.append({"method": method, "block_rel_rmse": round(metrics.block_relative_rmse(img, reference, mask, BLOCK),
                                                                4),
                     "high_pass_correlation": round(corr, 3), "mean_rgb": [round(float(x), 3) for x in means],
                     "seconds": round(seconds, 3), "bake_seconds": round(bake_seconds, 1)})
        print(rows[-1], flush=True)
    strip = np.concatenate([metrics.display(images[k][..., :3]) for k in ("Cycles", *METHODS)], axis=1)
    png.write_png(out / "spot_textured.png", strip)

    slot_rows = two_slots(bpy, runner, 128)

    # The surface layer's cost on the demo scene: the same frames with the layer and with it skipped.
    layer_mod = mod("gpu.surface_layer")
    bpy.ops.wm.read_homefile(use_empty=True)
    demo_scene = demo.build_default_scene(bpy.context.scene)
    subject = next(o for o in demo_scene.objects if o.type == "MESH" and o.translucent.method != "OFF")
    cost = {}
    original = layer_mod.SurfaceLayer.begin
    for method in ("IMAGE_SPACE", "TEXTURE_SPACE"):
        subject.translucent.method = method
        if method == "TEXTURE_SPACE":
            runner.bake_objects([subject], method, progress=lambda *_: None)
        for label, begin in (("with the surface layer", original), ("without it", lambda *a, **k: None)):
            layer_mod.SurfaceLayer.begin = begin
            try:
                runner.render_pixels(demo_scene, 480, 270)
                cost[(method, label)] = statistics.median(runner.render_pixels(demo_scene, 480, 270)[1]
                                                          for _ in range(5))
            finally:
                layer_mod.SurfaceLayer.begin = original
    ratios = {m: cost[(m, "with the surface layer")] / cost[(m, "without it")] for m in ("IMAGE_SPACE",
                                                                                         "TEXTURE_SPACE")}
    info = {"blender": bpy.app.version_string, "size": [w, h], "samples": args.samples,
            "cycles_seconds": None if math.isnan(cycles_seconds) else round(cycles_seconds, 1),
            "demo_frame_seconds": {f"{m} {k}": round(v, 3) for (m, k), v in cost.items()},
            "demo_frame_ratio": {m: round(r, 3) for m, r in ratios.items()}}
    (out / "results.json").write_text(json.dumps({"info": info, "rows": rows, "two_slots": slot_rows}, indent=1))
    lines = ["# The artist's material against Cycles (`scripts/bench_material.py`)", "",
             f"Textured, glossy, normal-mapped spot, {w} x {h}, front-lit by an area light; reference Cycles random "
             f"walk, {args.samples} samples ({info['cycles_seconds'] or 'cached'} s). Blender {info['blender']}.", "",
             "| method | 4x4-block rel. RMSE | high-pass correlation | mean R, G, B / Cycles | F12 s | bake s |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['block_rel_rmse']:.3f} | {r['high_pass_correlation']:.3f} | "
                     f"{', '.join(f'{x:.3f}' for x in r['mean_rgb'])} | {r['seconds']:.2f} | {r['bake_seconds']:.1f} |")
    lines += ["", "Two material slots on one sphere (left half A = (0.85, 0.45, 0.3), right half B = (0.3, 0.6, "
              "0.85), the same radius), each half away from the seam over the sphere with that material alone, R, G, "
              "B:", "",
              "| method | half A | half B |", "|---|---|---|"]
    lines += [f"| {r['method']} | {', '.join(f'{x:.3f}' for x in r['A'])} | {', '.join(f'{x:.3f}' for x in r['B'])} |"
              for r in slot_rows]
    lines += ["", "Demo scene (the back-lit bunny, 480 x 270, F12, median of 5), with the surface layer and with it "
              "skipped (the frame before it existed):", ""]
    lines += [f"- {m}: {cost[(m, 'with the surface layer')]:.3f} s with, {cost[(m, 'without it')]:.3f} s without: "
              f"{r:.2f}x" for m, r in ratios.items()]
    lines += ["",
              "![Cycles, IMAGE_SPACE, TEXTURE_SPACE, QUADGRAPH](spot_textured.png)", ""]
    (out / "summary.md").write_text("\n".join(lines))
    print("\n".join(lines))
    bpy.ops.preferences.addon_disable(module=package)
    return 0


if __name__ == "__main__":
    sys.exit(main())

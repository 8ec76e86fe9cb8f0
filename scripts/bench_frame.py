"""The frame budget: where a frame's time goes, `make bench-frame` and `make bench-gpu`.

Per scene and method, frames drawn after the key light moved (what an artist does between frames), in F12
and through the viewport's code path (``viewport_probe``): wall time, time inside GPU calls
(``gpu_split``: draws, dispatches, uploads, read-backs) and the rest, the CPU work per frame that no GPU
shortens (``extract``: reading the scene, the share of it). Medians of ``--frames`` frames.

The hook's own cost per GPU call is measured and taken out of the outside share.

``make bench-frame`` (64x64, the demo bunny, as issue 36 profiled it) adds: each further unchanged
translucent object (four full copies of the subject), a deforming subject (a shape key changing every
frame) and the object panel's redraw with a baked object selected. Writes bench/results/frame/.

``make bench-gpu`` draws each method on the demo and the bench scenes at 1920x1080 and prints frames per
second with the same split and the GPU's name, within ``--budget`` seconds (what does not fit is listed as
skipped). On llvmpipe (no GPU) it draws a quarter of each side, one frame per path (IMAGE_SPACE alone took
minutes a frame at 1920x1080 there), and its figures are labelled software rendering.
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import statistics
import sys
import time
import types
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402
import gpu_split  # noqa: E402
import viewport_probe  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
METHODS = ("OFF", "IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH")
BAKED = {"TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE"}
SUBJECT = {"bunny": "Bunny", "cow": "Cow", "spot": "Spot"}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gpu", action="store_true", help="1920x1080 on the demo and bench scenes, frames/s")
    parser.add_argument("--width", type=int)
    parser.add_argument("--height", type=int)
    parser.add_argument("--scenes", nargs="*")
    parser.add_argument("--methods", nargs="*", default=list(METHODS))
    parser.add_argument("--frames", type=int, default=3)
    parser.add_argument("--budget", type=float, default=300.0, help="seconds for --gpu (the rest is skipped)")
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "frame"))
    args = parser.parse_args()
    width = args.width or (1920 if args.gpu else 64)
    height = args.height or (1080 if args.gpu else 64)
    scenes = args.scenes or (["bunny_backlit", "figure_backlit", "skin_frontlit"] if args.gpu else ["bunny_backlit"])

    if not args.gpu:
        # llvmpipe draws on worker threads that compete with Python for this machine's cores and finish
        # asynchronously, inflating the outside share; one thread keeps its work inside the GPU calls. A
        # real driver ignores the variable.
        os.environ.setdefault("LP_NUM_THREADS", "0")
    package = blender_env.start()
    import importlib

    import bpy

    def mod(name):
        return importlib.import_module(f"{package}.translucent_addon.{name}")

    demo, runner, engine = mod("blender.demo"), mod("blender.compare_runner"), mod("blender.engine")
    probe = viewport_probe.engine_class(engine, mod("blender.extract"), mod("gpu.targets"))
    bpy.utils.register_class(probe)
    started = time.perf_counter()
    rows, skipped, extras = [], [], {}
    frames = args.frames
    slowest = 0.0  # seconds of the slowest method so far (--gpu's budget)

    def f12(scene):
        return runner.render_pixels(scene, width, height)[0]

    def measure(scene, key, path: str, updates=()) -> dict:
        """Median split of ``args.frames`` frames, the key light moved before each (``updates``: what else the
        viewport's depsgraph reports changed)."""
        samples = []
        for _ in range(frames):
            key.location.x += 0.002
            if path == "F12":
                split = gpu_split.split(lambda: f12(scene))
                wall = mod("blender.session").current().timings["frame"]
                extract = mod("blender.session").current().timings["extract"]
            else:
                moved = [viewport_probe.update_of(key, geometry=False, transform=True), *updates]
                split = gpu_split.split(lambda: viewport_probe.frame(scene, f12, moved))
                wall = viewport_probe.PROBE["seconds"]
                extract = mod("blender.session").current().timings["extract"]
            # GPU calls happen only inside the engine's frame; what Blender does around it is not ours.
            outside = max(wall - split["gpu_calls"] - split.get("hook", 0.0), 0.0)
            samples.append({"wall": wall, "gpu_calls": split["gpu_calls"], "outside": outside, "extract": extract})
        return {k: statistics.median(s[k] for s in samples) for k in samples[0]}

    bpy.ops.wm.read_homefile(use_empty=True)
    runner.render_pixels(demo.build_scene(scenes[0], bpy.context.scene), 16, 16)  # a GPU context, to name it
    gpu_name = gpu_platform()
    if args.gpu and "llvmpipe" in gpu_name.lower() and not (args.width or args.height):
        # Software rendering: IMAGE_SPACE alone takes minutes a frame at 1920x1080 here. A quarter of each side
        # and one frame per path keep the run under 5 minutes; the figures are labelled, not a GPU's.
        width, height, frames = width // 4, height // 4, 1
    for name in scenes:
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = demo.build_scene(name, bpy.context.scene)
        spec = demo.SCENES[name]
        subject = scene.objects[SUBJECT[spec["mesh"]]]
        key = scene.objects["Key Light"]
        triangles = sum(len(p.vertices) - 2 for p in subject.data.polygons)
        for method in args.methods:
            # What did not fit: a method is started only when the slowest so far would still end in time.
            if args.gpu and time.perf_counter() - started + slowest > args.budget:
                skipped.append(f"{name} {method}")
                continue
            method_started = time.perf_counter()
            subject.translucent.method = method
            bake_seconds = 0.0
            if method in BAKED:
                bake_seconds, _ = runner.bake_objects([subject], method, progress=lambda *_: None)
            f12(scene)  # uploads, shader compilation
            viewport_probe.frame(scene, f12)
            for path in ("F12", "viewport"):
                m = measure(scene, key, path)
                rows.append({"scene": name, "triangles": triangles, "method": method, "path": path,
                             "bake_seconds": round(bake_seconds, 1),
                             **{k: round(v * 1000, 2) for k, v in m.items()}})
                print(_line(rows[-1]), flush=True)
            if not args.gpu and name == scenes[0] and method == "IMAGE_SPACE":
                extras.update(further_objects(scene, subject, key, measure))
                extras.update(deforming(scene, subject, key, measure))
            if not args.gpu and name == scenes[0] and method == "TEXTURE_SPACE":
                extras["sidebar_ms"] = round(1000 * sidebar(mod("blender.ui"), subject, scene), 3)
                print(f"object panel redraw, baked TEXTURE_SPACE object: {extras['sidebar_ms']} ms", flush=True)
            slowest = max(slowest, time.perf_counter() - method_started)

    software = gpu_name is not None and "llvmpipe" in gpu_name.lower()
    info = {"gpu": gpu_name, "software_rendering": software, "cpu": platform.processor() or platform.machine(),
            "blender": bpy.app.version_string, "size": [width, height], "frames": frames,
            "seconds": round(time.perf_counter() - started, 1), "skipped": skipped, "budget": args.budget}
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    stem = "gpu" if args.gpu else "split"
    (out / f"{stem}.json").write_text(json.dumps({"machine": info, "rows": rows, "extras": extras}, indent=1))
    text = summary(rows, extras, info, args.gpu)
    (out / f"{stem}.md").write_text(text)
    print(text)
    # GPU objects freed while Blender still runs: left to the interpreter's exit they crashed it (SIGSEGV).
    viewport_probe.PROBE.clear()
    bpy.utils.unregister_class(probe)
    bpy.ops.preferences.addon_disable(module=package)  # the extension's own unregister frees its caches
    gc.collect()
    return 0


def gpu_platform() -> str:
    import gpu

    try:
        return f"{gpu.platform.renderer_get()} ({gpu.platform.vendor_get()}, {gpu.platform.version_get()})"
    except Exception as err:  # noqa: BLE001 - the name is a label; the bench goes on without it
        return f"unknown ({err})"


def further_objects(scene, subject, key, measure, count: int = 4) -> dict:
    """What each further unchanged translucent object adds: ``count`` full copies (own meshes, read
    separately) beside the subject, F12 and viewport."""
    before = {p: measure(scene, key, p)["outside"] for p in ("F12", "viewport")}
    copies = []
    for k in range(count):
        ob = subject.copy()
        ob.data = subject.data.copy()
        ob.location.x += (k + 1) * 0.2
        scene.collection.objects.link(ob)
        copies.append(ob)
    out = {}
    for p in ("F12", "viewport"):
        measure(scene, key, p)  # first frame of the copies: read and uploaded
        after = measure(scene, key, p)["outside"]
        out[f"per_further_object_ms_{p}"] = round(1000 * (after - before[p]) / count, 2)
        print(f"{p}: each further unchanged object adds {out[f'per_further_object_ms_{p}']} ms", flush=True)
    import bpy

    for ob in copies:
        mesh = ob.data
        bpy.data.objects.remove(ob)
        bpy.data.meshes.remove(mesh)
    return out


def deforming(scene, subject, key, measure) -> dict:
    """A subject whose shape key changes every frame: its positions and normals are new each time."""
    import bpy

    subject.shape_key_add(name="Basis")
    shape = subject.shape_key_add(name="Breathe")
    for p in shape.data:
        p.co *= 1.05
    static = {p: measure(scene, key, p)["outside"] for p in ("F12", "viewport")}
    out = {}
    for p in ("F12", "viewport"):
        samples = []
        for k in range(3):
            shape.value = 0.2 + 0.2 * k
            bpy.context.view_layer.update()
            updates = [viewport_probe.update_of(subject)] if p == "viewport" else []
            samples.append(measure(scene, key, p, updates)["outside"])
        out[f"deforming_ms_{p}"] = round(1000 * statistics.median(samples), 2)
        out[f"static_ms_{p}"] = round(1000 * static[p], 2)
        print(f"{p}: deforming subject {out[f'deforming_ms_{p}']} ms outside GPU calls "
              f"(static {out[f'static_ms_{p}']} ms)", flush=True)
    subject.shape_key_clear()
    return out


def sidebar(ui, ob, scene, repeats: int = 50) -> float:
    """Seconds per redraw of the object panel (the 3D view's sidebar) with ``ob`` selected: its ``draw`` with a
    layout that accepts everything and draws nothing (headless there is no region)."""
    import bpy

    class Sink:
        def __getattr__(self, name):
            return self

        def __call__(self, *args, **kwargs):
            return self

        def __setattr__(self, name, value):
            pass

    bpy.context.view_layer.objects.active = ob
    context = types.SimpleNamespace(active_object=ob, object=ob, scene=scene,
                                    evaluated_depsgraph_get=bpy.context.evaluated_depsgraph_get)
    panel = types.SimpleNamespace(layout=Sink())
    draw = ui.VIEW3D_PT_translucent_object.draw
    draw(panel, context)
    t0 = time.perf_counter()
    for _ in range(repeats):
        draw(panel, context)
    return (time.perf_counter() - t0) / repeats


def _line(r: dict) -> str:
    fps = 1000.0 / r["wall"] if r["wall"] else float("inf")
    return (f"{r['scene']:15s} {r['method']:13s} {r['path']:8s} {r['wall']:9.1f} ms ({fps:6.2f} fps)  "
            f"GPU calls {r['gpu_calls']:9.1f}  outside {r['outside']:6.1f} (scene read {r['extract']:5.2f}) ms")


def summary(rows, extras, info, gpu: bool) -> str:
    label = " - software rendering (llvmpipe), not a GPU" if info["software_rendering"] else ""
    lines = [f"# Frame budget at {info['size'][0]}x{info['size'][1]}: {info['gpu']}{label}", "",
             f"Blender {info['blender']}, {info['size'][0]}x{info['size'][1]}, median of {info['frames']} frames "
             f"after the key light moved; whole run {info['seconds']} s.", "",
             "| scene | triangles | method | path | frame ms | frames/s | in GPU calls ms | outside ms | "
             "scene read ms |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        fps = 1000.0 / r["wall"] if r["wall"] else 0.0
        lines.append(f"| {r['scene']} | {r['triangles']:,} | {r['method']} | {r['path']} | {r['wall']:.1f} | "
                     f"{fps:.2f} | {r['gpu_calls']:.1f} | {r['outside']:.1f} | {r['extract']:.2f} |")
    if extras:
        lines += ["", "| further figure | ms |", "|---|---|"]
        lines += [f"| {k} | {v} |" for k, v in extras.items()]
    if info["skipped"]:
        lines += ["", f"Skipped (over the {info['budget']:.0f} s budget): " + ", ".join(info["skipped"])]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())

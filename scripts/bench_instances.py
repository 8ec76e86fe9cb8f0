"""Scenes of many (issue 57): frame time and Blender's peak memory with 1, 10 and 100 linked duplicates of a baked
object per method, and 1,000 geometry-nodes instances of a small one; `make bench-instances`.

Duplicates: the issue's subject, a 20,480-triangle ico sphere of 3 cm marble under a point light, F12 at 128x128,
and its Alt+D duplicates on a grid beside it. Instances: a 1,280-triangle grape of 1.5 cm scattered by geometry
nodes (Instance on Points of an Object Info, *As Instance* off: geometry instances, Blender's default there) on
1,000 points, at 256x256. Each method is baked once into a .blend; each count is measured in a fresh process that
opens it (Blender's peak resident memory, VmHWM, is the process's: a count measured after another would carry the
other's peak). The time is F12's second frame (the first uploads the bake and starts cold).

llvmpipe runs on one thread here (``LP_NUM_THREADS=0``, as ``bench_frame`` runs it): on its worker threads it held
about 40 MB more per TEXTURE_SPACE instance drawn, its own queue, which a GPU driver does not have and which hid ours.
Writes bench/results/instances/: summary.md, results.json.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "tests"))  # blender_helpers: the scene builders the tests use

METHODS = ("OFF", "IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE")
BAKED = ("TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE")
DUPLICATES = (1, 10, 100)
INSTANCES = 1000
MEMORY_PER_DUPLICATE_MB = 10.0  # the allowance per duplicate, over 1.5x one object's peak
TIME_FACTOR = 10.0  # and 100 duplicates' frame at most this many times one object's


def _start():
    import importlib

    import blender_env

    package = blender_env.start()
    import bpy

    return bpy, (lambda name: importlib.import_module(f"{package}.translucent_addon.{name}"))


def build(kind: str, method: str, path: Path) -> None:
    """The scene of ``kind`` ('duplicates' or 'instances') with ``method``, baked, saved to ``path``."""
    bpy, mod = _start()
    runner = mod("blender.compare_runner")
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "TRANSLUCENT_RT"
    mod("blender.demo").uniform_world(scene, (0.03, 0.03, 0.04))
    subject = kind == "duplicates"
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=5 if subject else 3, radius=0.015 if subject else 0.0075)
    ob = bpy.context.object
    ob.name = "Subject"
    ob.translucent.method = method
    if method != "OFF":
        ob.translucent.preset = "marble"
    if method == "TEXTURE_SPACE" and not subject:
        ob.translucent.atlas_resolution = 128
    if method in BAKED:
        runner.bake_objects([ob], method, lambda text: print(text, flush=True))
    bpy.ops.object.light_add(type="POINT", location=(0.15, -0.25, 0.2))
    bpy.context.object.data.energy = 8.0 if subject else 30.0
    location = (0.0, -0.55, 0.12) if subject else (0.0, -0.75, 0.55)
    bpy.ops.object.camera_add(location=location)
    camera = bpy.context.object
    target = bpy.data.objects.new("Target", None)
    target.location = (0.0, 0.05, 0.0) if subject else (0.0, 0.0, 0.0)
    scene.collection.objects.link(target)
    camera.constraints.new("TRACK_TO").target = target
    scene.camera = camera
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


def _grid(count: int, spacing: float, columns: int):
    for k in range(count):
        yield ((k % columns) - (columns - 1) / 2) * spacing, (k // columns) * spacing, 0.0


def measure(kind: str, path: Path, count: int, size: int) -> dict:
    """Open ``path``, make ``count`` duplicates or instances of its subject, draw two F12 frames."""
    bpy, mod = _start()
    runner, extract = mod("blender.compare_runner"), mod("blender.extract")
    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    subject = bpy.data.objects["Subject"]
    method = subject.translucent.method
    if kind == "duplicates":
        positions = list(_grid(count, 0.035, 10))
        subject.location = positions[0]
        for p in positions[1:]:
            twin = subject.copy()
            twin.location = p
            scene.collection.objects.link(twin)
    else:
        from blender_helpers import scatter_on_points  # after _start(): it imports bpy

        points = [(x, y - 0.25, z) for x, y, z in _grid(count, 0.02, 40)]
        scatter_on_points(scene, points, subject)
        subject.hide_render = True
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, size, size))
    # The viewport's depsgraph (frame_inputs here) holds the render-hidden subject of the instances too.
    drawn = sum(m.method == method for m in frame.meshes) - (kind == "instances")
    first = runner.render_pixels(scene, size, size)[1]
    image, second = runner.render_pixels(scene, size, size)
    session = mod("blender.session").current()
    held = mod("gpu.resources").current()
    status = {}
    for line in open("/proc/self/status"):
        key, _, value = line.partition(":")
        if key in ("VmHWM", "VmRSS"):
            status[key] = int(value.split()[0]) / 1024.0
    return {"kind": kind, "method": method, "count": count, "size": size, "drawn_with_method": drawn,
            "first_s": round(first, 3), "second_s": round(second, 3), "peak_mb": round(status["VmHWM"], 1),
            "resident_mb": round(status["VmRSS"], 1), "bake_entries": len(held.bakes),
            "mean": round(float(image[..., :3].mean()), 6),
            "lost": [w for w in session.warnings if "base colour" in w or "without subsurface" in w]}


def _child(args: list[str]) -> dict:
    env = dict(os.environ, LP_NUM_THREADS="0")
    out = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, env=env, check=False)
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT "):])
    raise RuntimeError(f"{args}: no result\n{out.stdout[-2000:]}\n{out.stderr[-2000:]}")


def summary(rows: list[dict], seconds: float) -> str:
    lines = ["# Scenes of many: duplicates and instances (issue 57)", "",
             f"`make bench-instances`, {time.strftime('%Y-%m-%d')}, llvmpipe on one thread (LP_NUM_THREADS=0), "
             f"{seconds / 60:.0f} min. Peak: Blender's resident memory high-water mark (VmHWM) in a fresh process "
             "that opens the baked .blend and draws two F12 frames; time: the second frame.", "",
             "## Linked duplicates of a baked 20,480-triangle ball (3 cm marble), 128x128", "",
             "| method | duplicates | frame s | x one | peak MB | MB per further duplicate | GPU bake entries |"
             " drawn with the method |", "|---|---|---|---|---|---|---|---|"]
    verdicts = []
    for method in METHODS:
        mine = sorted((r for r in rows if r["kind"] == "duplicates" and r["method"] == method),
                      key=lambda r: r["count"])
        if not mine:
            continue
        one = mine[0]
        for r in mine:
            per = (r["peak_mb"] - one["peak_mb"]) / (r["count"] - 1) if r["count"] > 1 else 0.0
            lines.append(f"| {method} | {r['count']} | {r['second_s']:.2f} | {r['second_s'] / one['second_s']:.1f} | "
                         f"{r['peak_mb']:.0f} | {per:.1f} | {r['bake_entries']} | {r['drawn_with_method']} |")
        last = mine[-1]
        if method in BAKED and last["count"] == 100:
            limit = 1.5 * one["peak_mb"] + MEMORY_PER_DUPLICATE_MB * (last["count"] - 1)
            ratio = last["second_s"] / one["second_s"]
            verdicts.append(f"- {method}, 100 duplicates: peak {last['peak_mb']:.0f} MB against at most "
                            f"{limit:.0f} MB ({'met' if last['peak_mb'] <= limit else 'NOT met'}); frame "
                            f"{ratio:.1f}x one object's against at most {TIME_FACTOR:g}x "
                            f"({'met' if ratio <= TIME_FACTOR else 'NOT met'})")
    off = {r["count"]: r["second_s"] for r in rows if r["kind"] == "duplicates" and r["method"] == "OFF"}
    if 1 in off and 100 in off:
        verdicts.append(f"- for scale: OFF (the base pass alone, 100 times the triangles) took "
                        f"{off[100] / off[1]:.1f}x one object's frame at 100 duplicates on this software rasterizer")
    counts = "/".join(f"{c:,}" for c in sorted({r["count"] for r in rows if r["kind"] == "instances"}) or [INSTANCES])
    lines += ["", "Acceptance (issue 57):", "", *verdicts, "",
              f"## {counts} geometry-nodes instances of a 1,280-triangle grape (1.5 cm marble), 256x256", "",
              "| method | instances | drawn with the method | frame s | peak MB | objects left opaque |",
              "|---|---|---|---|---|---|"]
    for r in sorted((r for r in rows if r["kind"] == "instances"), key=lambda r: METHODS.index(r["method"])):
        lines.append(f"| {r['method']} | {r['count']} | {r['drawn_with_method']} | {r['second_s']:.2f} | "
                     f"{r['peak_mb']:.0f} | {len(r['lost'])} |")
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="*", default=list(METHODS))
    parser.add_argument("--counts", nargs="*", type=int, default=list(DUPLICATES))
    parser.add_argument("--instances", type=int, default=INSTANCES)
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "instances"))
    parser.add_argument("--report-only", action="store_true", help="summary.md again from results.json")
    parser.add_argument("--build", nargs=3, metavar=("KIND", "METHOD", "PATH"), help=argparse.SUPPRESS)
    parser.add_argument("--measure", nargs=4, metavar=("KIND", "PATH", "COUNT", "SIZE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.build:
        build(args.build[0], args.build[1], Path(args.build[2]))
        print("RESULT {}")
        return 0
    if args.measure:
        kind, path, count, size = args.measure
        print("RESULT " + json.dumps(measure(kind, Path(path), int(count), int(size))), flush=True)
        return 0
    out = Path(args.output)
    if args.report_only:
        rows = json.loads((out / "results.json").read_text())
        (out / "summary.md").write_text(summary(rows, float(rows[0].get("run_s", 0.0)) if rows else 0.0))
        print((out / "summary.md").read_text())
        return 0
    started = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="translucent-instances-") as folder:
        for method in args.methods:
            for kind, counts, size in (("duplicates", args.counts, 128), ("instances", [args.instances], 256)):
                if not counts or counts == [0]:
                    continue
                path = Path(folder) / f"{kind}_{method}.blend"
                _child(["--build", kind, method, str(path)])
                for count in counts:
                    row = _child(["--measure", kind, str(path), str(count), str(size)])
                    rows.append(row)
                    print(f"{kind} {method} x{count}: {row['second_s']:.2f} s, peak {row['peak_mb']:.0f} MB, "
                          f"{row['drawn_with_method']} drawn with the method, lost {len(row['lost'])}", flush=True)
    out.mkdir(parents=True, exist_ok=True)
    for row in rows:
        row["run_s"] = round(time.perf_counter() - started)
    (out / "results.json").write_text(json.dumps(rows, indent=1) + "\n")
    (out / "summary.md").write_text(summary(rows, time.perf_counter() - started))
    print((out / "summary.md").read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())

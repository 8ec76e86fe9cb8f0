"""`make bench`: every scene of the set, every series, in one run on this machine.

For each scene of translucent_addon/demo.py SCENES: translucent.compare_cycles' runner (our engine
at several shadow resolutions, Cycles random walk and brute force at several sample counts, EEVEE
at several sample counts, the CPU dipole model) against a cached Cycles random-walk reference.
Writes bench/results/<scene>/ (report.json, chart.png, images), bench/results/summary.md (the
table) and bench/results/machine.json.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", default=str(ROOT / "bench" / "results"))
    parser.add_argument("--cache", default=str(ROOT / "bench" / "cache"))
    parser.add_argument("--width", type=int, default=192)
    parser.add_argument("--height", type=int, default=144)
    parser.add_argument("--scenes", nargs="*", default=None)
    parser.add_argument("--quick", action="store_true", help="few samples: checks the pipeline, not the numbers")
    parser.add_argument("--discretisation-size", type=int, default=512,
                        help="square size of the IMAGE_SPACE-against-dipole-model phase (0: skip)")
    parser.add_argument("--discretisation-scenes", nargs="*", default=["bunny_backlit", "bunny_frontlit", "cow_backlit"],
                        help="scenes of that phase (the acceptance set of the IMAGE_SPACE issue)")
    args = parser.parse_args()

    package = blender_env.start()
    import importlib

    import bpy

    demo = importlib.import_module(f"{package}.translucent_addon.demo")
    runner = importlib.import_module(f"{package}.translucent_addon.compare.runner")
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    rows, disc_rows = [], []
    t_start = time.perf_counter()
    for name in args.scenes or list(demo.SCENES):
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = demo.build_scene(name, bpy.context.scene)
        scene.render.resolution_x, scene.render.resolution_y = args.width, args.height
        settings = runner.CompareSettings.quick() if args.quick else runner.CompareSettings()
        settings.cache_dir = args.cache
        print(f"== {name}", flush=True)
        subject = bpy.data.objects[demo.SCENES[name]["mesh"].capitalize()]
        entries, meta = runner.run(scene, out / name, settings, objects=[subject],
                                   progress=lambda text, n=name: print(f"[{n}] {text}", flush=True))
        for e in entries:
            rows.append((name, e))
        if args.discretisation_size and not args.quick and name in args.discretisation_scenes:
            scene.render.resolution_x = scene.render.resolution_y = args.discretisation_size
            disc = runner.discretisation(scene, [subject], out / name / "discretisation", cache_dir=args.cache,
                                         progress=lambda text, n=name: print(f"[{n}] {text}", flush=True))
            disc_rows.extend((name, r) for r in disc)
    machine = {**runner.machine_description(), "blender": bpy.app.version_string,
               "gpu_for_our_engine": "see report: Mesa llvmpipe (software OpenGL) unless a GPU is present",
               "total_seconds": round(time.perf_counter() - t_start, 1), "size": [args.width, args.height]}
    (out / "machine.json").write_text(json.dumps(machine, indent=2))
    (out / "summary.md").write_text(summary_table(rows, machine) + discretisation_table(disc_rows, args))
    print(f"wrote {out / 'summary.md'}")
    return 0


def summary_table(rows, machine) -> str:
    lines = [
        "# Benchmark: speed against accuracy",
        "",
        f"Machine: {machine['cpu']}, {machine['cores']} cores; Blender {machine['blender']}; "
        f"{machine['size'][0]}x{machine['size'][1]} px; whole run {machine['total_seconds']} s. All renders of a scene in "
        "one run on this machine: compare times as ratios, not as absolute frame rates.",
        "",
        "Error: relative RMSE (and SSIM, and the firefly-robust median relative error) of linear radiance over the "
        "translucent object's pixels (silhouette pixels excluded), against the Cycles random-walk reference of the "
        "same scene; for our engine also against the CPU dipole model (its discretisation error); and the median "
        "relative error against the Cycles brute force (volume in a dielectric boundary), whose fireflies under small "
        "lights make its RMSE meaningless.",
        "",
        "| scene | series | setting | seconds | rel. RMSE | SSIM | median rel. error | rel. RMSE vs dipole model "
        "| median rel. error vs brute force |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, e in rows:
        fmt = lambda x: "-" if x is None else f"{x:.3f}"  # noqa: E731
        lines.append(f"| {name} | {e.series} | {e.settings.get('label', '')} | {e.seconds:.2f} | {fmt(e.rel_rmse)} | "
                     f"{fmt(e.ssim)} | {fmt(e.median_rel_error)} | {fmt(e.rel_rmse_model)} | "
                     f"{fmt(e.median_vs_brute_force)} |")
    return "\n".join(lines) + "\n"


def discretisation_table(rows, args) -> str:
    if not rows:
        return ""
    size = args.discretisation_size
    lines = ["", f"## IMAGE_SPACE against the dipole model ({size}x{size})", "",
             "The GPU method's own discretisation error (the dipole model evaluated by quadrature on the CPU is the "
             "reference), against the splat overlap k (light-view sample spacing r_max / k). Target: at most 5 % at "
             "the default k = 32.", "",
             "| scene | k | light-view texels | samples on the object | seconds | rel. RMSE vs dipole model |",
             "|---|---:|---:|---:|---:|---:|"]
    for name, r in rows:
        lines.append(f"| {name} | {r['overlap']:g} | {r['light_view_texels']} | {r['object_samples']} | "
                     f"{r['seconds']:.2f} | {r['rel_rmse_vs_model']:.4f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())

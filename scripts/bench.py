"""`make bench`: every scene of the set, every series, in one run on this machine.

For each scene of translucent_addon/demo.py SCENES: translucent.compare_cycles' runner (IMAGE_SPACE at
four splat overlaps, TEXTURE_SPACE at three atlas and proxy settings, QUADGRAPH at K = 2, 1 and 0.5, Quality
= Auto at a 5 % target for IMAGE_SPACE and TEXTURE_SPACE, Cycles random walk and brute force at several
sample counts, EEVEE at several sample counts, the CPU dipole model) against a cached Cycles random-walk
reference.
Writes bench/results/<scene>/ (report.json, chart.png, images), bench/results/summary.md (the
table), bench/results/pareto.png (every scene's speed against accuracy, with its Pareto front) and
bench/results/machine.json. ``--charts-only`` draws the charts again from the report.json files.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_series  # noqa: E402
import blender_env  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _atlas_setting(text: str):
    """'512' or '512:2.4' (atlas texels, proxy spacing in texels)."""
    res, _, spacing = str(text).partition(":")
    return (int(res), float(spacing)) if spacing else int(res)


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
    parser.add_argument("--discretisation-scenes", nargs="*",
                        default=["bunny_backlit", "bunny_frontlit", "cow_backlit"],
                        help="scenes of that phase (the acceptance set of the IMAGE_SPACE issue)")
    parser.add_argument("--texture-space-atlas", nargs="*", type=_atlas_setting,
                        default=[256, 512, (512, 2.4)],
                        help="TEXTURE_SPACE settings of the discretisation phase: atlas texels, or "
                             "texels:proxy spacing (the High quality tier is 512:2.4)")
    parser.add_argument("--bake-curve", nargs="*", type=int, default=[128, 192, 256, 384, 512],
                        help="atlas resolutions of the TEXTURE_SPACE bake-time curve (bunny; none: skip)")
    parser.add_argument("--no-blending", action="store_true", help="skip the TEXTURE_SPACE checkerboard phase")
    parser.add_argument("--only-texture-space", action="store_true",
                        help="run only the TEXTURE_SPACE phases (bake curve, blending, discretisation)")
    parser.add_argument("--charts-only", action="store_true",
                        help="render nothing: draw every scene's chart.png and pareto.png again from report.json")
    args = parser.parse_args()
    if args.charts_only:
        return draw_charts(Path(args.output))

    package = blender_env.start()
    import importlib

    import bpy

    demo = importlib.import_module(f"{package}.translucent_addon.blender.demo")
    runner = importlib.import_module(f"{package}.translucent_addon.blender.compare_runner")
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    rows, disc_rows, ts_rows = [], [], []
    t_start = time.perf_counter()
    ts_out = out / "texture_space"
    if args.bake_curve and not args.quick:
        bake_curve(demo, runner, bpy, args.bake_curve, ts_out)
    if not args.quick and not args.no_blending:
        blending_phase(demo, runner, bpy, ts_out, args.cache)
    for name in [] if args.only_texture_space else (args.scenes or list(demo.SCENES)):
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = demo.build_scene(name, bpy.context.scene)
        scene.render.resolution_x, scene.render.resolution_y = args.width, args.height
        settings = runner.CompareSettings.quick_settings() if args.quick else runner.CompareSettings(
            series={"IMAGE_SPACE": (8.0, 16.0, 32.0, 48.0), "TEXTURE_SPACE": (256, 512, (512, 2.4)),
                    "QUADGRAPH": (2.0, 1.0, 0.5)},
            auto_targets=(0.05,), auto_methods=("IMAGE_SPACE", "TEXTURE_SPACE"))
        settings.cache_dir = args.cache
        print(f"== {name}", flush=True)
        subject = bpy.data.objects[demo.SCENES[name]["mesh"].capitalize()]
        entries, meta = runner.run(scene, out / name, settings, objects=[subject],
                                   progress=lambda text, n=name: print(f"[{n}] {text}", flush=True))
        for e in entries:
            rows.append((name, e))
        if args.discretisation_size and not args.quick and name in args.discretisation_scenes:
            scene.render.resolution_x = scene.render.resolution_y = args.discretisation_size
            disc = bench_series.discretisation(runner, scene, [subject], out / name / "discretisation",
                                               cache_dir=args.cache,
                                         progress=lambda text, n=name: print(f"[{n}] {text}", flush=True))
            disc_rows.extend((name, r) for r in disc)
    for name in args.discretisation_scenes if args.discretisation_size and not args.quick else []:
        if name not in {"bunny_backlit", "cow_backlit"}:
            continue  # the acceptance set of the TEXTURE_SPACE issue
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = demo.build_scene(name, bpy.context.scene)
        scene.render.resolution_x = scene.render.resolution_y = args.discretisation_size
        subject = bpy.data.objects[demo.SCENES[name]["mesh"].capitalize()]
        ts = bench_series.texture_space_discretisation(runner, scene, [subject], ts_out / name,
                                                       args.texture_space_atlas,
                                                 cache_dir=args.cache,
                                                 progress=lambda text, n=name: print(f"[{n}] {text}", flush=True))
        ts_rows.extend((name, r) for r in ts)
    machine = {**runner.machine_description(), "blender": bpy.app.version_string,
               "gpu_for_our_engine": "see report: Mesa llvmpipe (software OpenGL) unless a GPU is present",
               "total_seconds": round(time.perf_counter() - t_start, 1), "size": [args.width, args.height]}
    if args.only_texture_space:
        (ts_out / "discretisation.json").write_text(json.dumps([{"scene": n, **r} for n, r in ts_rows], indent=2))
        print(texture_space_table(ts_rows, args))
        return 0
    (out / "machine.json").write_text(json.dumps(machine, indent=2))
    draw_charts(out)
    (out / "summary.md").write_text(summary_table(rows, machine) + discretisation_table(disc_rows, args)
                                    + texture_space_table(ts_rows, args) + texture_space_extras(ts_out))
    print(f"wrote {out / 'summary.md'}")
    return 0


def draw_charts(out: Path) -> int:
    """Each scene's chart.png and the summary pareto.png, from the scenes' report.json (pure: no Blender)."""
    sys.path.insert(0, str(ROOT))
    from translucent_addon.core.report import report

    scenes, size = {}, None
    for path in sorted(out.glob("*/report.json")):
        entries, meta = report.read_report(path)
        scenes[path.parent.name] = entries
        size = meta["size"]
        report.speed_accuracy_chart(entries, path.parent / "chart.png",
                                    f"{path.parent.name}: speed against accuracy ({size[0]}x{size[1]}); "
                                    f"reference {meta['reference']}")
    if not scenes:
        print(f"no report.json under {out}: run the bench first", file=sys.stderr)
        return 1
    machine = json.loads((out / "machine.json").read_text()) if (out / "machine.json").exists() else {}
    others, metrics, titles = other_scenes(out, report)
    report.pareto_summary_chart({**scenes, **others}, out / "pareto.png",
                                f"Median relative error against Cycles random walk 1024 spp, {size[0]}x{size[1]} "
                                f"(glass and caustics: their benchmarks' references); "
                                f"{machine.get('cpu', 'this machine')}, one make bench (Mesa llvmpipe for our engine "
                                f"and EEVEE)", panel_metrics=metrics, panel_titles=titles)
    print(f"wrote {out / 'pareto.png'} and {len(scenes)} scene charts")
    return 0


def other_scenes(out: Path, report) -> tuple[dict, dict, dict]:
    """The glass bunny (bench_geocube.py) and the caustic ball (bench_caustics.py) as report entries, for
    the summary chart: (entries per scene, the metric of each, the title of each)."""
    scenes, metrics, titles = {}, {}, {}
    geocube = out / "geocube" / "results.json"
    if geocube.exists():
        series = {"GEOCUBE": ("Translucent (GEOCUBE)", "TRANSLUCENT_RT"), "EEVEE": ("EEVEE", "BLENDER_EEVEE"),
                  "Cycles": ("Cycles path tracing", "CYCLES")}
        rows = [r for r in json.loads(geocube.read_text())["images"]
                if r["case"] == "bunny_glass" and "reference" not in r["label"]]
        scenes["bunny_glass"] = [report.Entry(series=series[fam][0], engine=series[fam][1],
                                              settings={"label": r["label"]}, seconds=r["seconds"],
                                              reference="Cycles 256", rel_rmse=r["rel_rmse"],
                                              median_rel_error=r["median"])
                                 for r in rows if (fam := r["label"].split()[0]) in series]
        titles["bunny_glass"] = "bunny_glass (bench_geocube; median against Cycles 256 spp)"
    caustics = out / "caustics" / "results.json"
    if caustics.exists():
        entries = []
        for r in json.loads(caustics.read_text())["ball"]:
            if r["label"].startswith("ours") and "fixed" not in r["label"]:
                name, engine = f"Translucent (caustics, grid {r['grid']})", "TRANSLUCENT_RT"
            elif r["label"].startswith("Cycles MNEE"):
                name, engine = "Cycles MNEE", "CYCLES"
            elif r["label"].startswith("EEVEE"):
                name, engine = "EEVEE", "BLENDER_EEVEE"
            else:
                continue
            entries.append(report.Entry(series=name, engine=engine, settings={"label": r["label"]},
                                        seconds=r["seconds"], reference="exact trace", rel_rmse=r["rel_rmse"]))
        scenes["caustic_ball"], metrics["caustic_ball"] = entries, "rel_rmse"
        titles["caustic_ball"] = "caustic_ball (bench_caustics; relative RMSE against an exact photon trace)"
    return scenes, metrics, titles


def summary_table(rows, machine) -> str:
    lines = [
        "# Benchmark: speed against accuracy",
        "",
        f"Machine: {machine['cpu']}, {machine['cores']} cores; Blender {machine['blender']}; "
        f"{machine['size'][0]}x{machine['size'][1]} px; whole run {machine['total_seconds']} s. "
        "All renders of a scene in "
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


def texture_space_table(rows, args) -> str:
    if not rows:
        return ""
    size = args.discretisation_size
    lines = ["", f"## TEXTURE_SPACE against the dipole model ({size}x{size})", "",
             "Lensch's method at several atlas resolutions and proxy spacings (mean proxy edge in atlas texels; "
             "3.5 is the default, 2.4 the High quality tier). Target: at most 5 %.", "",
             "| scene | atlas | spacing | proxy vertices | texel (mm) | form factors | bake s | frame s "
             "| rel. RMSE vs dipole model | mean ratio (RGB) |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for name, r in rows:
        lines.append(f"| {name} | {r['atlas']} | {r.get('proxy_spacing', 3.5):g} | {r['proxy_vertices']} | "
                     f"{r['texel_mm']:.3f} | {r['form_factors']:,} | "
                     f"{r['bake_seconds']:.1f} | {r['seconds']:.2f} | {r['rel_rmse_vs_model']:.4f} | "
                     f"{', '.join(f'{x:.3f}' for x in r['mean_ratio_rgb'])} |")
    return "\n".join(lines) + "\n"


def texture_space_extras(ts_out: Path) -> str:
    """The bake-time curve and the blending (Fig. 6) numbers, as written by their phases."""
    lines = []
    curve = ts_out / "bake_time.json"
    if curve.exists():
        data = json.loads(curve.read_text())
        lines += ["", "## TEXTURE_SPACE bake time against proxy size (bunny, marble)", "",
                  "Target: a 10k-vertex proxy in at most 60 s on this machine. Chart: texture_space/bake_time.png.", "",
                  "| atlas | proxy vertices | form factors | seconds |", "|---:|---:|---:|---:|"]
        lines += [f"| {r['atlas']} | {r['proxy_vertices']} | {r['form_factors']:,} | {r['seconds']:.1f} |"
                  for r in data["rows"]]
    blend = ts_out / "blending.json"
    if blend.exists():
        data = json.loads(blend.read_text())
        lines += ["", "## TEXTURE_SPACE blending (Lensch Sec. 5.4, Fig. 6): a checkerboard of light", "",
                  f"{data['description']} Image: texture_space/checker_blending.png (off, on, dipole model).", "",
                  "| blending | rel. RMSE vs dipole model | mean ratio (RGB) |", "|---|---:|---|"]
        lines += [f"| {'on' if r['blending'] else 'off'} | {r['rel_rmse_vs_model']:.4f} | "
                  f"{', '.join(f'{x:.3f}' for x in r['mean_ratio_rgb'])} |" for r in data["rows"]]
    return "\n".join(lines) + ("\n" if lines else "")


def bake_curve(demo, runner, bpy, resolutions, out: Path) -> None:
    """Bake the back-lit bunny at several atlas resolutions: seconds against proxy vertices."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = []
    for res in resolutions:
        bpy.ops.wm.read_homefile(use_empty=True)
        demo.build_scene("bunny_backlit", bpy.context.scene)
        ob = bpy.data.objects["Bunny"]
        ob.translucent.method = "TEXTURE_SPACE"
        ob.translucent.atlas_resolution = res
        seconds, (meta,) = runner.bake_objects([ob], "TEXTURE_SPACE",
                                               progress=lambda t: print(f"[bake curve] {t}", flush=True))
        rows.append({"atlas": res, "proxy_vertices": meta["proxy_vertices"], "proxy_triangles": meta["proxy_triangles"],
                     "surface_texels": meta["surface_texels"], "form_factors": meta["form_factors"],
                     "seconds": round(seconds, 2), "bytes": meta["bytes"]})
    out.mkdir(parents=True, exist_ok=True)
    (out / "bake_time.json").write_text(json.dumps({"mesh": "bunny (69k triangles), marble, 15 cm", "rows": rows},
                                                   indent=2))
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot([r["proxy_vertices"] for r in rows], [r["seconds"] for r in rows], "o-")
    for r in rows:
        ax.annotate(f"{r['atlas']}", (r["proxy_vertices"], r["seconds"]), textcoords="offset points", xytext=(4, -10))
    ax.axhline(60, color="grey", ls="--", lw=1)
    ax.axvline(10_000, color="grey", ls=":", lw=1)
    ax.set_xlabel("proxy vertices (label: atlas texels per side)")
    ax.set_ylabel("bake seconds (2-core machine)")
    ax.set_title("TEXTURE_SPACE bake time, bunny")
    fig.tight_layout()
    fig.savefig(out / "bake_time.png", dpi=110)
    plt.close(fig)


def checker_occluder(bpy, scene, light, target, squares: int = 12, square_mm: float = 6.0):
    """A checkerboard of opaque squares across the light's beam, halfway to the target."""
    from mathutils import Vector

    pos, aim = Vector(light.location), Vector(target)
    mid = pos.lerp(aim, 0.5)
    axis = (aim - pos).normalized()
    u = axis.orthogonal().normalized()
    v = axis.cross(u)
    s = square_mm / 1000.0
    verts, faces = [], []
    for i in range(squares):
        for j in range(squares):
            if (i + j) % 2:
                continue
            o = mid + u * (i - squares / 2) * s + v * (j - squares / 2) * s
            k = len(verts)
            verts += [o, o + u * s, o + u * s + v * s, o + v * s]
            faces.append((k, k + 1, k + 2, k + 3))
    me = bpy.data.meshes.new("Checker")
    me.from_pydata([tuple(p) for p in verts], [], faces)
    ob = bpy.data.objects.new("Checker", me)
    scene.collection.objects.link(ob)
    return ob


def blending_phase(demo, runner, bpy, out: Path, cache, size: int = 256) -> None:
    """Lensch Fig. 6: a checkerboard of light on the bunny, blending off and on, against the dipole model."""
    import numpy as np
    from mathutils import Vector

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = demo.build_scene("bunny_frontlit", bpy.context.scene)
    ob = bpy.data.objects["Bunny"]
    key = bpy.data.objects["Key Light"]
    key.data.shadow_soft_size = 0.0
    checker_occluder(bpy, scene, key, Vector((0.0, 0.0, 0.06)))
    scene.render.resolution_x = scene.render.resolution_y = size
    rows = []
    out.mkdir(parents=True, exist_ok=True)
    for blend in (False, True):
        ob.translucent.texture_blending = blend
        got = bench_series.texture_space_discretisation(runner, scene, [ob], out / "blending", (512,), cache_dir=cache,
                                                  progress=lambda t: print(f"[blending] {t}", flush=True),
                                                  name=f"blending_{'on' if blend else 'off'}")
        rows.append({"blending": blend, **got[0]})
    ob.translucent.texture_blending = True
    description = ("The front-lit bunny with a checkerboard occluder halfway to the key light (6 mm squares, about "
                   "12 mm of light and shadow on the bunny), atlas 512, %dx%d px." % (size, size))
    (out / "blending.json").write_text(json.dumps({"description": description, "rows": rows}, indent=2))
    # Side by side: blending off, on, the dipole model (same exposure).
    import matplotlib.image as mpimg

    off = mpimg.imread(out / "blending" / "blending_off_512.png")
    on = mpimg.imread(out / "blending" / "blending_on_512.png")
    ref = sorted((out / "blending").glob("dipole_model*.png"))
    panels = [off, on] + ([mpimg.imread(ref[0])] if ref else [])
    mpimg.imsave(out / "checker_blending.png", np.concatenate([p[..., :3] for p in panels], axis=1))


if __name__ == "__main__":
    sys.exit(main())

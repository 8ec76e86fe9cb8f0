"""AUTO quality in the benchmark: does it land on each method's front at its target?

For the back-lit bunny and cow at 512x512 (the discretisation phase's scenes and size), in one run:
IMAGE_SPACE at k = 8, 16, 32, 48 and TEXTURE_SPACE at atlas 256, 512 and 512 with spacing 2.4 (the
measured sweep), then each with Quality = Auto at several target errors, every image against the CPU
dipole model (the methods' own model: AUTO's target is the discretisation error). A third case, the
bunny at 3 m (mm_per_unit x 20), shows the pixel cap: there the splats at k = 32 are far finer than a
pixel. Cost: seconds per frame for IMAGE_SPACE, seconds of bake for TEXTURE_SPACE (its frames differ little).

Writes bench/results/auto/ (results.json, summary.md, chart.png).
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
SIZE = 512
IMAGE_SPACE_K = (8.0, 16.0, 32.0, 48.0)
IMAGE_SPACE_TARGETS = (0.10, 0.05, 0.03)
TEXTURE_SPACE_SETTINGS = ((256, 3.5), (512, 3.5), (512, 2.4))
TEXTURE_SPACE_TARGETS = (0.10, 0.05)
CASES = (("bunny_backlit", 1.0), ("cow_backlit", 1.0), ("bunny_backlit", 20.0))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "auto"))
    parser.add_argument("--cache", default=str(ROOT / "bench" / "cache"))
    parser.add_argument("--charts-only", action="store_true")
    parser.add_argument("--cases", nargs="*", help="run only these cases (e.g. cow_backlit bunny_backlit_x20); "
                                                    "the other cases' rows are kept from results.json")
    args = parser.parse_args()
    out = Path(args.output)
    if args.charts_only:
        return draw(out, json.loads((out / "results.json").read_text()))
    package = blender_env.start()
    import importlib

    import bpy

    demo = importlib.import_module(f"{package}.translucent_addon.blender.demo")
    runner = importlib.import_module(f"{package}.translucent_addon.blender.compare_runner")
    session = importlib.import_module(f"{package}.translucent_addon.blender.session")
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    if args.cases and (out / "results.json").exists():
        rows = [r for r in json.loads((out / "results.json").read_text())["rows"] if r["case"] not in args.cases]
    t_start = time.perf_counter()
    for name, scale in CASES:
        case = name if scale == 1.0 else f"{name}_x{scale:g}"
        if args.cases and case not in args.cases:
            continue
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = demo.build_scene(name, bpy.context.scene)
        scene.render.resolution_x = scene.render.resolution_y = SIZE
        subject = bpy.data.objects[demo.SCENES[name]["mesh"].capitalize()]
        subject.translucent.mm_per_unit *= scale
        bpy.context.view_layer.objects.active = subject

        def say(text, c=case):
            print(f"[{c}] {text}", flush=True)

        width, height, mask, model, _ = runner._model_setup(scene, [subject], 200_000, args.cache, say)

        def measured(img):
            return runner.relative_rmse(img, model, mask)

        def image_space(label, kind, target=None):
            img, sec = runner.warm_render(scene, width, height)
            # Auto's k is the frame's (the engine chooses it per frame), the manual one the scene's.
            chosen = session.current().results["IMAGE_SPACE"]
            k = chosen["overlap"] if kind == "auto" else scene.translucent.splat_overlap
            rows.append({"case": case, "method": "IMAGE_SPACE", "kind": kind, "label": label, "target": target,
                         "k": k, "cost_seconds": sec, "frame_seconds": sec, "error": measured(img),
                         "summary": subject.translucent.auto_summary if kind == "auto" else ""})
            runner.save_image_png(out / f"{case}_image_space_{label.replace(' ', '_')}.png", img)
            say(f"IMAGE_SPACE {label}: k {k:g}, {sec:.2f} s, error {rows[-1]['error']:.4f}")

        subject.translucent.method = "IMAGE_SPACE"
        for k in IMAGE_SPACE_K if scale == 1.0 else (32.0,):
            scene.translucent.splat_overlap = k
            scene.translucent.splat_max_grid = 2048 if k > 32 else 1024
            image_space(f"k={k:g}", "manual")
        subject.translucent.quality = "AUTO"
        for target in IMAGE_SPACE_TARGETS:
            subject.translucent.target_error = target
            bpy.ops.translucent.auto_quality()
            image_space(f"auto {target:g}", "auto", target)
        if scale != 1.0:
            continue

        def texture_space(label, kind, target=None):
            s = subject.translucent
            seconds, (meta,) = runner.bake_objects([subject], "TEXTURE_SPACE", say)
            img, sec = runner.warm_render(scene, width, height)
            rows.append({"case": case, "method": "TEXTURE_SPACE", "kind": kind, "label": label, "target": target,
                         "atlas": s.atlas_resolution, "proxy_spacing": round(s.proxy_spacing, 2),
                         "proxy_vertices": meta.get("proxy_vertices"), "form_factors": meta.get("form_factors"),
                         "cost_seconds": seconds, "frame_seconds": sec, "error": measured(img),
                         "summary": s.auto_summary if kind == "auto" else ""})
            runner.save_image_png(out / f"{case}_texture_space_{label.replace(' ', '_').replace(':', '_')}.png", img)
            say(f"TEXTURE_SPACE {label}: atlas {s.atlas_resolution}, spacing {s.proxy_spacing:g}, bake "
                f"{seconds:.1f} s, error {rows[-1]['error']:.4f}")

        subject.translucent.quality = "MANUAL"
        subject.translucent.method = "TEXTURE_SPACE"
        for atlas, spacing in TEXTURE_SPACE_SETTINGS:
            subject.translucent.atlas_resolution, subject.translucent.proxy_spacing = atlas, spacing
            texture_space(f"{atlas}:{spacing:g}", "manual")
        subject.translucent.quality = "AUTO"
        for target in TEXTURE_SPACE_TARGETS:
            subject.translucent.target_error = target
            bpy.ops.translucent.auto_quality()
            texture_space(f"auto {target:g}", "auto", target)
    meta = {"size": [SIZE, SIZE], "blender": bpy.app.version_string, **runner.machine_description(),
            "total_seconds": round(time.perf_counter() - t_start, 1),
            "cases_run": args.cases or [c if s == 1.0 else f"{c}_x{s:g}" for c, s in CASES]}
    result = {"machine": meta, "rows": rows}
    (out / "results.json").write_text(json.dumps(result, indent=1))
    return draw(out, result)


def pareto(points):
    """Indices of the points no other point beats in both cost and error."""
    return [i for i, (c, e) in enumerate(points)
            if not any(c2 <= c and e2 <= e and (c2, e2) != (c, e) for c2, e2 in points)]


def draw(out: Path, result: dict) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result["rows"]
    panels = [(case, method) for case in dict.fromkeys(r["case"] for r in rows)
              for method in ("IMAGE_SPACE", "TEXTURE_SPACE") if any(r["case"] == case and r["method"] == method
                                                                   for r in rows)]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.8), squeeze=False)
    lines = [f"# AUTO quality against each method's measured settings ({result['machine']['size'][0]}x"
             f"{result['machine']['size'][1]}, against the CPU dipole model)", "",
             f"Machine: {result['machine'].get('cpu', '')}, Blender {result['machine']['blender']}; whole run "
             f"{result['machine']['total_seconds']} s. Cost: seconds per frame (IMAGE_SPACE), seconds of bake "
             "(TEXTURE_SPACE). On the front: no manual or Auto setting is both cheaper and more accurate.", "",
             "| case | method | setting | target | cost (s) | frame (s) | error | on the front | Auto's choice |",
             "|---|---|---|---:|---:|---:|---:|---|---|"]
    for ax, (case, method) in zip(axes[0], panels):
        sel = [r for r in rows if r["case"] == case and r["method"] == method]
        front = set(pareto([(r["cost_seconds"], r["error"]) for r in sel]))
        manual = [r for r in sel if r["kind"] == "manual"]
        ax.plot([r["cost_seconds"] for r in manual], [r["error"] for r in manual], "o-", color="0.4",
                label="measured settings")
        for r in manual:
            ax.annotate(r["label"], (r["cost_seconds"], r["error"]), fontsize=7, xytext=(4, 3),
                        textcoords="offset points")
        for r in (r for r in sel if r["kind"] == "auto"):
            ax.plot(r["cost_seconds"], r["error"], "*", ms=13, label=f"Auto, target {100 * r['target']:g} %")
            ax.axhline(r["target"], ls=":", lw=0.8, color=ax.lines[-1].get_color())
        costs = [r["cost_seconds"] for r in sel]
        if max(costs) > 3 * min(costs):  # a narrow range (the 3 m bunny: timing noise only) stays linear
            ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("seconds per frame" if method == "IMAGE_SPACE" else "seconds of bake")
        ax.set_ylabel("relative RMSE against the dipole model")
        ax.set_title(f"{case}: {method}", fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(True, which="both", lw=0.3)
        for i, r in enumerate(sel):
            target = "-" if r["target"] is None else f"{100 * r['target']:g} %"
            lines.append(f"| {case} | {method} | {r['label']} | {target} | {r['cost_seconds']:.2f} | "
                         f"{r['frame_seconds']:.2f} | {r['error']:.4f} | {'yes' if i in front else 'no'} | "
                         f"{r['summary']} |")
    fig.tight_layout()
    fig.savefig(out / "chart.png", dpi=110)
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {out / 'summary.md'} and {out / 'chart.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

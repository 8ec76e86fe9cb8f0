"""GEOCUBE phase of the benchmark (Chan & Wang 2005), in one run on this machine.

1. Exit points of the cone-propelled search (the NumPy twin, which the GPU pass matches in the tests)
   against exact ray casting, for rays entering the bunny and the cow (100 mm across) at refraction-like
   angles: median and 99th-percentile error in units of the object's size, the share of errors above 1 %
   and of premature exits, for cube resolutions 16, 32, 64 and step caps 4, 8, 16, 32; cubes placed and
   coverage.
2. Images against Cycles (glass boundary around a volume with the same sigma_a, sigma_s, g: the brute-force
   twin of the physics issue) for a sphere at three scattering levels (the paper's Fig. 15) and a glass
   bunny, in front of a procedural environment: GEOCUBE at three cube resolutions (16, 32, 64 texels a
   face), EEVEE with the same twin material (its screen-space refraction) at 4 and 16 samples, and Cycles at
   4, 16 and 64 samples, timed in the same run. Relative RMSE and median relative error over the object's
   pixels; the sphere's blur at the silhouette against the centre.
Writes bench/results/geocube/ (summary.md, results.json, chart.png, images).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SPHERE_LEVELS = {"clear": 0.0, "slight": 0.002, "milky": 0.008}  # sigma_s' (1/mm), g = 0.9: tau = 0, 2, 8 across
GLASS_SIGMA_A = (0.002, 0.004, 0.012)  # 1/mm: a green-blue tinted glass, darker where thicker
IMAGE_CASES = ("sphere_clear", "sphere_slight", "sphere_milky", "bunny_glass")


def environment_image(w=512, h=256) -> np.ndarray:
    """A procedural world: sky gradient, a ground with a checker, coloured stripes and two bright
    windows, so that refraction, blur and absorption all show. Row 0 at the bottom (Blender)."""
    u, v = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    lat = (v - 0.5) * np.pi
    sky = np.stack([0.35 + 0.3 * np.sin(lat), 0.5 + 0.3 * np.sin(lat), 0.8 + 0.2 * np.sin(lat)], -1)
    chk = ((np.floor(u * 32) + np.floor(v * 16)) % 2)[..., None]
    ground = 0.15 + 0.45 * chk * np.array([0.9, 0.7, 0.5])
    img = np.where((lat > 0)[..., None], sky, ground)
    stripes = (np.floor(u * 12) % 3)[..., None] == np.arange(3)
    band = (np.abs(lat) < 0.25)[..., None]
    img = np.where(band, 0.2 + 0.7 * stripes, img)
    for cu, cv in ((0.3, 0.62), (0.75, 0.7)):
        win = ((np.abs(u - cu) < 0.03) & (np.abs(v - cv) < 0.05))[..., None]
        img = np.where(win, 6.0, img)
    return img.astype(np.float32)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "geocube"))
    parser.add_argument("--cache", default=str(ROOT / "bench" / "cache"))
    parser.add_argument("--width", type=int, default=192)
    parser.add_argument("--height", type=int, default=144)
    parser.add_argument("--resolutions", nargs="*", type=int, default=[16, 32, 64])
    parser.add_argument("--caps", nargs="*", type=int, default=[4, 8, 16, 32])
    parser.add_argument("--reference-samples", type=int, default=256)
    parser.add_argument("--image-resolutions", nargs="*", type=int, default=[16, 32, 64],
                        help="GEOCUBE cube texels a face in the image phase")
    parser.add_argument("--eevee-samples", nargs="*", type=int, default=[4, 16])
    parser.add_argument("--cycles-samples", nargs="*", type=int, default=[4, 16, 64])
    parser.add_argument("--cases", nargs="*", default=list(IMAGE_CASES))
    parser.add_argument("--skip-exits", action="store_true")
    parser.add_argument("--exits-only", action="store_true")
    parser.add_argument("--meshes", nargs="*", default=["bunny", "cow"])
    args = parser.parse_args()

    package = blender_env.start()
    import importlib

    import bpy

    def mod(name):
        return importlib.import_module(f"{package}.translucent_addon.{name}")

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    previous = json.loads((out / "results.json").read_text()) if (out / "results.json").exists() else {}
    # a phase skipped keeps the last run's rows, so that the summary stays whole
    exits = previous.get("exits", []) if args.skip_exits else exit_accuracy(mod, args)
    images = previous.get("images", []) if args.exits_only else image_phase(bpy, mod, args, out)
    (out / "results.json").write_text(json.dumps({"exits": exits, "images": images}, indent=2, default=float))
    chart(images, exits, out)
    (out / "summary.md").write_text(summary(exits, images, args))
    print(f"wrote {out / 'summary.md'}")
    return 0


def exit_accuracy(mod, args) -> list[dict]:
    geocube = mod("techniques.geocube.bake")
    gd = mod("techniques.geocube.model")
    mesh_io = mod("core.geometry.mesh_io")
    rows = []
    for name in args.meshes:
        v, t = mesh_io.load_npz(ROOT / "translucent_addon" / "data" / "meshes" / f"{name}.npz")
        v = np.asarray(v, np.float64)
        v = (v - v.mean(axis=0)) * (100.0 / np.linalg.norm(v.max(0) - v.min(0)))
        t = np.asarray(t, np.int64)
        tracer = geocube.default_tracer(v[t], mod("blender.bvh_tracer").BVHTracer)
        pts, nrm, tri = geocube.area_samples(v, t, 5000, seed=5)
        rng = np.random.default_rng(0)
        d = -nrm + 0.6 * rng.normal(size=nrm.shape)  # spread like refracted rays (within ~40 degrees)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        keep = np.einsum("rd,rd->r", d, nrm) < -0.3
        pts, d, tri = pts[keep], d[keep], tri[keep]
        th, _, _, _ = tracer.closest_hit(pts + d * 1e-4, d)
        ok = np.isfinite(th)
        exact = pts + d * (th + 1e-4)[:, None]
        for res in args.resolutions:
            t0 = time.perf_counter()
            g = geocube.build(v, t, res, 1.5, tracer)
            bake = time.perf_counter() - t0
            at = gd.atlases(g)
            for cap in args.caps:
                ex = gd.exit_search(at, pts, d, g.start_cube[tri], cap, g.min_step)
                err = np.linalg.norm(ex.point - exact, axis=1)[ok] / g.size
                row = {"mesh": name, "triangles": int(len(t)), "res": res, "cap": cap, "cubes": g.count,
                       "coverage": g.coverage, "bake_seconds": round(bake, 1), "rays": int(ok.sum()),
                       "median": float(np.median(err)), "p99": float(np.percentile(err, 99)),
                       "above_1pct": float((err > 0.01).mean()), "premature": float(ex.premature[ok].mean()),
                       "mean_steps": float(ex.steps[ok].mean())}
                rows.append(row)
                print(f"[exits] {name} res {res} cap {cap}: median {row['median']:.1e}, p99 {row['p99']:.1e}, "
                      f">1% {row['above_1pct']:.3f}, premature {row['premature']:.3f} ({g.count} cubes, "
                      f"{bake:.0f} s bake)", flush=True)
    return rows


def build_scene(bpy, mod, case: str):
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    demo = mod("blender.demo")
    demo.environment_world(scene, environment_image(), "bench_environment")
    if case.startswith("sphere"):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=0.05)
        ob = bpy.context.active_object
        ob.name = "Sphere"
        sigma_s_prime = SPHERE_LEVELS[case.split("_")[1]]
        sigma_a = (0.0, 0.0, 0.0)
    else:
        mesh_io = mod("core.geometry.mesh_io")
        v, t = mesh_io.load_npz(ROOT / "translucent_addon" / "data" / "meshes" / "bunny.npz")
        v = np.asarray(v, np.float64)
        v = (v - 0.5 * (v.max(0) + v.min(0))) * (0.12 / np.linalg.norm(v.max(0) - v.min(0)))
        v = v[:, [0, 2, 1]] * np.array([1, -1, 1])  # the scan's y-up to Blender's z-up
        ob = bpy.data.objects.new("Bunny", demo.mesh_from_arrays("Bunny", v, t))
        scene.collection.objects.link(ob)
        bpy.context.view_layer.objects.active = ob
        ob.select_set(True)
        sigma_s_prime = 1e-6
        sigma_a = GLASS_SIGMA_A
    bpy.ops.object.shade_smooth()
    s = ob.translucent
    s.mm_per_unit = 1000.0
    s.method = "GEOCUBE"
    s.eta = 1.5
    s.g = 0.9
    s.sigma_a = sigma_a
    s.sigma_s_prime = (max(sigma_s_prime, 1e-6),) * 3
    s.geocube_resolution = 64
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 50
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (0.05, -0.32, 0.06)
    direction = -np.asarray(cam.location)
    from mathutils import Vector

    cam.rotation_euler = Vector(direction).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    return scene, ob


def image_phase(bpy, mod, args, out: Path) -> list[dict]:
    runner = mod("blender.compare_runner")
    cache = mod("core.reference.cache")
    metrics = mod("core.metrics")
    report = mod("core.report.report")
    extract = mod("blender.extract")
    bvh = mod("blender.bvh_tracer")
    w, h = args.width, args.height
    rows = []
    for case in args.cases:
        scene, ob = build_scene(bpy, mod, case)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, w, h))
        tracer = bvh.BVHTracer(runner.scene_triangles(frame)[0])
        mask = runner.interior(runner._mask(frame, tracer, {ob.name}))
        description = {**runner.scene_description(depsgraph, frame, [ob]), "case": case, "world": "bench_env_v1"}
        bounces = 64

        def cycles(spp):
            desc = {**description, "engine": "CYCLES", "kind": "brute_force", "samples": spp, "bounces": bounces}
            hit = cache.load(Path(args.cache), desc)
            if hit is None:
                print(f"[{case}] Cycles {spp} spp ...", flush=True)
                with runner.twin_materials_applied([ob], "brute_force"), \
                        runner.engine_setup(scene, "CYCLES", **runner.cycles_options(spp, bounces)):
                    image, sec = runner.render_pixels(scene, w, h)
                cache.store(Path(args.cache), desc, image, sec)
                hit = (image, sec)
            return hit

        ref, ref_sec = cycles(args.reference_samples)
        report.save_image_png(out / f"{case}_cycles_{args.reference_samples}.png", ref)

        def measure(label, image, seconds, **extra):
            row = {"case": case, "label": label, "seconds": round(seconds, 3),
                   "rel_rmse": metrics.relative_rmse(image, ref, mask),
                   "median": metrics.median_relative_error(image, ref, mask), **extra}
            slug = "".join(c if c.isalnum() else "_" for c in f"{case}_{label}").lower()
            report.save_image_png(out / f"{slug}.png", image)
            report.save_error_png(out / f"{slug}_error.png", image, ref, mask)
            if case.startswith("sphere"):
                row.update(blur_profile(image, mask))
            rows.append(row)
            print(f"[{case}] {label}: relative RMSE {row['rel_rmse']:.3f}, median {row['median']:.3f}, "
                  f"{seconds:.2f} s", flush=True)

        for res in args.image_resolutions:
            ob.translucent.geocube_resolution = res
            bake_seconds, (meta,) = runner.bake_objects([ob], "GEOCUBE", progress=lambda t: None)
            img, sec = runner.warm_render(scene, w, h)  # the first frame uploads the bake and builds the tables
            measure(f"GEOCUBE {res}", img, sec, bake_seconds=round(bake_seconds, 2), cubes=meta["geocube_cubes"],
                    res=meta["geocube_res"], coverage=meta["geocube_coverage"])
        for i, spp in enumerate(args.eevee_samples):
            with runner.twin_materials_applied([ob], "brute_force"), \
                    runner.engine_setup(scene, "BLENDER_EEVEE", **runner.eevee_options(spp)):
                scene.eevee.use_raytracing = True
                if i == 0:
                    runner.warm_eevee(scene, w, h)
                img, sec = runner.render_pixels(scene, w, h)
            measure(f"EEVEE {spp}", img, sec)
        for spp in args.cycles_samples:
            img, sec = cycles(spp)
            measure(f"Cycles {spp}", img, sec)
        measure(f"Cycles {args.reference_samples} (reference)", ref, ref_sec)
    return rows


def blur_profile(image, mask) -> dict:
    """Local contrast (mean absolute Laplacian of luminance) in the sphere's centre against a ring near
    its silhouette: the paper's Fig. 15 says the blur is weaker at the silhouette (shorter paths)."""
    lum = image[..., :3].mean(axis=2)
    lap = np.abs(4 * lum[1:-1, 1:-1] - lum[:-2, 1:-1] - lum[2:, 1:-1] - lum[1:-1, :-2] - lum[1:-1, 2:])
    m = mask[1:-1, 1:-1]
    ys, xs = np.nonzero(m)
    cy, cx = ys.mean(), xs.mean()
    radius = np.sqrt(m.sum() / np.pi)
    yy, xx = np.mgrid[0:m.shape[0], 0:m.shape[1]]
    r = np.hypot(yy - cy, xx - cx) / radius
    centre = m & (r < 0.45)
    ring = m & (r > 0.7) & (r < 0.92)
    return {"contrast_centre": float(lap[centre].mean()), "contrast_ring": float(lap[ring].mean())}


def family(label: str) -> str:
    """The renderer of an image row: 'GEOCUBE 32' -> 'GEOCUBE'; the reference keeps its own name."""
    return "reference" if "reference" in label else label.split()[0]


def setting(label: str) -> int:
    return int(label.split()[1])


def chart(images, exits, out: Path) -> None:
    """Speed against accuracy per case (each renderer's settings joined, cheapest first) and the exit
    accuracy against the step cap."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(r["case"] for r in images))
    panels = len(cases) + (1 if exits else 0)
    cols = min(3, max(panels, 1))
    rows_n = -(-max(panels, 1) // cols)
    fig, axes = plt.subplots(rows_n, cols, figsize=(5.2 * cols, 4.2 * rows_n), squeeze=False)
    axes = axes.ravel()
    styles = {"GEOCUBE": ("o", "tab:green", "cube texels"), "EEVEE": ("s", "tab:orange", "samples"),
              "Cycles": ("^", "tab:blue", "samples")}
    for ax, case in zip(axes, cases):
        for fam, (mk, colour, unit) in styles.items():
            rs = sorted((r for r in images if r["case"] == case and family(r["label"]) == fam),
                        key=lambda r: r["seconds"])
            if not rs:
                continue
            ax.plot([r["seconds"] for r in rs], [r["median"] for r in rs], marker=mk, color=colour,
                    label=f"{fam} ({unit})")
            for r in rs:
                ax.annotate(str(setting(r["label"])), (r["seconds"], r["median"]), fontsize=7,
                            xytext=(3, 3), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("seconds per frame (llvmpipe, this machine)")
        ax.set_ylabel("median relative error vs Cycles 256 spp")
        ax.set_title(case.replace("_", " "))
        ax.legend(fontsize=7)
    if exits:
        ax = axes[len(cases)]
        for name in sorted({r["mesh"] for r in exits}):
            for res in sorted({r["res"] for r in exits}):
                rs = [r for r in exits if r["mesh"] == name and r["res"] == res]
                ax.plot([r["cap"] for r in rs], [r["above_1pct"] + 1e-4 for r in rs], marker="o",
                        label=f"{name} {res}x{res}x6")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("step cap")
        ax.set_ylabel("share of exits off by > 1 % of the size")
        ax.set_title("Exit points against exact ray casting")
        ax.legend(fontsize=7)
    for ax in axes[panels:]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(out / "chart.png", dpi=110)


def summary(exits, images, args) -> str:
    lines = ["# GEOCUBE (Chan & Wang 2005): bench on this machine (llvmpipe; times are ratios only)", ""]
    if exits:
        lines += ["## Exit points against exact ray casting (object 100 mm across)", "",
                  "| mesh | res | cap | cubes | coverage | bake s | median | p99 | > 1 % | premature | mean steps |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in exits:
            lines.append(f"| {r['mesh']} | {r['res']} | {r['cap']} | {r['cubes']} | {100 * r['coverage']:.1f} % | "
                         f"{r['bake_seconds']} | {r['median']:.1e} | {r['p99']:.1e} | {100 * r['above_1pct']:.1f} % | "
                         f"{100 * r['premature']:.1f} % | {r['mean_steps']:.1f} |")
        lines.append("")
    lines += [f"## Images against Cycles {args.reference_samples} spp (glass boundary around the same volume)", "",
              "| case | renderer | bake s | s/frame | relative RMSE | median | contrast centre | contrast ring |",
              "|---|---|---|---|---|---|---|---|"]
    for r in images:
        cc = f"{r['contrast_centre']:.4f}" if "contrast_centre" in r else ""
        cr = f"{r['contrast_ring']:.4f}" if "contrast_ring" in r else ""
        lines.append(f"| {r['case']} | {r['label']} | {r.get('bake_seconds', '')} | {r['seconds']} | "
                     f"{r['rel_rmse']:.3f} | {r['median']:.3f} | {cc} | {cr} |")
    lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())

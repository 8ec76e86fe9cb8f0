"""Subsurface methods against exact transport: `make bench-exact`.

Per scene (the bench set's back-lit figure with thin limbs and front-lit skin included): the floor out and
the medium index-matched (eta = 1, so Cycles' brute force samples the lights from inside the volume and
converges; it is the yardstick, Cycles' random walk a peer), the boundary black to light coming back from
outside (no method here carries light from one part of the object into another through the air). The
reference is the mean of several seeds (cached in bench/cache), their spread its noise floor. ``skin_frontlit_ior``
is front-lit skin at its own index (1.3) behind a Glass boundary, its key an area light (``AT_IOR``): where the
angular law is an approximation, and where Cycles' brute force still converges.

Each subsurface method is drawn with the exact-transport profile (EXACT, the default) and with the papers'
dipole (DIPOLE), box-filtered from 3 x 3 samples per pixel as Cycles' BOX filter does, and measured by
the per-channel mean over the object (1 = right) and the relative RMSE over 4 x 4-pixel blocks. Writes
bench/results/exact/ (summary.md, results.json, images).
"""
from __future__ import annotations

import argparse
import contextlib
import json
import re
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402
from bench_quadgraph import isolated  # noqa: E402  (floor out, index-matched: the same set-up)

ROOT = Path(__file__).resolve().parents[1]
SUPERSAMPLE = 3
BLOCK = 4
METHODS = ("IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH")


# Scenes drawn at their preset's index of refraction: Cycles' brute force (a Glass boundary) converges under
# area lights and the world only, so the key spot becomes an area light of the same on-axis intensity.
AT_IOR = {"skin_frontlit_ior": "skin_frontlit"}


def area_key(scene, scale: float) -> None:
    """Swap the scene's key spot for a square area light at its place, aimed alike, as bright on axis, as large as
    the fill (0.3 of the scene's scale: a smaller one leaves the brute force's paths out of the glass too few
    chances to meet it; at 0.02 its 4 x 1024 samples kept a block noise of 0.49)."""
    import bpy

    key = bpy.data.objects["Key Light"]
    spot = key.data
    area = bpy.data.lights.new("Key Area", "AREA")
    area.size = 0.3 * scale
    area.energy = spot.energy / 4.0  # on-axis intensity: a spot P / (4 pi), an area light P / pi
    key.data = area


@contextlib.contextmanager
def at_ior(scene, subject):
    """The refracting set-up: the floor out, the medium at its own index of refraction."""
    import bpy

    ground = bpy.data.objects["Ground"]
    scene.collection.objects.unlink(ground)
    try:
        yield
    finally:
        scene.collection.objects.link(ground)


# The quality settings of the sweep (``--sweep``): the main bench's and bench_auto's series.
SWEEP = {
    "IMAGE_SPACE": [("k=8", {"splat_overlap": 8.0}), ("k=16", {"splat_overlap": 16.0}),
                    ("k=32", {"splat_overlap": 32.0}), ("k=48", {"splat_overlap": 48.0, "splat_max_grid": 2048})],
    "TEXTURE_SPACE": [("atlas 256", {"atlas_resolution": 256, "proxy_spacing": 3.5}),
                      ("atlas 512", {"atlas_resolution": 512, "proxy_spacing": 3.5}),
                      ("atlas 512, spacing 2.4", {"atlas_resolution": 512, "proxy_spacing": 2.4})],
    "QUADGRAPH": [("K=2", {"quadgraph_K": 2.0}), ("K=1", {"quadgraph_K": 1.0}), ("K=0.5", {"quadgraph_K": 0.5})],
}
AUTO_TARGETS = {"IMAGE_SPACE": (0.10, 0.05, 0.03), "TEXTURE_SPACE": (0.10, 0.05), "QUADGRAPH": ()}


def variants(method: str, subject, sweep: bool):
    """(label, apply) per image of a method: the exact profile and the dipole, or with ``sweep`` the quality
    settings of ``SWEEP`` and Auto at each of ``AUTO_TARGETS`` (the exact profile)."""
    import bpy

    t = subject.translucent
    if not sweep:
        return [(p, lambda p=p: setattr(t, "profile", p)) for p in (("EXACT", "DIPOLE") if method != "QUADGRAPH"
                                                                     else ("EXACT",))]
    scene = bpy.context.scene

    def manual(values):
        t.profile, t.quality = "EXACT", "MANUAL"
        for key, value in values.items():
            setattr(scene.translucent if hasattr(scene.translucent, key) else t, key, value)

    def auto(target):
        t.profile, t.quality, t.target_error = "EXACT", "AUTO", target
        bpy.context.view_layer.objects.active = subject
        bpy.ops.translucent.auto_quality()

    return ([(label, lambda v=values: manual(v)) for label, values in SWEEP[method]]
            + [(f"auto {target:g}", lambda x=target: auto(x)) for target in AUTO_TARGETS[method]])


# The peers, measured against the same exact transport: Cycles' random walk (the Principled BSDF's subsurface,
# the twin of our medium) and EEVEE. Not at IOR 1.3: there their boundary mirrors the lamps, which the reference
# leaves out, and the block error would measure the highlight.
RANDOM_WALK_SPP = (16, 128)
EEVEE_SAMPLES = (16,)


def peers(scene, subject, runner, metrics, cache, reference, mask, noise, floor, name, n, cache_dir, description):
    """Rows for Cycles' random walk and EEVEE on the scene (the random walk cached like the reference)."""
    settings = runner.CompareSettings()
    rows = []

    def row(series, label, image, seconds):
        ratio = image[mask][:, :3].mean(0) / reference[mask][:, :3].mean(0)
        r = {"scene": name, "method": series, "profile": label, "seconds": round(seconds, 3), "bake_seconds": 0.0,
             "mean_ratio": [round(float(v), 4) for v in ratio],
             "block_rmse": round(metrics.block_relative_rmse(image, reference, mask, BLOCK), 4),
             "rel_rmse": round(metrics.relative_rmse(image, reference, mask), 4),
             "reference_noise": round(noise, 4), "block_rmse_floor": round(float(floor), 4)}
        print(f"[{name}] {series} {label}: mean {r['mean_ratio']}, block RMSE {r['block_rmse']}, {seconds:.2f} s",
              flush=True)
        return r

    for spp in RANDOM_WALK_SPP:
        desc = {**description, "engine": "CYCLES", "kind": "random_walk", "samples": spp,
                "bounces": settings.cycles_bounces, "seed": 1}
        hit = cache.load(cache_dir, desc)
        if hit is None:
            with runner.twin_materials_applied([subject], "random_walk"), \
                    runner.engine_setup(scene, "CYCLES", **runner.cycles_options(spp, settings.cycles_bounces)):
                hit = runner.render_pixels(scene, n, n)
            cache.store(cache_dir, desc, *hit)
        rows.append(row("Cycles random walk", f"{spp} spp", *hit))
    for spp in EEVEE_SAMPLES:
        with runner.twin_materials_applied([subject], "random_walk"), \
                runner.engine_setup(scene, runner.eevee_engine_id(), **runner.eevee_options(spp)):
            runner.warm_eevee(scene, n, n)
            rows.append(row("EEVEE", f"{spp} samples", *runner.render_pixels(scene, n, n)))
    return rows


def draw_timed(runner, scene, subject, method: str, n: int, supersample: int):
    """``subject`` drawn with ``method``: baked first where the method bakes (timed), a frame that uploads and
    caches, a timed n x n frame, then the image box-filtered from supersample x supersample samples a pixel, as
    Cycles' BOX filter does: (RGBA (n, n, 4), seconds per frame, bake seconds)."""
    t0 = time.perf_counter()
    if method != "IMAGE_SPACE":
        runner.bake_objects([subject], method, progress=lambda *_: None)
    bake_seconds = time.perf_counter() - t0
    with runner.engine_setup(scene, "TRANSLUCENT_RT"):
        runner.render_pixels(scene, n, n)  # uploads and caches
        _, seconds = runner.render_pixels(scene, n, n)
        image, _ = runner.render_pixels(scene, n * supersample, n * supersample)
    return image.reshape(n, supersample, n, supersample, 4).mean(axis=(1, 3)), seconds, bake_seconds


def chart(rows, path: Path) -> None:
    """Speed against accuracy, one panel per scene: 4x4-block error against exact transport over seconds per
    frame, our methods (exact profile) and the peers; the reference's own block noise dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(1, len(scenes), figsize=(4.2 * len(scenes), 4.0), squeeze=False)
    styles = {"IMAGE_SPACE": ("C0", "o"), "TEXTURE_SPACE": ("C1", "s"), "QUADGRAPH": ("C2", "D"),
              "Cycles random walk": ("C3", "^"), "EEVEE": ("C4", "v")}
    for ax, scene in zip(axes[0], scenes):
        rs = [r for r in rows if r["scene"] == scene and r["profile"] != "DIPOLE"]
        for series, (colour, marker) in styles.items():
            pts = [r for r in rs if r["method"] == series]
            if pts:
                ax.plot([r["seconds"] for r in pts], [r["block_rmse"] for r in pts], marker, color=colour,
                        label=series.replace("_", " ").lower() if series in METHODS else series)
                for r in pts:
                    if series not in METHODS:
                        ax.annotate(r["profile"], (r["seconds"], r["block_rmse"]), fontsize=7,
                                    xytext=(4, 2), textcoords="offset points")
        if rs:
            ax.axhline(rs[0]["block_rmse_floor"], color="0.5", ls="--", lw=0.8, label="reference noise")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(scene.replace("_", " "))
        ax.set_xlabel("seconds per frame (128x128, llvmpipe / CPU)")
        ax.set_ylabel("4x4-block relative RMSE vs exact transport")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "exact"))
    parser.add_argument("--cache", default=str(ROOT / "bench" / "cache"))
    parser.add_argument("--size", type=int, default=128, help="image width and height")
    parser.add_argument("--scenes", nargs="*", default=["figure_backlit", "skin_frontlit", "skin_frontlit_ior",
                                                          "bunny_backlit"])
    parser.add_argument("--methods", nargs="*", default=list(METHODS))
    parser.add_argument("--samples", type=int, default=256, help="samples per seed of the reference")
    parser.add_argument("--seeds", type=int, default=2, help="seeds averaged into the reference (at least 2)")
    parser.add_argument("--sweep", action="store_true",
                        help="each method at its quality settings and Auto (exact profile) instead of the two "
                             "profiles: what the quality Auto aims at buys against exact transport "
                             "(write it elsewhere: --output bench/results/exact_sweep)")
    parser.add_argument("--raw", default="", help="also write linear float images here (<scene>_<method>.npy, the "
                                                 "reference and the object mask), for ratio maps")
    args = parser.parse_args()

    package = blender_env.start()
    import importlib

    import bpy

    def mod(name):
        return importlib.import_module(f"{package}.translucent_addon.{name}")

    demo, runner, cache = mod("blender.demo"), mod("blender.compare_runner"), mod("core.reference.cache")
    metrics, report, extract, bvh = mod("core.metrics"), mod("core.report.report"), mod("blender.extract"), \
        mod("blender.bvh_tracer")
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    settings = runner.CompareSettings()
    n = args.size
    rows = []
    for name in args.scenes:
        bpy.ops.wm.read_homefile(use_empty=True)
        base = AT_IOR.get(name, name)
        scene = demo.build_scene(base, bpy.context.scene)
        subject = bpy.data.objects[demo.SCENES[base]["mesh"].capitalize()]
        if name in AT_IOR:
            area_key(scene, demo.SCENES[base]["size"] / 0.15)  # demo.build_scene's light scale
        with (at_ior if name in AT_IOR else isolated)(scene, subject):
            depsgraph = bpy.context.evaluated_depsgraph_get()
            frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, n, n))
            tracer = bvh.BVHTracer(runner.scene_triangles(frame)[0])
            mask = runner.interior(runner._mask(frame, tracer, {subject.name}))
            description = runner.scene_description(depsgraph, frame, [subject])
            seeds = []
            for seed in range(1, args.seeds + 1):
                desc = {**description, "engine": "CYCLES", "kind": "brute_force", "samples": args.samples,
                        "bounces": settings.cycles_bounces, "seed": seed, "self_interreflection": False,
                        **({"surface_reflection": False} if name in AT_IOR else {})}
                hit = cache.load(Path(args.cache), desc)
                if hit is None:
                    print(f"[{name}] Cycles brute force, seed {seed}, {args.samples} spp ...", flush=True)
                    # At an index of refraction, the camera sees the light that leaves the medium and not the
                    # glass's mirror image of the lamps (which no method here draws).
                    with runner.twin_materials_applied([subject], "brute_force", self_interreflection=False,
                                                       surface_reflection=name not in AT_IOR), \
                            runner.engine_setup(scene, "CYCLES", **runner.cycles_options(
                                args.samples, settings.cycles_bounces, seed=seed)):
                        image, sec = runner.render_pixels(scene, n, n)
                    cache.store(Path(args.cache), desc, image, sec)
                    hit = (image, sec)
                seeds.append(hit[0])
            seeds = np.stack(seeds)
            reference = seeds.mean(axis=0)
            noise = metrics.mean_noise(seeds, mask)
            # The reference's own block RMSE: half-sample seeds against each other, over sqrt(2).
            pair = metrics.block_relative_rmse(seeds[0], seeds[1], mask, BLOCK)
            floor = pair / np.sqrt(2.0) / np.sqrt(args.seeds / 2)
            report.save_image_png(out / f"{name}_exact.png", reference)
            raw = Path(args.raw) if args.raw else None
            if raw is not None:
                raw.mkdir(parents=True, exist_ok=True)
                np.save(raw / f"{name}_exact.npy", reference.astype(np.float32))
                np.save(raw / f"{name}_mask.npy", mask)
            print(f"[{name}] reference noise {noise:.4f}, block RMSE floor {floor:.4f}", flush=True)

            for method in args.methods:
                for profile, apply in variants(method, subject, args.sweep):
                    subject.translucent.method = method
                    apply()
                    image, seconds, bake_seconds = draw_timed(runner, scene, subject, method, n, SUPERSAMPLE)
                    ratio = image[mask][:, :3].mean(0) / reference[mask][:, :3].mean(0)
                    row = {"scene": name, "method": method, "profile": profile, "seconds": round(seconds, 3),
                           "bake_seconds": round(bake_seconds, 1),
                           "mean_ratio": [round(float(v), 4) for v in ratio],
                           "block_rmse": round(metrics.block_relative_rmse(image, reference, mask, BLOCK), 4),
                           "rel_rmse": round(metrics.relative_rmse(image, reference, mask), 4),
                           "reference_noise": round(noise, 4), "block_rmse_floor": round(float(floor), 4)}
                    rows.append(row)
                    slug = re.sub(r"[^a-z0-9.=]+", "_", f"{name}_{method}_{profile}".lower())
                    report.save_image_png(out / f"{slug}.png", image)
                    if raw is not None:
                        np.save(raw / f"{slug}.npy", image.astype(np.float32))
                    report.save_error_png(out / f"{slug}_error.png", image, reference, mask)
                    print(f"[{name}] {method} {profile}: mean {row['mean_ratio']}, block RMSE {row['block_rmse']}, "
                          f"{seconds:.2f} s, bake {bake_seconds:.1f} s", flush=True)
            if not args.sweep and name not in AT_IOR:
                rows.extend(peers(scene, subject, runner, metrics, cache, reference, mask, noise, floor, name, n,
                                  Path(args.cache), description))
    (out / "results.json").write_text(json.dumps(rows, indent=1))
    if not args.sweep:
        chart(rows, out / "chart.png")
    lines = [f"| scene | method | {'setting' if args.sweep else 'profile'} | mean R, G, B (1 = exact) | "
             "4x4 block rel. RMSE | frame s | bake s |", "|---" * 7 + "|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['method']} | {r['profile']} | "
                     f"{', '.join(f'{v:.3f}' for v in r['mean_ratio'])} | {r['block_rmse']:.3f} | {r['seconds']:.2f} | "
                     f"{r['bake_seconds']:.1f} |")
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())

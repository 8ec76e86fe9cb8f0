"""The generalisation suite (issue 56): every subsurface method against exact transport on 24 drawn scenes.

`make bench-suite`. The scenes are ``suite_scenes.draw()``'s (fixed seed): ten shapes from 1 cm to 1 m, the 12
presets and Principled conversions, point / spot / area / sun lights from the front, side, back and rim, indices
1.0 and 1.3-1.4. Each reference is Cycles' brute force of the scene's volume, the mean of two seeds, kept in
``bench/suite_references/`` (float16, with the description it was rendered from: a scene whose description changed
is rendered again). Each method draws at default quality, box-filtered from 2 x 2 samples per pixel.

Per method: the distribution (median, 90th percentile, worst) of the 4x4-block relative RMSE and of the per-channel
mean ratio, over all scenes, front-lit ones, and each half (A: the half a fitted term is fitted on; B: held out);
which factor drives the error (Spearman's rank correlation of the block error with thickness in diffusion lengths,
curvature, albedo; medians per light direction), and a chart. Writes bench/results/suite/.
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402
import suite_scenes  # noqa: E402
from bench_exact import draw_timed  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
METHODS = ("IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH")
BLOCK = 4
SUPERSAMPLE = 2
# Samples behind Glass, times the others: the suite's 1 (its high-albedo media run paths to the bounce cap), the
# tests' 4 (a small torus of potato: its light leaves the glass towards the area light by chance).
GLASS_SAMPLES = {"suite": 1, "tests": 4}
REFERENCES = ROOT / "bench" / "suite_references"
TEST_REFERENCES = ROOT / "tests" / "data" / "exact"


def reference(name, scene, subject, runner, n, samples, seeds, directory: Path, glass_samples: int = 1):
    """The exact reference of a built scene: (mean image, per-seed images), rendered or read back."""
    import bpy

    from_cache = directory / f"{name}.npz"
    depsgraph = bpy.context.evaluated_depsgraph_get()
    extract = importlib.import_module(f"{blender_env.PACKAGE}.translucent_addon.blender.extract")
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, n, n))
    description = runner.scene_description(depsgraph, frame, [subject])
    description.pop("blender")  # a reference stays valid across Blender versions of the same Cycles
    description.update(samples=samples, seeds=seeds, kind="brute_force", self_interreflection=False)
    text = json.dumps(description, sort_keys=True, default=str)
    if from_cache.exists():
        data = np.load(from_cache)
        if str(data["description"]) == text:
            return data["seeds"].astype(np.float32), frame
        print(f"[{name}] the scene changed since its reference: rendering it again", flush=True)
    settings = runner.CompareSettings()
    samples *= glass_samples if runner.medium_source.resolve(subject).eta != 1.0 else 1
    images = []
    for seed in range(1, seeds + 1):
        t0 = time.perf_counter()
        with runner.twin_materials_applied([subject], "brute_force", self_interreflection=False,
                                           surface_reflection=False), \
                runner.engine_setup(scene, "CYCLES", **runner.cycles_options(samples, settings.cycles_bounces,
                                                                             seed=seed)):
            image, _ = runner.render_pixels(scene, n, n)
        print(f"[{name}] Cycles brute force, seed {seed}, {samples} spp: {time.perf_counter() - t0:.1f} s", flush=True)
        images.append(image[..., :3])
    images = np.stack(images)
    directory.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(from_cache, seeds=images.astype(np.float16), description=text)
    return images, frame


def factors(spec, subject, medium) -> dict:
    """What may drive a scene's error: the object's mean chord (4 V / A, Cauchy) in diffusion lengths, its
    area-weighted mean curvature times a diffusion length, the reduced albedo, the light's direction. The
    diffusion length 1 / sigma_tr (Jensen Eq. 4's sigma_tr = sqrt(3 sigma_a sigma_t')) is the channels' mean,
    with sigma_a kept at least 1e-4 sigma_s' (spectralon's is 0)."""
    import bpy
    import scipy.sparse as sp

    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = subject.evaluated_get(depsgraph).to_mesh()
    mesh.calc_loop_triangles()
    p = np.empty(len(mesh.vertices) * 3, np.float64)
    mesh.vertices.foreach_get("co", p)
    t = np.empty(len(mesh.loop_triangles) * 3, np.int64)
    mesh.loop_triangles.foreach_get("vertices", t)
    subject.evaluated_get(depsgraph).to_mesh_clear()
    m = np.asarray(subject.matrix_world, np.float64)
    p = p.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    t = t.reshape(-1, 3)
    a, b, c = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
    cross = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    volume = abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0
    # Mean curvature |H| = |Laplace-Beltrami x| / 2 with cotangent weights (Meyer et al. 2003), area-weighted.
    rows, cols, weights = [], [], []
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        u, v = p[t[:, i]] - p[t[:, k]], p[t[:, j]] - p[t[:, k]]
        cot = np.einsum("ij,ij->i", u, v) / np.maximum(np.linalg.norm(np.cross(u, v), axis=1), 1e-30)
        rows += [t[:, i], t[:, j]]
        cols += [t[:, j], t[:, i]]
        weights += [0.5 * cot, 0.5 * cot]
    n = len(p)
    w = sp.csr_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    laplace = w - sp.diags(np.asarray(w.sum(axis=1)).ravel())
    vertex_area = np.bincount(t.ravel(), np.repeat(area / 3.0, 3), n)
    h = 0.5 * np.linalg.norm(laplace @ p, axis=1) / np.maximum(vertex_area, 1e-30)
    mean_h = float((h * vertex_area).sum() / vertex_area.sum())
    sigma_a, sigma_s = np.asarray(medium.sigma_a), np.asarray(medium.sigma_s_prime)
    sigma_a = np.maximum(sigma_a, 1e-4 * sigma_s)
    sigma_tr = np.sqrt(3.0 * sigma_a * (sigma_a + sigma_s))  # mm^-1
    ell = float(np.mean(1.0 / (sigma_tr * medium.mm_per_unit)))  # Blender units
    return {"thickness": round(4.0 * volume / area.sum() / ell, 4), "curvature": round(mean_h * ell, 4),
            "albedo": round(float(np.mean(sigma_s / (sigma_a + sigma_s))), 4), "direction": spec.direction,
            "diffusion_length_m": ell}


def spearman(x, y) -> float:
    rx, ry = np.argsort(np.argsort(x)), np.argsort(np.argsort(y))
    return float(np.corrcoef(rx, ry)[0, 1]) if len(x) > 2 else float("nan")


def distribution(rows) -> dict:
    """Median, 90th percentile and worst block error; the per-channel mean ratio's median, 10th and 90th
    percentile, worst (farthest from 1), and the share of scenes whose every channel is within 10 %."""
    if not rows:
        nan = float("nan")
        return {"scenes": 0, **{k: nan for k in ("block_median", "block_p90", "block_worst", "mean_median", "mean_p10",
                                                 "mean_p90", "mean_worst", "within_10pct")}}
    block = np.array([r["block_rmse"] for r in rows])
    ratio = np.array([r["mean_ratio"] for r in rows])
    worst = ratio.ravel()[np.argmax(np.abs(np.log(ratio.ravel())))]
    return {"scenes": len(rows), "block_median": float(np.median(block)), "block_p90": float(np.percentile(block, 90)),
            "block_worst": float(block.max()), "mean_median": float(np.median(ratio)),
            "mean_p10": float(np.percentile(ratio, 10)), "mean_p90": float(np.percentile(ratio, 90)),
            "mean_worst": float(worst), "within_10pct": float(np.mean(np.all(np.abs(ratio - 1) <= 0.10, axis=1)))}


def summarise(rows) -> dict:
    """Per method: the distributions over all scenes, the front-lit ones and each half; the factors' rank
    correlation with the block error and the block error's median per light direction."""
    out = {}
    for method in METHODS:
        rs = [r for r in rows if r["method"] == method]
        if not rs:
            continue
        block = [r["block_rmse"] for r in rs]
        bias = [float(np.mean(np.abs(np.log(r["mean_ratio"])))) for r in rs]
        out[method] = {
            "all": distribution(rs), "front": distribution([r for r in rs if r["direction"] == "FRONT"]),
            "half_A": distribution([r for r in rs if r["half"] == "A"]),
            "half_B": distribution([r for r in rs if r["half"] == "B"]),
            "spearman_block": {f: spearman([r[f] for r in rs], block) for f in ("thickness", "curvature", "albedo")},
            "spearman_mean_bias": {f: spearman([r[f] for r in rs], bias) for f in ("thickness", "curvature", "albedo")},
            "block_by_direction": {d: float(np.median([r["block_rmse"] for r in rs if r["direction"] == d]))
                                   for d in suite_scenes.DIRECTIONS if any(r["direction"] == d for r in rs)},
            "mean_by_direction": {d: float(np.median([r["mean_ratio"] for r in rs if r["direction"] == d]))
                                  for d in suite_scenes.DIRECTIONS if any(r["direction"] == d for r in rs)},
        }
    return out


def chart(rows, path: Path) -> None:
    """Five panels: each method's block error over the scenes (sorted), then the block error against thickness
    in diffusion lengths, curvature and albedo, and the mean ratio (green) per light direction."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 5, figsize=(22, 4.2))
    colours = {"IMAGE_SPACE": "C0", "TEXTURE_SPACE": "C1", "QUADGRAPH": "C2"}
    for method, colour in colours.items():
        rs = [r for r in rows if r["method"] == method]
        if not rs:
            continue
        label = method.replace("_", " ").lower()
        block = np.sort([r["block_rmse"] for r in rs])
        axes[0].plot(np.arange(1, len(block) + 1) / len(block), block, "o-", ms=3, color=colour, label=label)
        for ax, f in zip(axes[1:4], ("thickness", "curvature", "albedo")):
            ax.scatter([r[f] for r in rs], [r["block_rmse"] for r in rs], s=14, color=colour, label=label)
        for k, d in enumerate(suite_scenes.DIRECTIONS):
            ys = [r["mean_ratio"][1] for r in rs if r["direction"] == d]
            axes[4].scatter(np.full(len(ys), k) + 0.2 * (list(colours).index(method) - 1), ys, s=14, color=colour)
    axes[0].axhline(0.10, color="0.4", ls="--", lw=0.8)
    axes[0].axhline(0.20, color="0.4", ls=":", lw=0.8)
    axes[0].set(xlabel="fraction of scenes", ylabel="4x4-block rel. RMSE vs exact", title="block error, sorted",
                yscale="log")
    axes[0].legend(fontsize=8)
    for ax, f, xl in zip(axes[1:4], ("thickness", "curvature", "albedo"),
                         ("mean chord / diffusion length", "mean curvature x diffusion length", "reduced albedo")):
        ax.set(xlabel=xl, ylabel="block rel. RMSE", yscale="log", xscale="log" if f != "albedo" else "linear",
               title=f"block error vs {f}")
        ax.grid(True, which="both", alpha=0.3)
    axes[4].axhline(1.0, color="0.4", lw=0.8)
    axes[4].axhspan(0.9, 1.1, color="0.9")
    axes[4].set_xticks(range(len(suite_scenes.DIRECTIONS)), [d.lower() for d in suite_scenes.DIRECTIONS])
    axes[4].set(ylabel="mean ratio (green) vs exact", title="mean by light direction")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def markdown(rows, summary) -> str:
    lines = ["# Generalisation suite: every method against exact transport", "",
             f"{len({r['scene'] for r in rows})} scenes (`scripts/suite_scenes.py`, seed 56), 128x128, default "
             "quality, Cycles brute force references. Block: 4x4-block relative RMSE; mean: the per-channel mean "
             "ratio over the object (1 = exact).", "",
             "| method | scenes | block median | block p90 | block worst | front-lit block median | mean p10 - p90 "
             "| worst channel mean | all channels within 10 % | half A block median / p90 | half B block median / "
             "p90 |", "|---" * 11 + "|"]
    for method, s in summary.items():
        a, f, ha, hb = s["all"], s["front"], s["half_A"], s["half_B"]
        lines.append(f"| {method} | {a['scenes']} | {a['block_median']:.3f} | {a['block_p90']:.3f} | "
                     f"{a['block_worst']:.3f} | {f['block_median']:.3f} | {a['mean_p10']:.3f} - "
                     f"{a['mean_p90']:.3f} | {a['mean_worst']:.3f} | {100 * a['within_10pct']:.0f} % | "
                     f"{ha['block_median']:.3f} / {ha['block_p90']:.3f} | {hb['block_median']:.3f} / "
                     f"{hb['block_p90']:.3f} |")
    lines += ["", "Which factor drives the error (Spearman rank correlation with the block error; with |log mean "
              "ratio| in brackets), and the median block error and green mean ratio per light direction:", "",
              "| method | thickness | curvature | albedo | " + " | ".join(d.lower() for d in suite_scenes.DIRECTIONS)
              + " |", "|---" * (4 + len(suite_scenes.DIRECTIONS)) + "|"]
    for method, s in summary.items():
        cells = [f"{s['spearman_block'][f]:+.2f} ({s['spearman_mean_bias'][f]:+.2f})"
                 for f in ("thickness", "curvature", "albedo")]
        nan = float("nan")
        dirs = [f"{s['block_by_direction'].get(d, nan):.3f} / {s['mean_by_direction'].get(d, nan):.2f}"
                for d in suite_scenes.DIRECTIONS]
        lines.append(f"| {method} | " + " | ".join(cells + dirs) + " |")
    lines += ["", "| scene | shape | size m | medium | light | eta | thickness / curvature / albedo | reference noise "
              "| IMAGE_SPACE mean; block | TEXTURE_SPACE mean; block | QUADGRAPH mean; block |", "|---" * 11 + "|"]
    for name in dict.fromkeys(r["scene"] for r in rows):
        rs = {r["method"]: r for r in rows if r["scene"] == name}
        r0 = next(iter(rs.values()))
        cells = []
        for method in METHODS:
            r = rs.get(method)
            cells.append("-" if r is None else
                         f"{', '.join(f'{v:.2f}' for v in r['mean_ratio'])}; {r['block_rmse']:.3f}")
        lines.append(f"| {name} | {r0['shape']} | {r0['size']:g} | {r0['medium']} | {r0['light'].lower()} "
                     f"{r0['direction'].lower()} | {r0['eta']:g} | {r0['thickness']:.3g} / {r0['curvature']:.3g} / "
                     f"{r0['albedo']:.3f} | {r0['block_rmse_floor']:.3f} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def report_only(out: Path, merges: list[Path], count: int) -> int:
    rows = json.loads((out / "results.json").read_text())
    for path in merges:
        new = json.loads(path.read_text())
        done = {(r["scene"], r["method"]) for r in new}
        rows = [r for r in rows if (r["scene"], r["method"]) not in done] + new
    return write_report(out, rows, suite_scenes.draw(count=count))


def write_report(out: Path, rows: list, specs) -> int:
    """results.json (rows in the specs' order), summary.json, summary.md and chart.png."""
    order = {s.name: i for i, s in enumerate(specs)}
    rows.sort(key=lambda r: (order.get(r["scene"], 99), METHODS.index(r["method"])))
    (out / "results.json").write_text(json.dumps(rows, indent=1))
    summary = summarise(rows)
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    chart(rows, out / "chart.png")
    text = markdown(rows, summary)
    (out / "summary.md").write_text(text)
    print(text)
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "suite"))
    parser.add_argument("--references", default=str(REFERENCES))
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--count", type=int, default=24)
    parser.add_argument("--scenes", nargs="*", default=None, help="only these scenes (names or indices)")
    parser.add_argument("--methods", nargs="*", default=list(METHODS))
    parser.add_argument("--samples", type=int, default=512, help="Cycles samples per seed of a reference")
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--references-only", action="store_true", help="render the references, draw no method")
    parser.add_argument("--raw", default="", help="also write float images here (npz per scene)")
    parser.add_argument("--test-references", action="store_true",
                        help="render the exact references of the tests' scenes (suite_scenes.TEST_SCENES) at 64x64, "
                             "4 seeds, into tests/data/exact/, and draw each method on them")
    parser.add_argument("--report-only", action="store_true",
                        help="write summary.md, summary.json and chart.png from results.json as it stands (after rows "
                             "of a rerun were merged into it)")
    parser.add_argument("--merge", nargs="*", default=[],
                        help="results.json files of partial reruns whose rows replace the same scene and method")
    args = parser.parse_args()
    if args.report_only:
        return report_only(Path(args.output), [Path(m) for m in args.merge], args.count)
    if args.test_references:
        args.size, args.seeds, args.samples = 64, 4, 1024
        args.references, args.output = str(TEST_REFERENCES), str(ROOT / "bench" / "results" / "suite_tests")

    package = blender_env.start()
    import bpy

    def mod(name):
        return importlib.import_module(f"{package}.translucent_addon.{name}")

    runner, metrics, report = mod("blender.compare_runner"), mod("core.metrics"), mod("core.report.report")
    bvh, medium_source = mod("blender.bvh_tracer"), mod("blender.medium_source")
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    n = args.size
    specs = list(suite_scenes.TEST_SCENES) if args.test_references else suite_scenes.draw(count=args.count)
    if args.scenes:
        specs = [s for i, s in enumerate(specs) if s.name in args.scenes or str(i) in args.scenes]
    results = out / "results.json"
    rows = [r for r in json.loads(results.read_text())] if results.exists() and args.scenes else []
    for spec in specs:
        rows = [r for r in rows if r["scene"] != spec.name or r["method"] not in args.methods]
        bpy.ops.wm.read_homefile(use_empty=True)
        scene, subject = suite_scenes.build(spec, package)
        seeds, frame = reference(spec.name, scene, subject, runner, n, args.samples, args.seeds,
                                 Path(args.references),
                                 GLASS_SAMPLES["tests" if args.test_references else "suite"])
        ref = seeds.mean(axis=0)
        tracer = bvh.BVHTracer(runner.scene_triangles(frame)[0])
        mask = runner.interior(runner._mask(frame, tracer, {subject.name}))
        # Two seeds differ by sqrt(2) of one's noise; the mean of k keeps 1 / sqrt(k) of it.
        floor = metrics.block_relative_rmse(seeds[0], seeds[1], mask, BLOCK) / np.sqrt(2.0 * len(seeds))
        medium = medium_source.resolve(subject)
        info = {**factors(spec, subject, medium), "scene": spec.name, "shape": spec.shape, "size": spec.size,
                "medium": spec.medium, "light": spec.light, "eta": spec.eta, "half": spec.half,
                "block_rmse_floor": round(float(floor), 4)}
        print(f"[{spec.name}] {spec}: thickness {info['thickness']:.3g}, curvature {info['curvature']:.3g}, "
              f"albedo {info['albedo']:.3f}, reference block noise {floor:.4f}", flush=True)
        raw = {"reference": ref, "mask": mask}
        kept = Path(args.raw) / f"{spec.name}.npz" if args.raw else None
        if kept is not None and kept.exists():  # a rerun of some methods keeps the others' images
            with np.load(kept) as old:
                raw.update({k: old[k] for k in METHODS if k in old.files and k not in args.methods})
        exposure = 0.5 / max(float(np.percentile(ref[mask], 95)), 1e-6) if mask.any() else 1.0
        if args.references_only:
            report.save_image_png(out / f"{spec.name}_exact.png", ref, exposure)
            continue
        for method in args.methods:
            subject.translucent.method = method
            image, seconds, bake_seconds = draw_timed(runner, scene, subject, method, n, SUPERSAMPLE)
            image = image[..., :3]
            ratio = image[mask].mean(0) / ref[mask].mean(0)
            row = {**info, "method": method, "mean_ratio": [round(float(v), 4) for v in ratio],
                   "block_rmse": round(metrics.block_relative_rmse(image, ref, mask, BLOCK), 4),
                   "rel_rmse": round(metrics.relative_rmse(image, ref, mask), 4),
                   "seconds": round(seconds, 3), "bake_seconds": round(bake_seconds, 1)}
            rows.append(row)
            raw[method] = image
            print(f"[{spec.name}] {method}: mean {row['mean_ratio']}, block {row['block_rmse']}, {seconds:.2f} s, "
                  f"bake {bake_seconds:.1f} s", flush=True)
        # Reference, then each method; exposure set by the reference so dark and bright scenes both read.
        strip = [ref] + [raw[m] for m in METHODS if m in raw]
        report.save_image_png(out / f"{spec.name}.png", np.concatenate(strip, axis=1), exposure)
        if args.raw:
            Path(args.raw).mkdir(parents=True, exist_ok=True)
            np.savez_compressed(Path(args.raw) / f"{spec.name}.npz", **{k: np.asarray(v, np.float32)
                                                                       for k, v in raw.items()})
        results.write_text(json.dumps(rows, indent=1))
    return 0 if args.references_only else write_report(out, rows, specs)


if __name__ == "__main__":
    sys.exit(main())

"""Caustics phase of the benchmark (Shah ch. 5), in one run on this machine.

1. The intersection estimate (the NumPy twin, which the GPU pass matches in the tests) against exact
   ray marching on three rugged height fields seen by a light straight above through a 512^2 positions
   texture: median and 90th-percentile error against look-ups, for Shah's step with and without the
   oscillation guard and for Secant steps.
2. A 5 cm glass ball 10 cm over a white floor under a small lamp (off-axis, so the caustic moves): the
   caustic alone (lamp caustics on minus off) for vertex grids 64, 128, 256 and 1, 2, 5 iterations of
   Shah's estimate plus the default (Secant, 4), and with fixed splats (Shah Fig. 5.11's gaps), against
   the exact caustic (photons through the analytic ball, Fresnel in and out) and against Cycles' shadow
   caustics (MNEE, on minus off); Cycles at several sample counts and EEVEE (no caustics) timed in the
   same run. Relative RMSE over the floor around the shadow; centroid offset of the caustic on the floor.
3. The glass bunny (double refraction through a complex caster) against Cycles; a mirror ball whose
   caustic falls beside and behind it, caught by the point light's cube map; a shelf over half of the
   ball (no caustic from the blocked half); and the failure case: a receiver hidden from the light (the
   underside of a shelf that a mirror ball lights from below) gets no caustic.
Writes bench/results/caustics/ (summary.md, results.json, chart.png, images).
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
LAMP = (0.06, 0.02, 0.5)  # off-axis: the caustic lands off the origin
FLOOR_ALBEDO = 0.8


# -- 1. the intersection estimate on height fields --------------------------------------------------

HEIGHT_FIELDS = {
    "ridges": lambda x, y: 0.02 * (np.sin(23 * x) * np.cos(17 * y) + 0.5 * np.sin(51 * x + 31 * y)),
    "bumps": lambda x, y: 0.015 * np.exp(-((np.mod(x * 20, 2) - 1) ** 2 + (np.mod(y * 20, 2) - 1) ** 2) * 4),
    "steps": lambda x, y: 0.01 * np.floor(np.mod(x * 15 + 4 * y, 4)),
}


def estimate_phase(mod) -> list[dict]:
    cm = mod("techniques.caustics.model")
    rng = np.random.default_rng(5)
    n, texels = 4000, 512
    rows = []
    for name, h in HEIGHT_FIELDS.items():
        def lookup(points, h=h):
            x = (np.floor((points[:, 0] + 0.2) / 0.4 * texels) + 0.5) / texels * 0.4 - 0.2
            y = (np.floor((points[:, 1] + 0.2) / 0.4 * texels) + 0.5) / texels * 0.4 - 0.2
            ok = (np.abs(points[:, 0]) <= 0.2) & (np.abs(points[:, 1]) <= 0.2)
            return np.stack([x, y, h(x, y)], 1), ok

        v = np.c_[rng.uniform(-0.1, 0.1, (n, 2)), np.full(n, 0.12)]
        r = np.c_[rng.uniform(-0.5, 0.5, (n, 2)), -np.ones(n)]
        r /= np.linalg.norm(r, axis=1, keepdims=True)
        exact = march(v, r, h)
        for label, guard, secant in (("Shah, no guard", False, False), ("Shah + guard", True, False),
                                     ("Secant + guard", True, True)):
            for it in (1, 2, 3, 5, 8):
                y, valid, _, _ = cm.estimate_intersection(v, r, lookup, it, guard=guard, secant=secant)
                err = np.linalg.norm(y - exact, axis=1)[valid] * 1000.0
                rows.append({"field": name, "estimator": label, "iterations": it,
                             "median_mm": float(np.median(err)), "p90_mm": float(np.quantile(err, 0.9)),
                             "within_1mm": float((err < 1.0).mean())})
        print(f"[estimate] {name}: " + ", ".join(f"{r['estimator']} x{r['iterations']} {r['median_mm']:.2f} mm"
                                                 for r in rows if r["field"] == name and r["iterations"] in (1, 5)))
    return rows


def march(v, r, h):
    """Exact ray / height-field hits: marching in 0.5 mm steps, then 40 bisections."""
    t = np.zeros(len(v))
    step = 5e-4

    def above(t):
        p = v + t[:, None] * r
        return p[:, 2] - h(p[:, 0], p[:, 1])

    while True:
        nxt = t + step
        done = above(nxt) <= 0
        if done.all():
            break
        t = np.where(done, t, nxt)
    lo, hi = t, t + step
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        a = above(mid) > 0
        lo, hi = np.where(a, mid, lo), np.where(a, hi, mid)
    return v + lo[:, None] * r


# -- 2. the glass ball --------------------------------------------------------------------------------

def floor_geometry(mod, bpy, w, h):
    """Per pixel: the floor point, whether the pixel sees the floor (not the ball), the floor area."""
    extract = mod("blender.extract")
    camera = extract.render_camera(bpy.context.evaluated_depsgraph_get(), w, h)
    o, d = mod("core.geometry.camera").pixel_rays(camera.view_proj, w, h)
    t = -o[..., 2] / d[..., 2]
    floor = o + t[..., None] * d
    oc = o - np.array([0.0, 0.0, 0.1])
    b = np.sum(oc * d, -1)
    sees_ball = b * b - (np.sum(oc * oc, -1) - 0.05**2) > 0
    sees_floor = ~sees_ball & (np.abs(floor[..., :2]) < 0.2).all(-1) & (t > 0)
    area = t * t / np.maximum(np.abs(d[..., 2]), 1e-6)  # floor area per pixel, up to a constant
    return floor, sees_floor, area


def exact_caustic(mod, floor, sees_floor, photons: int, bins: int = 400, light_radius: float = 0.0):
    """rho / pi E_exact at each floor pixel, E by histogram (bilinear) of photons through the ball. A lamp
    of radius a (Cycles' soft point light) is sampled as 64 point lamps spread uniformly over the disk
    of radius a facing the ball."""
    import dataclasses

    cs = mod("core.reference.caustic_sphere")
    lights = mod("core.lights")
    e = lights.emitters_from_light("Lamp", "POINT", _matrix(LAMP), (1, 1, 1), 10.0)[0]
    sphere = cs.GlassSphere((0, 0, 0.1), 0.05, 1.5)
    E = np.zeros((bins, bins, 3))
    chunks = max(photons // 2_000_000, 1) if light_radius == 0 else 64
    axis = np.array([0, 0, 0.1]) - np.array(LAMP)
    axis /= np.linalg.norm(axis)
    a1 = np.cross(axis, [1.0, 0, 0])
    a1 /= np.linalg.norm(a1)
    a2 = np.cross(axis, a1)
    rng = np.random.default_rng(11)
    for seed in range(chunks):
        if light_radius > 0:
            rad, phi = light_radius * np.sqrt((seed + rng.random()) / chunks), 2 * np.pi * rng.random()
            e = dataclasses.replace(e, position=tuple(np.array(LAMP) + rad * (np.cos(phi) * a1 + np.sin(phi) * a2)))
        pts, flux, _ = cs.trace(e, sphere, 0.0, n=photons // chunks, seed=seed + 1)
        E_k, centres = cs.irradiance_grid(pts, flux, -0.2, 0.2, bins)
        E += E_k / chunks
    cell = 0.4 / bins
    fx = (floor[..., 0] + 0.2) / cell - 0.5
    fy = (floor[..., 1] + 0.2) / cell - 0.5
    x0 = np.clip(np.floor(fx).astype(int), 0, bins - 2)
    y0 = np.clip(np.floor(fy).astype(int), 0, bins - 2)
    ax = np.clip(fx - x0, 0, 1)[..., None]
    ay = np.clip(fy - y0, 0, 1)[..., None]
    Ep = ((1 - ax) * (1 - ay) * E[y0, x0] + ax * (1 - ay) * E[y0, x0 + 1] + (1 - ax) * ay * E[y0 + 1, x0]
          + ax * ay * E[y0 + 1, x0 + 1])
    return np.where(sees_floor[..., None], FLOOR_ALBEDO / np.pi * Ep, 0.0)


def _matrix(location):
    m = np.eye(4)
    m[:3, 3] = location
    return m


def centroid(image, floor, mask, area):
    w = image[..., :3].mean(-1) * area * mask
    return (floor[..., :2] * w[..., None]).sum((0, 1)) / max(w.sum(), 1e-30)


def ball_phase(bpy, mod, args, out: Path) -> tuple[list[dict], dict]:
    runner = mod("blender.compare_runner")
    metrics = mod("core.metrics")
    report = mod("core.report.report")
    demo = mod("blender.demo")
    w = h = args.size
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = demo.build_caustics_scene(bpy.context.scene)
    lamp = bpy.data.objects["Lamp"]
    lamp.location = LAMP
    lamp.rotation_euler = (0, 0, 0)  # a point light: orientation does not matter
    s = scene.translucent
    floor, sees_floor, area = floor_geometry(mod, bpy, w, h)
    ref = exact_caustic(mod, floor, sees_floor, args.photons)
    shadow_centre = np.array(LAMP[:2]) * (0.0 - 0.5) / (0.1 - 0.5)  # the ball's centre seen from the lamp
    rho = np.linalg.norm(floor[..., :2] - shadow_centre, axis=-1)
    mask = sees_floor & (rho < 0.09)
    c_ref = centroid(ref, floor, mask, area)
    report.save_image_png(out / "ball_exact.png", ref)
    rows = []

    def record(label, caustic, seconds, **extra):
        c = centroid(caustic, floor, mask, area)
        row = {"label": label, "seconds": round(seconds, 4), "rel_rmse": metrics.relative_rmse(caustic, ref, mask),
               "centroid_offset_mm": float(np.linalg.norm(c - c_ref) * 1000), "peak_ratio":
               float(caustic[mask][:, :3].mean(-1).max() / ref[mask][:, :3].mean(-1).max()), **extra}
        rows.append(row)
        slug = "".join(ch if ch.isalnum() else "_" for ch in label).lower()
        report.save_image_png(out / f"ball_{slug}.png", caustic)
        print(f"[ball] {label}: rel. RMSE {row['rel_rmse']:.3f}, centroid {row['centroid_offset_mm']:.2f} mm, "
              f"peak {row['peak_ratio']:.2f}, {seconds:.3f} s", flush=True)
        return row

    def ours(**settings):
        saved = {k: getattr(s, k) for k in settings}
        for k, v in settings.items():
            setattr(s, k, v)
        try:
            with runner.engine_setup(scene, "TRANSLUCENT_RT"):
                lamp.data.translucent.caustics = True
                runner.render_pixels(scene, w, h)  # warm-up: shaders, targets
                on, sec = best_of(lambda: runner.render_pixels(scene, w, h))
                lamp.data.translucent.caustics = False
                off, sec_off = best_of(lambda: runner.render_pixels(scene, w, h))
                lamp.data.translucent.caustics = True
        finally:
            for k, v in saved.items():
                setattr(s, k, v)
        return np.clip(on[..., :3] - off[..., :3], 0, None), sec, sec_off

    base_seconds = None
    for grid in (64, 128, 256):
        for estimator, iterations in (("SHAH", 1), ("SHAH", 2), ("SHAH", 5), ("SECANT", 4)):
            caustic, sec, sec_off = ours(caustics_grid=grid, caustics_estimator=estimator,
                                         caustics_iterations=iterations)
            base_seconds = sec_off
            record(f"ours {grid} {estimator.lower()} x{iterations}", caustic, sec, grid=grid,
                   estimator=estimator, iterations=iterations, caustic_seconds=round(sec - sec_off, 4))
    for grid in (64, 128):
        caustic, sec, sec_off = ours(caustics_grid=grid, caustics_adaptive=False)
        record(f"ours {grid} fixed splats", caustic, sec, grid=grid, estimator="SECANT", iterations=4,
               adaptive=False, caustic_seconds=round(sec - sec_off, 4))

    # Cycles: shadow caustics (MNEE) on minus off, at several sample counts.
    ball = bpy.data.objects["Glass ball"]
    for spp in args.cycles_samples:
        with runner.engine_setup(scene, "CYCLES", **runner.cycles_options(spp, 16)):
            ball.cycles.is_caustics_caster = True
            on, sec = runner.render_pixels(scene, w, h)
            ball.cycles.is_caustics_caster = False
            off, _ = runner.render_pixels(scene, w, h)
            ball.cycles.is_caustics_caster = True
        record(f"Cycles MNEE {spp}", np.clip(on[..., :3] - off[..., :3], 0, None) * sees_floor[..., None], sec,
               samples=spp)
        report.save_image_png(out / f"ball_cycles_full_{spp}.png", on)
    # Cycles brute force (no MNEE) needs a lamp it can hit: 2 cm radius, against the exact trace of the same.
    ball.cycles.is_caustics_caster = False
    lamp.data.shadow_soft_size = args.brute_radius
    ref_soft = exact_caustic(mod, floor, sees_floor, args.photons, light_radius=args.brute_radius)
    report.save_image_png(out / "ball_exact_soft_lamp.png", ref_soft)
    with runner.engine_setup(scene, "CYCLES", **runner.cycles_options(args.brute_samples, 16)):
        on, sec = runner.render_pixels(scene, w, h)
    black = bpy.data.materials.new("Opaque")  # the ball as an opaque occluder: the shadow without caustic
    ball.data.materials[0], glass = black, ball.data.materials[0]
    with runner.engine_setup(scene, "CYCLES", **runner.cycles_options(64, 16)):
        off, _ = runner.render_pixels(scene, w, h)
    ball.data.materials[0] = glass
    brute = np.clip(on[..., :3] - off[..., :3], 0, None) * sees_floor[..., None]
    report.save_image_png(out / "ball_cycles_brute_force.png", brute)
    soft = {"label": f"Cycles brute force {args.brute_samples} spp, {args.brute_radius * 1000:.0f} mm lamp, vs exact "
                     "trace of that lamp", "seconds": sec,
            "rel_rmse": metrics.relative_rmse(brute, ref_soft, mask),
            "centroid_offset_mm": float(np.linalg.norm(centroid(brute, floor, mask, area)
                                                       - centroid(ref_soft, floor, mask, area)) * 1000),
            "flux_ratio": float((brute[..., :3].mean(-1) * area * mask).sum()
                                / (ref_soft[..., :3].mean(-1) * area * mask).sum())}
    print(f"[ball] {soft['label']}: rel. RMSE {soft['rel_rmse']:.3f}, centroid {soft['centroid_offset_mm']:.2f} mm, "
          f"flux ratio {soft['flux_ratio']:.3f}", flush=True)
    lamp.data.shadow_soft_size = 0.002
    ball.cycles.is_caustics_caster = True
    with runner.engine_setup(scene, "BLENDER_EEVEE", **runner.eevee_options(16)):
        img, sec = runner.render_pixels(scene, w, h)
    record("EEVEE 16 (no caustics)", np.zeros_like(ref), sec)
    report.save_image_png(out / "ball_eevee_full.png", img)
    with runner.engine_setup(scene, "TRANSLUCENT_RT"):
        full, _ = runner.render_pixels(scene, w, h)
    report.save_image_png(out / "ball_ours_full.png", full)
    return rows, {"frame_without_caustics_s": base_seconds, "mask_pixels": int(mask.sum()), "brute_force": soft,
                  "exact_centroid_mm": (c_ref * 1000).tolist()}


def best_of(fn, n: int = 2):
    best = None
    for _ in range(n):
        img, sec = fn()
        if best is None or sec < best[1]:
            best = (img, sec)
    return best


# -- 3. the bunny and the failure cases ---------------------------------------------------------------

def scenes_phase(bpy, mod, args, out: Path) -> list[dict]:
    runner = mod("blender.compare_runner")
    report = mod("core.report.report")
    demo = mod("blender.demo")
    w = h = args.size
    rows = []
    # Glass bunny: ours and Cycles MNEE, full images.
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = demo.build_caustics_scene(bpy.context.scene, caster="bunny")
    with runner.engine_setup(scene, "TRANSLUCENT_RT"):
        runner.render_pixels(scene, w, h)
        img, sec = runner.render_pixels(scene, w, h)
    report.save_image_png(out / "bunny_ours.png", img)
    with runner.engine_setup(scene, "CYCLES", **runner.cycles_options(args.cycles_samples[-1], 16)):
        ref, ref_sec = runner.render_pixels(scene, w, h)
    report.save_image_png(out / "bunny_cycles.png", ref)
    rows.append({"case": "glass bunny", "ours_s": sec, "cycles_s": ref_sec})
    print(f"[bunny] ours {sec:.3f} s, Cycles {ref_sec:.1f} s", flush=True)

    # A mirror ball beside a wall: the reflected caustic lands outside the cone a spot would cover.
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = demo.build_caustics_scene(bpy.context.scene)
    ball = bpy.data.objects["Glass ball"]
    ball.translucent.caustics_caster = "REFLECTIVE"
    ball.translucent.caustics_color = (0.9, 0.9, 0.9)
    ball.location = (0.0, 0.0, 0.05)
    wall = bpy.data.objects.new("Wall", bpy.data.meshes.new("Wall"))
    wall.data.from_pydata([(-0.2, 0.12, 0), (0.2, 0.12, 0), (0.2, 0.12, 0.3), (-0.2, 0.12, 0.3)], [], [(0, 1, 2, 3)])
    scene.collection.objects.link(wall)
    lamp = bpy.data.objects["Lamp"]
    lamp.location = (0.0, -0.1, 0.25)
    with runner.engine_setup(scene, "TRANSLUCENT_RT"):
        on, _ = runner.render_pixels(scene, w, h)
        lamp.data.translucent.caustics = False
        off, _ = runner.render_pixels(scene, w, h)
    report.save_image_png(out / "failure_mirror_cube_map.png", on)
    report.save_image_png(out / "failure_mirror_cube_map_caustic.png", np.clip(on - off, 0, None) * 4)
    rows.append({"case": "mirror ball, caustic beside it (cube map)",
                 "caustic_sum": float(np.clip(on - off, 0, None)[..., :3].sum())})

    # A shelf over half of the ball: the light it blocks makes no caustic (the shadow map test in the trace).
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = demo.build_caustics_scene(bpy.context.scene)
    shelf = bpy.data.objects.new("Shelf", bpy.data.meshes.new("Shelf"))
    shelf.data.from_pydata([(0.0, -0.2, 0.2), (0.2, -0.2, 0.2), (0.2, 0.2, 0.2), (0.0, 0.2, 0.2)], [],
                           [(0, 1, 2, 3)])
    scene.collection.objects.link(shelf)
    bpy.data.objects["Lamp"].location = (-0.02, 0.0, 0.5)
    with runner.engine_setup(scene, "TRANSLUCENT_RT"):
        img, _ = runner.render_pixels(scene, w, h)
    report.save_image_png(out / "occluded_caster.png", img)
    rows.append({"case": "shelf over half of the ball: no caustic from the blocked half (image)"})

    # Failure: a receiver hidden from the light. A mirror ball throws light up under a shelf that the lamp
    # sees only from above; the underside gets nothing (Cycles: a bright reflected caustic there).
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = demo.build_caustics_scene(bpy.context.scene)
    ball = bpy.data.objects["Glass ball"]
    ball.translucent.caustics_caster = "REFLECTIVE"
    ball.translucent.caustics_color = (0.9, 0.9, 0.9)
    ball.location = (0.0, 0.0, 0.05)
    mirror = bpy.data.materials.new("Mirror")
    mirror.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 1.0
    mirror.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.0
    ball.data.materials[0] = mirror
    shelf = bpy.data.objects.new("Shelf", bpy.data.meshes.new("Shelf"))  # a solid board, 1 cm thick
    box = [(x, y, z) for x in (0.04, 0.2) for y in (-0.2, 0.2) for z in (0.12, 0.13)]
    shelf.data.from_pydata(box, [], [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4),
                                     (1, 5, 7, 3)])
    scene.collection.objects.link(shelf)
    bpy.data.objects["Lamp"].location = (-0.2, 0.0, 0.3)
    cam = scene.camera
    cam.location = (-0.05, -0.4, 0.06)
    cam.rotation_euler = (np.radians(90), 0.0, 0.0)
    with runner.engine_setup(scene, "TRANSLUCENT_RT"):
        img, _ = runner.render_pixels(scene, w, h)
    report.save_image_png(out / "failure_hidden_receiver.png", img)
    ball.cycles.is_caustics_caster = False
    with runner.engine_setup(scene, "CYCLES", **runner.cycles_options(args.cycles_samples[-1], 16)):
        ref, _ = runner.render_pixels(scene, w, h)
    report.save_image_png(out / "failure_hidden_receiver_cycles.png", ref)
    rows.append({"case": "mirror ball under a shelf the lamp sees only from above: no caustic under it (images)"})
    return rows


# -- output -------------------------------------------------------------------------------------------

def chart(ball_rows, estimate_rows, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.8))
    for row in ball_rows:
        label = row["label"]
        color = "tab:blue" if label.startswith("ours") else ("tab:red" if "Cycles" in label else "tab:gray")
        a.scatter(row["seconds"], row["rel_rmse"], color=color, s=22)
        if not label.startswith("ours") or "x4" in label or "fixed" in label:
            a.annotate(label, (row["seconds"], row["rel_rmse"]), fontsize=7, xytext=(3, 3), textcoords="offset points")
    a.set_xscale("log")
    a.set_xlabel("seconds per frame (this machine, llvmpipe / CPU)")
    a.set_ylabel("relative RMSE of the caustic vs exact trace")
    a.set_title("Glass ball caustic: speed vs accuracy")
    a.grid(alpha=0.3)
    for label, style in (("Shah, no guard", ":"), ("Shah + guard", "--"), ("Secant + guard", "-")):
        for field, color in zip(HEIGHT_FIELDS, ("tab:blue", "tab:orange", "tab:green")):
            rows = [r for r in estimate_rows if r["estimator"] == label and r["field"] == field]
            b.plot([r["iterations"] for r in rows], [r["median_mm"] for r in rows], style, color=color,
                   label=f"{field}: {label}")
    b.set_yscale("log")
    b.set_xlabel("look-ups")
    b.set_ylabel("median error of the intersection (mm)")
    b.set_title("Intersection estimate on height fields (512^2 texture)")
    b.legend(fontsize=6)
    b.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "chart.png", dpi=110)


def summary(ball_rows, extra, estimate_rows, scene_rows, args) -> str:
    lines = ["# Caustics benchmark (Shah ch. 5)", "",
             f"Machine: this session's CPU with Mesa llvmpipe (no GPU); {args.size}x{args.size} pixels; "
             f"exact reference from {args.photons:,} photons through the analytic ball.", "",
             "## Glass ball: the caustic (lamp caustics on minus off) against the exact trace", "",
             "| configuration | s / frame | caustic s | rel. RMSE | centroid offset (mm) | peak / exact |",
             "|---|---|---|---|---|---|"]
    for r in ball_rows:
        lines.append(f"| {r['label']} | {r['seconds']:.3f} | {r.get('caustic_seconds', '')} | {r['rel_rmse']:.3f} | "
                     f"{r['centroid_offset_mm']:.2f} | {r['peak_ratio']:.2f} |")
    lines += ["", f"Frame without caustics (ours): {extra['frame_without_caustics_s']:.3f} s; "
              f"{extra['mask_pixels']} floor pixels in the error mask; exact centroid "
              f"({extra['exact_centroid_mm'][0]:.1f}, {extra['exact_centroid_mm'][1]:.1f}) mm.", "",
              "The reference checked against Cycles: " + json.dumps(extra["brute_force"], default=float), "",
              "## Intersection estimate on height fields (median / 90th percentile error, mm)", "",
              "| field | estimator | 1 | 2 | 3 | 5 | 8 |", "|---|---|---|---|---|---|---|"]
    for field in HEIGHT_FIELDS:
        for label in ("Shah, no guard", "Shah + guard", "Secant + guard"):
            rows = [r for r in estimate_rows if r["field"] == field and r["estimator"] == label]
            lines.append(f"| {field} | {label} | " + " | ".join(f"{r['median_mm']:.2f} / {r['p90_mm']:.2f}"
                                                                for r in rows) + " |")
    lines += ["", "## Other scenes", ""] + [f"- {json.dumps(r, default=float)}" for r in scene_rows]
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "caustics"))
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--photons", type=int, default=8_000_000)
    parser.add_argument("--cycles-samples", nargs="*", type=int, default=[16, 64, 256])
    parser.add_argument("--brute-samples", type=int, default=4096)
    parser.add_argument("--brute-radius", type=float, default=0.02)
    parser.add_argument("--skip-scenes", action="store_true")
    parser.add_argument("--scenes-only", action="store_true", help="rerun phase 3 into the existing results")
    args = parser.parse_args()
    package = blender_env.start()
    import importlib

    import bpy

    def mod(name):
        return importlib.import_module(f"{package}.translucent_addon.{name}")

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    if args.scenes_only:
        previous = json.loads((out / "results.json").read_text())
        estimate_rows, ball_rows, extra = previous["estimate"], previous["ball"], previous["ball_extra"]
    else:
        estimate_rows = estimate_phase(mod)
        ball_rows, extra = ball_phase(bpy, mod, args, out)
    scene_rows = [] if args.skip_scenes else scenes_phase(bpy, mod, args, out)
    (out / "results.json").write_text(json.dumps({"ball": ball_rows, "ball_extra": extra, "estimate": estimate_rows,
                                                  "scenes": scene_rows}, indent=2, default=float))
    chart(ball_rows, estimate_rows, out)
    (out / "summary.md").write_text(summary(ball_rows, extra, estimate_rows, scene_rows, args))
    print(f"wrote {out / 'summary.md'} in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

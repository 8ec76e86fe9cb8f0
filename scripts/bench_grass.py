"""Grass phase of the benchmark (Shah ch. 4), in one run on this machine.

1. Acquisition: the default patch (500 blades per tile) under 81 views x 21 lights at 128 x 128 with
   our moderngl rasteriser; seconds.
2. Compression: the relative error of the mean-adjusted SVD in Y, Cb, Cr against the count of
   eigen-textures, and the storage; the exact RGB error over blade pixels of 60 sampled images for
   several (Y, chroma) counts, with Shah's 140 / 6 among them; images as Shah Fig. 4.5.
3. Unsampled directions: 16 (view, light) pairs that are not samples, rendered directly and
   reconstructed per pixel (three nearest views and lights): the interpolation error alone
   (uncompressed images) and with the default compression; gap agreement.
4. Blender scenes (256 x 256): a ball half sunk in a field, a hill crest against the sky, frame time
   at 10^3 and 10^6 equivalent blades (the same BTF over tiles of 1.4 m and 4.5 cm), with and without
   fewer eigen-textures far away; the same blades as geometry in EEVEE at 10^3 .. 10^5 blades.
5. The field against Cycles: 1.2 m of grass, our BTF layer at three compression targets, EEVEE (4, 16
   samples) and Cycles (16, 64) with the blades as geometry, against Cycles at 512 samples: relative
   RMSE per pixel and over 8 x 8 blocks, median, mean brightness.
Writes bench/results/grass/ (summary.md, results.json, chart.png, images).
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
FIELD = 4.0  # field side, m
# Above the tallest layer of the density runs (1.27 m blades on 2.8 m tiles), the field filling the view.
DENSITY_CAMERA = (0.0, -4.5, 5.0)


def compression_phase(mod, out: Path) -> tuple[dict, object, object]:
    grass_patch, btf_acquire, btf_compress = (mod("techniques.grass.patch"), mod("techniques.grass.acquire"),
                                              mod("techniques.grass.compress"))
    patch = grass_patch.build_patch()
    btf = btf_acquire.run(btf_acquire.acquire(patch, 128))
    print(f"[grass] acquisition {btf.seconds:.1f} s", flush=True)
    t0 = time.perf_counter()
    F = btf_compress.btf_matrices(btf)
    spectra = [btf_compress.spectrum(F[c]) for c in range(3)]
    svd_s = time.perf_counter() - t0
    curves = btf_compress.error_curve(spectra)
    rng = np.random.default_rng(3)
    n_v, n_l = btf.images.shape[:2]
    picks = [(int(rng.integers(n_v)), int(rng.integers(n_l))) for _ in range(60)]
    rows = []
    for n_y, n_c in ((4, 1), (40, 2), (140, 6), (400, 20), (400, 400)):
        cb = btf_compress.compress(btf, counts=(n_y, n_c), spectra=spectra)
        num = den = 0.0
        for v, l in picks:
            hit = btf.depth[v] != btf_acquire.SENTINEL
            rec = btf_compress.reconstruct(cb, v, l)
            num += float(((rec - btf.images[v, l])[hit] ** 2).sum())
            den += float((btf.images[v, l][hit] ** 2).sum())
        rows.append({"Y": n_y, "chroma": n_c, "svd_error": btf_compress.total_error(curves, n_y, n_c),
                     "rgb_error_blades": float(np.sqrt(num / den)), "MB": cb.storage_bytes()["total"] / 2**20})
        print(f"[grass] counts {n_y}/{n_c}: {rows[-1]}", flush=True)
    for target in (0.6, 0.5, 0.4, 0.3):
        n_y, n_c = btf_compress.choose_counts(spectra, target)
        rows.append({"target": target, "Y": n_y, "chroma": n_c,
                     "svd_error": btf_compress.total_error(curves, n_y, n_c)})
    # Shah Fig. 4.5: one image at 4, 40, 140 luminance eigen-textures and the original.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    v, l = 40, 9
    cb = btf_compress.compress(btf, counts=(400, 6), spectra=spectra)
    panels = [btf_compress.reconstruct(cb, v, l, n_y=n) for n in (4, 40, 140)] + [btf.images[v, l]]
    scale = 1.0 / np.percentile(btf.images[v, l], 99)
    fig, axes = plt.subplots(1, 4, figsize=(12, 3.3))
    for ax, img, title in zip(axes, panels, ("4 Y", "40 Y", "140 Y", "rendered")):
        ax.imshow(np.clip(np.tile(img, (2, 2, 1))[::-1] * scale, 0, 1) ** (1 / 2.2))
        ax.set_title(title)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(out / "coefficients_fig4_5.png", dpi=80)
    plt.close(fig)
    return ({"acquisition_s": btf.seconds, "svd_s": svd_s, "counts": rows, "curves": curves[:, :401].tolist(),
             "uncompressed_MB": btf.images.size * 2 / 2**20}, btf, spectra)


def unsampled_phase(mod, btf, spectra) -> list[dict]:
    """Directly rendered unsampled pairs against the per-pixel reconstruction."""
    grass_patch, btf_acquire, btf_compress = (mod("techniques.grass.patch"), mod("techniques.grass.acquire"),
                                              mod("techniques.grass.compress"))
    grass_data = mod("techniques.grass.model")
    renderer = btf_acquire.PatchRenderer(grass_patch.build_patch(), 128)
    rng = np.random.default_rng(11)
    R = 128
    ij = np.stack(np.meshgrid(np.arange(R), np.arange(R), indexing="xy"), -1).reshape(-1, 2)
    uv = (ij + 0.5) / R
    default = btf_compress.compress(btf, 0.5, spectra=spectra)
    # "Uncompressed": every image kept exactly (all eigen-textures up to the rank formed, 400) is not
    # exact; so interpolate the images themselves with the same weights.
    tables = grass_data.Tables.of(default)
    rows = []
    try:
        for k in range(16):
            def random_dir(max_theta):
                t, p = np.radians(rng.uniform(5, max_theta)), rng.uniform(0, 2 * np.pi)
                return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])
            wv, wl = random_dir(72), random_dir(72)
            direct, depth = renderer.render(wv, wl)
            direct = direct.reshape(-1, 3)[ij[:, 1] * R + ij[:, 0]]
            hit_direct = depth.reshape(-1)[ij[:, 1] * R + ij[:, 0]] != btf_acquire.SENTINEL
            rgb, cov, _ = grass_data.shade(default, uv, wv, wl, tables)
            vi, vw = tables.lookup("view", wv)
            li, lw = tables.lookup("light", wl)
            interp = np.zeros_like(direct)
            covr = np.zeros(len(ij))
            for a in range(3):
                hit_a = (btf.depth[vi[a]] != btf_acquire.SENTINEL).reshape(-1)[ij[:, 1] * R + ij[:, 0]]
                img = sum(lw[b] * btf.images[vi[a], li[b]] for b in range(3)).reshape(-1, 3)[ij[:, 1] * R + ij[:, 0]]
                interp += vw[a] * hit_a[:, None] * img
                covr += vw[a] * hit_a
            interp /= np.maximum(covr, 1e-9)[:, None]
            both = hit_direct & (cov >= 0.5)
            err = lambda x: float(np.sqrt(((x[both] - direct[both]) ** 2).sum() / (direct[both] ** 2).sum()))  # noqa: E731
            mean_err = float(abs(rgb[both].mean() - direct[both].mean()) / direct[both].mean())

            def blocks(x, hit, b=8):  # mean over the blade pixels of each b x b block
                x = (x * hit[:, None]).reshape(R // b, b, R // b, b, 3).sum(axis=(1, 3))
                n = hit.reshape(R // b, b, R // b, b).sum(axis=(1, 3))
                return x / np.maximum(n, 1)[..., None], n > 0
            bd, nd = blocks(direct, hit_direct)
            br, nr = blocks(rgb, cov >= 0.5)
            ok = nd & nr
            block_err = float(np.sqrt(((br[ok] - bd[ok]) ** 2).sum() / (bd[ok] ** 2).sum()))
            rows.append({"theta_v": float(np.degrees(np.arccos(wv[2]))), "theta_l": float(np.degrees(np.arccos(wl[2]))),
                         "interpolation_error": err(interp), "compressed_error": err(rgb), "mean_error": mean_err,
                         "blocks8_error": block_err,
                         "gap_agreement": float(np.mean(hit_direct == (cov >= 0.5)))})
    finally:
        renderer.release()
    return rows


def _store_btf(mod, ob, arrays, meta, tile):
    store, grass_btf, gp = mod("blender.bake_files"), mod("techniques.grass.bake"), mod("techniques.grass.patch")
    s = ob.translucent
    target = float(meta["target_error"])
    s.grass, s.grass_tile, s.grass_blade_height = True, tile, 0.45 * tile
    s.grass_blades, s.grass_seed, s.grass_resolution, s.grass_target_error = 500, 7, "128", target
    params = grass_btf.params_from_settings(s.grass_tile, s.grass_blade_height, 500, 7)
    assert params == gp.GrassParams(blades=500, height=0.45, seed=7)
    store.write(ob, "GRASS", grass_btf.settings_hash(params, 128, s.grass_target_error), arrays, meta)
    status = mod("blender.extract").grass_status(ob)[0]
    if status != "OK":
        raise RuntimeError(f"the stored BTF does not match the settings of '{ob.name}' ({status})")


def new_scene(bpy, demo, sky=(0.35, 0.45, 0.7)):
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    demo.uniform_world(scene, sky)
    scene.render.engine = "TRANSLUCENT_RT"
    return scene


def light_and_camera(bpy, scene, cam_loc, target, lens=50.0):
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.7, 0.3, 0.6)
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = lens
    cam.location = cam_loc
    from mathutils import Vector
    cam.rotation_euler = (Vector(target) - Vector(cam_loc)).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam


def ground(bpy, demo, scene, size_m, name="Ground"):
    h = size_m / 2
    ob = demo.mesh_from_arrays(name, np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]], np.float64),
                               np.array([[0, 1, 2], [0, 2, 3]]))
    obj = bpy.data.objects.new(name, ob)
    soil = demo._material("Soil", (0.12, 0.08, 0.05))
    bsdf = next(n for n in soil.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Specular IOR Level"].default_value = 0.0  # a Lambert soil, as our base pass draws it
    obj.data.materials.append(soil)
    scene.collection.objects.link(obj)
    return obj


def blades_object(bpy, demo, patch, field, side, material, count=None):
    """The patch's blades as geometry, tiled side x side over a field centred at the origin, tile k's
    corner at (k * tile - field / 2): the BTF layer's tiles exactly (its uv is the ground's local xy over
    the tile) when field / 2 is a whole number of tiles. ``count`` tiles (row by row) if fewer; the
    reflectance and transmittance as the point attributes rho_r and rho_t (``twin_materials.leaf``)."""
    n = side * side if count is None else count
    tile = field / side
    offs = np.array([(i, j) for i in range(side) for j in range(side)][:n], np.float64)
    verts = (patch.positions[None, :, :] * tile + np.c_[offs * tile - field / 2, np.zeros(len(offs))][:, None, :])
    tris = patch.triangles[None] + (np.arange(len(offs)) * len(patch.positions))[:, None, None]
    mesh = demo.mesh_from_arrays("Blades", verts.reshape(-1, 3), tris.reshape(-1, 3))
    mesh.shade_smooth()
    for name, rho in (("rho_r", patch.rho_r), ("rho_t", patch.rho_t)):
        attr = mesh.color_attributes.new(name, "FLOAT_COLOR", "POINT")
        rgba = np.concatenate([np.tile(rho, (len(offs), 1)), np.ones((len(offs) * len(rho), 1), np.float32)], 1)
        attr.data.foreach_set("color", rgba.astype(np.float32).ravel())
    ob = bpy.data.objects.new("Blades", mesh)
    ob.data.materials.append(material)
    return ob, int(500 * len(offs)), int(tris.size // 3)


def scenes_phase(bpy, mod, arrays, meta, out: Path, size: int) -> dict:
    runner, report, demo = mod("blender.compare_runner"), mod("core.report.report"), mod("blender.demo")
    twins = mod("blender.twin_materials")
    results = {}

    # Ball half sunk in the field.
    scene = new_scene(bpy, demo)
    g = ground(bpy, demo, scene, FIELD)
    _store_btf(mod, g, arrays, meta, 0.1)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.06, location=(0, 0, 0), segments=64, ring_count=32)
    bpy.context.active_object.data.materials.append(demo._material("Red", (0.7, 0.05, 0.04)))
    light_and_camera(bpy, scene, (0.0, -0.45, 0.22), (0.0, 0.0, 0.02), lens=50.0)
    img, sec = runner.render_pixels(scene, size, size)
    img, sec = runner.render_pixels(scene, size, size)
    report.save_image_png(out / "sunk_ball.png", img)
    results["sunk_ball_s"] = sec
    # Hill crest against the sky.
    scene = new_scene(bpy, demo)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0, 0, -0.7), segments=96, ring_count=48)
    hill = bpy.context.active_object
    hill.data.materials.append(demo._material("Soil", (0.12, 0.08, 0.05)))
    bpy.ops.object.shade_smooth()
    _store_btf(mod, hill, arrays, meta, 0.1)
    light_and_camera(bpy, scene, (0.0, -3.0, 0.35), (0.0, 0.0, 0.3), lens=85.0)
    img, sec = runner.render_pixels(scene, size, size)
    report.save_image_png(out / "hill_crest.png", img)
    # Frame time against blade density: the same BTF over big and small tiles (equivalent blades =
    # blades per tile x field area / tile area).
    timing = []
    for blades in (1e3, 1e6):
        tile = float(np.sqrt(FIELD * FIELD * 500 / blades))
        for lod in (0.0, 1.0):
            scene = new_scene(bpy, demo)
            g = ground(bpy, demo, scene, FIELD)
            _store_btf(mod, g, arrays, meta, tile)
            g.translucent.grass_lod = lod
            light_and_camera(bpy, scene, DENSITY_CAMERA, (0.0, 0.0, 0.0), lens=35.0)
            runner.render_pixels(scene, size, size)
            img, sec = min((runner.render_pixels(scene, size, size) for _ in range(2)), key=lambda r: r[1])
            timing.append({"blades": blades, "tile_m": tile, "lod": lod, "seconds": sec})
            report.save_image_png(out / f"field_{int(blades):d}_lod{int(lod)}.png", img)
            print(f"[grass] field {blades:.0e} blades, tile {tile:.3f} m, lod {lod}: {sec:.2f} s", flush=True)
    results["ours"] = timing
    # The same blades as geometry in EEVEE.
    gp = mod("techniques.grass.patch")
    patch = gp.build_patch()
    eevee = []
    for blades in (1e3, 1e4, 1e5):
        scene = new_scene(bpy, demo)
        g = ground(bpy, demo, scene, FIELD)
        n = max(1, int(round(blades / 500)))
        ob, n_blades, n_tris = blades_object(bpy, demo, patch, FIELD, int(np.ceil(np.sqrt(n))),
                                             twins.leaf("Blade", patch.params.specular), count=n)
        scene.collection.objects.link(ob)
        light_and_camera(bpy, scene, DENSITY_CAMERA, (0.0, 0.0, 0.0), lens=35.0)
        with runner.engine_setup(scene, "BLENDER_EEVEE", **runner.eevee_options(16)):
            runner.warm_eevee(scene, size, size)
            img, sec = runner.render_pixels(scene, size, size)
        eevee.append({"blades": n_blades, "triangles": n_tris, "seconds": sec})
        report.save_image_png(out / f"eevee_geometry_{int(blades):d}.png", img)
        print(f"[grass] EEVEE geometry {eevee[-1]}", flush=True)
    results["eevee_geometry"] = eevee
    return results


# The field against Cycles: 1.2 m of ground under 0.1 m tiles (144 tiles, 72,000 blades, 864,000
# triangles as geometry), seen from 0.67 m at 42 degrees down: the field fills the image below a strip
# of sky beyond its far edge.
REF_FIELD, REF_TILE = 1.2, 0.1
REF_CAMERA, REF_TARGET = (0.0, -0.5, 0.45), (0.0, 0.05, 0.0)
REF_COMPRESSION = (0.6, 0.5, 0.4)  # our three quality settings: the BTF's compression targets


def reference_phase(bpy, mod, btf, spectra, seconds, out: Path, size: int, args) -> list[dict]:
    """The same field three ways against Cycles path tracing the blades as geometry (the leaf twin of the
    acquisition's shading, ``twin_materials.leaf``; Cycles adds the light that bounces between blades and
    the blades' shadows on the soil, which the BTF's direct light leaves out): our BTF layer at three
    compression targets, EEVEE with the blades as geometry, Cycles at fewer samples. Errors over the whole
    pixels that see the field (the rest is sky beyond its far edge): per pixel, the median, and over 8 x 8
    blocks (the texture's look without each blade's place)."""
    runner, report, demo = mod("blender.compare_runner"), mod("core.report.report"), mod("blender.demo")
    twins, metrics, cache = mod("blender.twin_materials"), mod("core.metrics"), mod("core.reference.cache")
    grass_btf, gp = mod("techniques.grass.bake"), mod("techniques.grass.patch")
    patch = gp.build_patch()
    scene = new_scene(bpy, demo)
    g = ground(bpy, demo, scene, REF_FIELD)
    light_and_camera(bpy, scene, REF_CAMERA, REF_TARGET, lens=50.0)
    side = int(round(REF_FIELD / REF_TILE))
    description = {"bench": "grass_reference_v1", "size": size, "field": REF_FIELD, "tile": REF_TILE,
                   "camera": REF_CAMERA, "params": patch.params.as_dict(), "blender": bpy.app.version_string}
    # The pixels that see the field (its far edge is in view): the rays that meet the ground within it,
    # a blade's height in from its borders (no side wall there in either render).
    extract, camera_rays = mod("blender.extract"), mod("core.geometry.camera")
    cam = extract.render_camera(bpy.context.evaluated_depsgraph_get(), size, size)
    origins, dirs = camera_rays.pixel_rays(cam.view_proj, size, size)
    t = -origins[..., 2] / np.where(np.abs(dirs[..., 2]) > 1e-12, dirs[..., 2], -1e-12)
    ground_hit = origins + t[..., None] * dirs
    inner = REF_FIELD / 2 - 0.45 * REF_TILE
    mask = (t > 0) & (np.abs(ground_hit[..., 0]) < inner) & (np.abs(ground_hit[..., 1]) < inner)
    print(f"[grass reference] {mask.mean():.1%} of the image sees the field", flush=True)
    rows = []

    def cycles(spp):
        desc = {**description, "samples": spp}
        hit = cache.load(Path(args.cache), desc)
        if hit is None:
            print(f"[grass reference] Cycles {spp} spp ...", flush=True)
            with runner.engine_setup(scene, "CYCLES", **runner.cycles_options(spp, 16)):
                hit = runner.render_pixels(scene, size, size)
            cache.store(Path(args.cache), desc, *hit)
        return hit

    # Ours first, with the grass on the ground; then the blades as geometry for the others.
    ours = []
    for target in REF_COMPRESSION:
        arrays, meta = grass_btf.package(btf, spectra, gp.GrassParams(), 128, target, seconds)
        _store_btf(mod, g, arrays, meta, REF_TILE)
        img, sec = runner.warm_render(scene, size, size)
        ours.append((f"BTF {target:g}", img, sec, {"counts": list(meta["counts"]),
                                                    "MB": meta["storage"]["total"] / 2**20}))
    g.translucent.grass = False
    blades, n_blades, n_tris = blades_object(bpy, demo, patch, REF_FIELD, side,
                                             twins.leaf("Blade", patch.params.specular))
    scene.collection.objects.link(blades)
    ref, ref_sec = cycles(args.reference_samples)
    report.save_image_png(out / f"reference_cycles_{args.reference_samples}.png", ref)

    def measure(label, image, sec, **extra):
        row = {"label": label, "seconds": round(sec, 3), "rel_rmse": metrics.relative_rmse(image, ref, mask),
               "median": metrics.median_relative_error(image, ref, mask),
               "blocks8": metrics.block_relative_rmse(image, ref, mask, 8),
               "mean_ratio": float(image[..., :3][mask].mean() / ref[..., :3][mask].mean()),
               "field_pixels": float(mask.mean()), **extra}
        slug = "".join(c if c.isalnum() else "_" for c in label).lower()
        report.save_image_png(out / f"reference_{slug}.png", image)
        report.save_error_png(out / f"reference_{slug}_error.png", image, ref, mask)
        rows.append(row)
        print(f"[grass reference] {label}: relative RMSE {row['rel_rmse']:.3f}, 8x8 blocks {row['blocks8']:.3f}, "
              f"median {row['median']:.3f}, mean ratio {row['mean_ratio']:.3f}, {sec:.2f} s", flush=True)

    for label, img, sec, extra in ours:
        measure(label, img, sec, **extra)
    for i, spp in enumerate(args.eevee_samples):
        with runner.engine_setup(scene, "BLENDER_EEVEE", **runner.eevee_options(spp)):
            if i == 0:
                runner.warm_eevee(scene, size, size)
            img, sec = runner.render_pixels(scene, size, size)
        measure(f"EEVEE {spp}", img, sec, triangles=n_tris)
    for spp in args.cycles_samples:
        img, sec = cycles(spp)
        measure(f"Cycles {spp}", img, sec, triangles=n_tris)
    measure(f"Cycles {args.reference_samples} (reference)", ref, ref_sec, blades=n_blades, triangles=n_tris)
    return rows


def chart(comp: dict, unsampled: list, scenes: dict, reference: list, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4 if reference else 3, figsize=(20 if reference else 15, 4.2))
    curves = np.array(comp["curves"])
    n = np.arange(curves.shape[1])
    for c, name in enumerate(("Y", "Cb", "Cr")):
        axes[0].plot(n, curves[c], label=name)
    axes[0].plot(n, np.sqrt((curves ** 2).sum(0)), "k--", label="total")
    pts = [r for r in comp["counts"] if "rgb_error_blades" in r]
    axes[0].scatter([r["Y"] for r in pts], [r["rgb_error_blades"] for r in pts], c="r", zorder=5,
                    label="RGB error, blade pixels (Y count)")
    axes[0].set_xlabel("eigen-textures kept")
    axes[0].set_ylabel("relative error")
    axes[0].set_title("Compression (81 x 21 images, 128^2)")
    axes[0].legend(fontsize=8)
    axes[1].plot([r["MB"] for r in pts], [r["rgb_error_blades"] for r in pts], "o-")
    for r in pts:
        axes[1].annotate(f"{r['Y']}/{r['chroma']}", (r["MB"], r["rgb_error_blades"]), fontsize=8)
    axes[1].axvline(comp["uncompressed_MB"], color="gray", ls=":", label="uncompressed (half floats)")
    axes[1].set_xscale("log")
    axes[1].set_xlabel("storage, MB")
    axes[1].set_ylabel("RGB error, blade pixels")
    axes[1].legend(fontsize=8)
    ours = scenes.get("ours", [])
    ee = scenes.get("eevee_geometry", [])
    for lod in (0.0, 1.0):
        pts = [r for r in ours if r["lod"] == lod]
        axes[2].plot([r["blades"] for r in pts], [r["seconds"] for r in pts], "o-",
                     label=f"BTF layer ({'fewer eigen-textures far' if lod else 'all eigen-textures'})")
    axes[2].plot([r["blades"] for r in ee], [r["seconds"] for r in ee], "s-", label="EEVEE 16, blades as geometry")
    axes[2].set_xscale("log")
    axes[2].set_yscale("log")
    axes[2].set_xlabel("blades in the field")
    axes[2].set_ylabel("seconds per frame (llvmpipe, 256^2)")
    axes[2].legend(fontsize=8)
    if reference:
        ax = axes[3]
        for fam, mk in (("BTF", "o"), ("EEVEE", "s"), ("Cycles", "^")):
            rs = sorted((r for r in reference if r["label"].startswith(fam) and "reference" not in r["label"]),
                        key=lambda r: r["seconds"])
            for key, ls in (("rel_rmse", "-"), ("blocks8", "--")):
                ax.plot([r["seconds"] for r in rs], [r[key] for r in rs], marker=mk, ls=ls,
                        label=f"{fam}, {'per pixel' if key == 'rel_rmse' else '8x8 blocks'}")
            for r in rs:
                ax.annotate(r["label"].split()[1], (r["seconds"], r["rel_rmse"]), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
        ax.set_xscale("log")
        ax.set_xlabel("seconds per frame (llvmpipe, 256^2)")
        ax.set_ylabel("relative RMSE against Cycles (blades as geometry)")
        ax.set_title("The field against Cycles")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "chart.png", dpi=90)
    plt.close(fig)


def summary(comp, unsampled, scenes, reference, bake_meta, args) -> str:
    lines = ["# Grass BTF (Shah ch. 4)", "",
             "Machine: 2-core AMD EPYC, Mesa llvmpipe (no GPU), bpy 5.0.1. Patch: 500 blades per tile, "
             "blade height 0.45 tile, 81 views x 21 lights at 128 x 128, our moderngl rasteriser (direct light, "
             "leaf transmission, shadows between blades).", "",
             f"Acquisition {comp['acquisition_s']:.1f} s; SVD of the three channels {comp['svd_s']:.1f} s; "
             f"uncompressed {comp['uncompressed_MB']:.0f} MB (half floats).", "",
             "## Error against eigen-textures kept", "",
             "| Y | chroma | SVD error (all pixels) | RGB error over blade pixels (60 images) | MB |",
             "|---|---|---|---|---|"]
    for r in comp["counts"]:
        if "rgb_error_blades" in r:
            lines.append(f"| {r['Y']} | {r['chroma']} | {r['svd_error']:.3f} | {r['rgb_error_blades']:.3f} | "
                         f"{r['MB']:.1f} |")
    lines += ["", "Counts chosen for a target error (greedy, error removed per eigen-texture stored):", ""]
    for r in comp["counts"]:
        if "target" in r:
            lines.append(f"- target {r['target']}: {r['Y']} Y, {r['chroma']} chroma (error {r['svd_error']:.3f})")
    lines += ["", "## Unsampled view and light pairs (direct render vs per-pixel reconstruction)", "",
              "| theta_v | theta_l | interpolation only | with default compression | 8x8 block means | mean brightness "
              "| gaps agree |",
              "|---|---|---|---|---|---|---|"]
    for r in unsampled:
        lines.append(f"| {r['theta_v']:.0f} | {r['theta_l']:.0f} | {r['interpolation_error']:.3f} | "
                     f"{r['compressed_error']:.3f} | {r['blocks8_error']:.3f} | {r['mean_error']:.3f} | "
                     f"{r['gap_agreement']:.3f} |")
    med = lambda k: float(np.median([r[k] for r in unsampled]))  # noqa: E731
    lines += ["", f"Medians: interpolation {med('interpolation_error'):.3f}, with compression "
                  f"{med('compressed_error'):.3f}, 8x8 block means {med('blocks8_error'):.3f}, "
                  f"mean brightness {med('mean_error'):.3f}, gaps agree "
                  f"{med('gap_agreement'):.3f}.", "", "## Frame time against blade density (256 x 256)", "",
              "| equivalent blades | tile | fewer eigen-textures far | s/frame |", "|---|---|---|---|"]
    for r in scenes.get("ours", []):
        lines.append(f"| {r['blades']:.0e} | {r['tile_m']:.3f} m | {'yes' if r['lod'] else 'no'} | "
                     f"{r['seconds']:.2f} |")
    lines += ["", "| EEVEE 16, blades as geometry | triangles | s/frame |", "|---|---|---|"]
    for r in scenes.get("eevee_geometry", []):
        lines.append(f"| {r['blades']:.0e} | {r['triangles']:,} | {r['seconds']:.2f} |")
    if reference:
        ref = next(r for r in reference if "reference" in r["label"])
        lines += ["", f"## The field against Cycles {args.reference_samples} spp (blades as geometry)", "",
                  f"{REF_FIELD} m of ground under {REF_TILE} m tiles: {ref['blades']:,} blades, {ref['triangles']:,} "
                  "triangles as geometry with the leaf twin of the acquisition's shading (Cycles adds the light "
                  "bouncing between blades and their shadows on the soil). Errors over the pixels that see the field "
                  f"({100 * ref['field_pixels']:.0f} % of the image): per pixel, median, and of 8 x 8 block means; the "
                  "mean brightness against the reference.", "",
                  "| renderer | s/frame | relative RMSE | 8x8 blocks | median | mean ratio "
                  "| eigen-textures (Y, chroma) | MB |",
                  "|---|---|---|---|---|---|---|---|"]
        for r in reference:
            counts = f"{r['counts'][0]}, {r['counts'][1]}" if "counts" in r else ""
            mb = f"{r['MB']:.1f}" if "MB" in r else ""
            lines.append(f"| {r['label']} | {r['seconds']:.2f} | {r['rel_rmse']:.3f} | {r['blocks8']:.3f} | "
                         f"{r['median']:.3f} | {r['mean_ratio']:.3f} | {counts} | {mb} |")
    lines += ["", f"Default bake (target error 0.5): {bake_meta['counts'][0]} Y + 2 x {bake_meta['counts'][1]} "
                  f"chroma eigen-textures, {bake_meta['storage']['total'] / 2**20:.1f} MB, "
                  f"{bake_meta['bake_s']:.0f} s.",
              "", "Images: coefficients_fig4_5.png (4, 40, 140 Y and the render), sunk_ball.png, hill_crest.png, "
                  "field_*.png, eevee_geometry_*.png, reference_*.png (the field against Cycles, with error images)."]
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", default=str(ROOT / "bench" / "results" / "grass"))
    parser.add_argument("--cache", default=str(ROOT / "bench" / "cache"))
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--reference-samples", type=int, default=512)
    parser.add_argument("--eevee-samples", nargs="*", type=int, default=[4, 16])
    parser.add_argument("--cycles-samples", nargs="*", type=int, default=[16, 64])
    parser.add_argument("--only-reference", action="store_true",
                        help="acquire and compress, then only the field against Cycles; the other phases' "
                             "results are kept from the last run")
    args = parser.parse_args()
    package = blender_env.start()
    import importlib

    import bpy

    def mod(name):
        return importlib.import_module(f"{package}.translucent_addon.{name}")

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    previous = json.loads((out / "results.json").read_text()) if (out / "results.json").exists() else {}
    t0 = time.perf_counter()
    comp, btf, spectra = compression_phase(mod, out)
    unsampled = previous.get("unsampled", []) if args.only_reference else unsampled_phase(mod, btf, spectra)
    grass_btf, gp = mod("techniques.grass.bake"), mod("techniques.grass.patch")
    bake_s = comp["acquisition_s"] + comp["svd_s"]
    arrays, meta = grass_btf.package(btf, spectra, gp.GrassParams(), 128, 0.5, bake_s)
    reference = reference_phase(bpy, mod, btf, spectra, bake_s, out, args.size, args)
    del btf, spectra
    scenes = previous.get("scenes", {}) if args.only_reference else scenes_phase(bpy, mod, arrays, meta, out, args.size)
    (out / "results.json").write_text(json.dumps({"compression": comp, "unsampled": unsampled, "scenes": scenes,
                                                  "reference": reference, "bake": meta}, indent=2, default=float))
    chart(comp, unsampled, scenes, reference, out)
    (out / "summary.md").write_text(summary(comp, unsampled, scenes, reference, meta, args))
    print(f"wrote {out / 'summary.md'} in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

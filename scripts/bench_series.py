"""The benchmark's series against the CPU dipole model (``make bench``): IMAGE_SPACE at several splat overlaps and
TEXTURE_SPACE at several atlas settings, each against the model (their discretisation error apart from the model's).

Run inside Blender with the extension installed (``bench.py``); ``runner`` is its ``compare_runner``.
"""
from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np

SPACING_TEXELS = 3.5  # the default proxy spacing (techniques/texture_space/proxy.py)


def error_against_samples_chart(runner, rows, path, title) -> None:
    """The extension's chart of error against samples (its report module, beside the runner)."""
    report = importlib.import_module(runner.__name__.replace("blender.compare_runner", "core.report.report"))
    report.error_against_samples_chart(rows, path, title)


def texture_space_setting(item) -> tuple[int, float]:
    """(atlas texels, proxy spacing in texels) from an atlas resolution or such a pair."""
    res, spacing = (item, SPACING_TEXELS) if np.ndim(item) == 0 else item
    return int(res), float(spacing)


def texture_space_label(res: int, spacing: float) -> str:
    return f"{res} texels" + ("" if spacing == SPACING_TEXELS else f", spacing {spacing:g}")


def texture_space_series(runner, scene, objects, settings, width: int, height: int, progress=print):
    """TEXTURE_SPACE at each setting (an atlas resolution, or a pair of it and the proxy spacing): yields
    ((resolution, spacing), product, bake seconds, bake metas, image, seconds).

    Every setting is drawn with the GPU product; the first also with the CPU one (scipy.sparse).
    The objects' method, resolution and spacing are restored afterwards.
    """
    for i, item in enumerate(settings):
        res, spacing = texture_space_setting(item)
        with runner.method_applied(objects, "TEXTURE_SPACE", atlas_resolution=res, proxy_spacing=spacing):
            bake_seconds, metas = runner.bake_objects(objects, "TEXTURE_SPACE", progress)
            for product in ("GPU", "CPU") if i == 0 else ("GPU",):
                with runner.engine_setup(scene, "TRANSLUCENT_RT", translucent_texture_product=product):
                    progress(f"Translucent (TEXTURE_SPACE) {texture_space_label(res, spacing)}, {product} product ...")
                    runner.render_pixels(scene, width, height)  # first frame uploads the bake to the GPU
                    img, sec = runner.render_pixels(scene, width, height)
                yield (res, spacing), product, bake_seconds, metas, img, sec


def discretisation(runner, scene, objects, output_dir, overlaps=(4.0, 8.0, 16.0, 32.0, 48.0), samples: int = 200_000,
                   cache_dir=None, progress=print):
    """Our engine at several splat overlaps against the CPU dipole model: error against splat count.

    Measures the discretisation error of the GPU method apart from the dipole's model error, at the
    scene's resolution; returns rows (overlap, light-view samples, seconds, rel. RMSE) and writes
    discretisation.json and discretisation.png into output_dir.
    """
    import json

    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    width, height, mask, model_image, model_seconds = runner.model_setup(scene, objects, samples,
                                                                         cache_dir or out / "cache", progress)
    rows = []
    for k in overlaps:
        grid = 2048 if k > 32 else 1024
        with runner.engine_setup(scene, "TRANSLUCENT_RT", translucent_splat_overlap=k, translucent_splat_max_grid=grid,
                          translucent_capture_passes=True):
            progress(f"IMAGE_SPACE k={k} ...")
            img, sec = runner.render_pixels(scene, width, height)
        plan = runner.current_session().capture.get("plan")
        count = int(sum(s.sample_count for s in plan.samplings)) if plan else 0
        lit = sum(int((pid[..., 3] > 0.5).sum()) for pid, _ in runner.current_session().capture.get("samples", []))
        rows.append({"overlap": k, "light_view_texels": count, "object_samples": lit, "seconds": sec,
                     "rel_rmse_vs_model": runner.relative_rmse(img, model_image, mask)})
        runner.save_error_png(out / f"image_space_k{int(k)}_vs_model_error.png", img, model_image, mask)
        runner.save_image_png(out / f"image_space_k{int(k)}.png", img)
    runner.save_image_png(out / "dipole_model.png", model_image)
    runner.current_session().capture.clear()
    (out / "discretisation.json").write_text(json.dumps({"size": [width, height], "model_samples": samples,
                                                          "model_seconds": model_seconds, "rows": rows}, indent=2))
    error_against_samples_chart(runner, rows, out / "discretisation.png", f"{scene.name}: IMAGE_SPACE against the "
                                           f"dipole model ({width}x{height})")
    return rows


def texture_space_discretisation(runner, scene, objects, output_dir, resolutions=(256, 512), samples: int = 200_000,
                                 cache_dir=None, progress=print, name: str = "texture_space"):
    """TEXTURE_SPACE at several atlas resolutions (or (resolution, proxy spacing) pairs) against the CPU
    dipole model (its discretisation error).

    Returns rows (atlas, spacing, proxy vertices, bake seconds, frame seconds, rel. RMSE, mean ratio) and
    writes <name>.json and the images into output_dir.
    """
    import json

    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    width, height, mask, model_image, model_seconds = runner.model_setup(scene, objects, samples,
                                                                         cache_dir or out / "cache", progress)
    rows = []
    series = texture_space_series(runner, scene, objects, resolutions, width, height, progress)
    for (res, spacing), product, bake_seconds, metas, img, sec in series:
        if product != "GPU":
            continue
        meta = metas[0]
        ratio = img[mask][:, :3].sum(axis=0) / np.maximum(model_image[mask][:, :3].sum(axis=0), 1e-30)
        rows.append({"atlas": res, "proxy_spacing": spacing, "proxy_vertices": meta.get("proxy_vertices"),
                     "texel_mm": meta.get("texel_mm"),
                     "form_factors": meta.get("form_factors"), "bake_seconds": round(bake_seconds, 2),
                     "seconds": sec, "rel_rmse_vs_model": runner.relative_rmse(img, model_image, mask),
                     "mean_ratio_rgb": [round(float(x), 4) for x in ratio]})
        tag = f"{res}" if spacing == SPACING_TEXELS else f"{res}_s{spacing:g}"
        runner.save_error_png(out / f"{name}_{tag}_vs_model_error.png", img, model_image, mask)
        runner.save_image_png(out / f"{name}_{tag}.png", img)
        progress(f"TEXTURE_SPACE {texture_space_label(res, spacing)}: rel. RMSE against the dipole model "
                 f"{rows[-1]['rel_rmse_vs_model']:.4f}")
    runner.save_image_png(out / "dipole_model.png", model_image)
    (out / f"{name}.json").write_text(json.dumps({"size": [width, height], "model_samples": samples,
                                                  "model_seconds": model_seconds, "rows": rows}, indent=2))
    return rows



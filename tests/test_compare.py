"""translucent.compare_cycles end to end on a small scene: files, numbers, cache, reproducibility."""
from __future__ import annotations

import json
import math

import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import add_camera, add_light, add_plane, set_world  # noqa: E402
from conftest import ext_module  # noqa: E402


def _scene(tr, scene):
    set_world(scene, (0.05, 0.05, 0.06))
    add_plane(scene, size=0.6)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=0.05, location=(0, 0, 0.05))
    ob = bpy.context.active_object
    ob.name = "Ball"
    ob.translucent.preset = "skin1"
    ob.translucent.method = "IMAGE_SPACE"
    add_light(scene, "POINT", (0.15, 0.25, 0.3), (0, 0, 0.05), energy=20.0, shadow_soft_size=0.01)
    add_camera(scene, (0.0, -0.4, 0.2), (0, 0, 0.04), lens=50)
    scene.render.resolution_x, scene.render.resolution_y = 48, 36
    return ob


def test_compare_writes_report_images_chart_and_reproduces_from_cache(tr, scene, tmp_path):
    _scene(tr, scene)
    runner = ext_module(tr, "translucent_addon.blender.compare_runner")
    settings = runner.CompareSettings(series={"IMAGE_SPACE": (8.0,)},
                                      cycles_random_walk_samples=(4,),
                                      cycles_brute_force_samples=(8,), eevee_samples=(1,), reference_samples=64,
                                      brute_force_reference_samples=32, model_reference_samples=5000)
    entries, meta = runner.run(scene, tmp_path / "a", settings, progress=lambda s: None)
    report = json.loads((tmp_path / "a" / "report.json").read_text())
    engines = {r["engine"] for r in report["renders"]}
    assert engines == {"CYCLES", "BLENDER_EEVEE", "TRANSLUCENT_RT", "CPU_DIPOLE_MODEL"}
    assert meta["mask_pixels"] > 50
    for r in report["renders"]:
        assert (tmp_path / "a" / r["image"]).exists()
        assert r["seconds"] > 0
        if r["reference"] != "itself":
            assert math.isfinite(r["rel_rmse"]) and r["rel_rmse"] > 0
            assert -1 <= r["ssim"] <= 1
            assert (tmp_path / "a" / r["error_image"]).exists()
    assert (tmp_path / "a" / "chart.png").stat().st_size > 10_000
    # The reference's own noise (its two independent halves), beside every error: the 4 spp random walk is well
    # above it, and an entry is flagged exactly when its error is not.
    noise = report["meta"]["reference_noise"]
    assert 0 < noise["rel_rmse"] < 0.2 and 0 < noise["median_rel_error"] < 0.2
    for r in report["renders"]:
        if r["reference"] != "itself":
            assert r["below_reference_noise"] == (r["rel_rmse"] <= noise["rel_rmse"])
    by_series = {r["series"]: r for r in report["renders"]}
    # More samples, less error: the 4 spp random walk is noisier than the 64 spp reference of itself.
    assert by_series["Cycles random walk"]["rel_rmse"] > 0.02
    # Our IMAGE_SPACE is measured against the dipole model too (its discretisation error).
    ours = by_series["Translucent (IMAGE_SPACE)"]
    assert ours["rel_rmse_model"] is not None and ours["rel_rmse_model"] < 0.1

    # Again into another folder with the same cache: references come from the cache, numbers repeat.
    settings.cache_dir = str(tmp_path / "a" / "cache")
    entries2, _ = runner.run(scene, tmp_path / "b", settings, progress=lambda s: None)
    first = {(e.series, e.settings["label"]): e for e in entries}
    for e in entries2:
        e1 = first[(e.series, e.settings["label"])]
        if e.engine == "CYCLES":
            assert e.cached and e.seconds == e1.seconds
        if e.rel_rmse is not None and e.engine != "BLENDER_EEVEE":
            assert e.rel_rmse == pytest.approx(e1.rel_rmse, rel=1e-6), e.series


def test_compare_operator_bad_input(tr, scene, tmp_path):
    add_camera(scene, (0, -1, 0), (0, 0, 0))
    with pytest.raises(RuntimeError, match="no visible object has a translucency method"):
        bpy.ops.translucent.compare_cycles(output_dir=str(tmp_path), quick=True)
    scene.camera = None
    with pytest.raises(RuntimeError, match="no active camera"):
        bpy.ops.translucent.compare_cycles(output_dir=str(tmp_path), quick=True)


def test_compare_steps_report_progress_and_stop_cleanly(tr, scene, tmp_path):
    """The comparison as steps (what the modal operator drives): one step per render with rising
    fractions ending at 1; stopped after a step (Esc), the scene keeps its engine and materials."""
    ob = _scene(tr, scene)
    runner = ext_module(tr, "translucent_addon.blender.compare_runner")
    settings = runner.CompareSettings(series={"IMAGE_SPACE": (8.0,)},
                                      cycles_random_walk_samples=(2,), cycles_brute_force_samples=(),
                                      eevee_samples=(), reference_samples=4, brute_force_reference_samples=0,
                                      model_reference_samples=0)
    job = runner.run_steps(scene, tmp_path / "a", settings)
    fractions = []
    while True:
        try:
            fractions.append(next(job)[0])
        except StopIteration as done:
            entries, _ = done.value
            break
    # The reference's two halves, 2 spp, ours, the report.
    assert len(fractions) == 5 and fractions == sorted(fractions) and fractions[-1] == 1.0
    assert len(entries) == 3
    engine, materials = scene.render.engine, [s.material for s in ob.material_slots]
    job = runner.run_steps(scene, tmp_path / "b", settings)
    next(job)
    job.close()
    assert scene.render.engine == engine and [s.material for s in ob.material_slots] == materials


def test_a_glass_object_s_comparison_leaves_out_the_dipole_model(tr, scene, tmp_path):
    """The CPU dipole model draws light diffusing below the surface, not refraction: on a GEOCUBE (glass) object it
    cost 120 s of a quick comparison and drew nothing the method does. Left out there; kept where a method it models
    is drawn (the first test)."""
    ob = _scene(tr, scene)
    ob.translucent.method = "GEOCUBE"
    ob.translucent.geocube_resolution = 16
    runner = ext_module(tr, "translucent_addon.blender.compare_runner")
    settings = runner.CompareSettings(cycles_random_walk_samples=(), cycles_brute_force_samples=(), eevee_samples=(),
                                      reference_samples=4, brute_force_reference_samples=0,
                                      model_reference_samples=5000)
    job = runner.run_steps(scene, tmp_path, settings)
    steps = []
    while True:
        try:
            steps.append(next(job))
        except StopIteration as done:
            entries, _ = done.value
            break
    assert {e.engine for e in entries} == {"CYCLES", "TRANSLUCENT_RT"}
    assert [e.series for e in entries if e.engine == "TRANSLUCENT_RT"] == ["Translucent (GEOCUBE)"]  # its own only
    assert not any("dipole model" in text for _, text in steps) and steps[-1][0] == 1.0


def test_compare_quadgraph_and_auto_series_restore_the_object(tr, scene, tmp_path):
    ball = _scene(tr, scene)
    ball.translucent.atlas_resolution = 384
    overlap = scene.translucent.splat_overlap
    runner = ext_module(tr, "translucent_addon.blender.compare_runner")
    settings = runner.CompareSettings(series={"IMAGE_SPACE": (), "QUADGRAPH": (2.0,)}, cycles_random_walk_samples=(),
                                      cycles_brute_force_samples=(),
                                      eevee_samples=(), reference_samples=16, brute_force_reference_samples=0,
                                      model_reference_samples=0, auto_targets=(0.1,),
                                      auto_methods=("IMAGE_SPACE", "TEXTURE_SPACE"))
    entries, _ = runner.run(scene, tmp_path, settings, progress=lambda s: None)
    by_series = {e.series: e for e in entries}
    assert set(by_series) == {"Cycles random walk (reference)", "Translucent (QUADGRAPH)",
                              "Translucent Auto (IMAGE_SPACE)", "Translucent Auto (TEXTURE_SPACE)"}
    assert by_series["Translucent (QUADGRAPH)"].settings["bake_seconds"] > 0
    auto_ts = by_series["Translucent Auto (TEXTURE_SPACE)"]
    assert "atlas_resolution" in auto_ts.settings["choice"] and auto_ts.settings["bake_seconds"] > 0
    assert "splat_overlap" in by_series["Translucent Auto (IMAGE_SPACE)"].settings["choice"]
    for e in entries[1:]:
        assert math.isfinite(e.rel_rmse) and e.rel_rmse < 1.0, e.series  # lit, not black
    # The object and the scene as they were.
    assert ball.translucent.method == "IMAGE_SPACE" and ball.translucent.quality == "MANUAL"
    assert ball.translucent.atlas_resolution == 384 and ball.translucent.auto_summary == ""
    assert scene.translucent.splat_overlap == overlap


def test_the_dialog_says_how_long_each_comparison_takes_and_an_unsaved_file_reports_elsewhere(tr, scene):
    """Quick could not be chosen from the UI (the button ran the full set: hours at 640x480), and an unsaved file
    wrote its report into the working directory."""
    import os
    import tempfile

    _scene(tr, scene)
    runner = ext_module(tr, "translucent_addon.blender.compare_runner")
    quick = runner.expected_seconds(scene, runner.CompareSettings.quick_settings())
    full = runner.expected_seconds(scene, runner.CompareSettings())
    overhead, per_sample = runner.cycles_rate(scene)
    print(f"expected here: quick {quick:.0f} s, full {full:.0f} s (Cycles {overhead:.2f} s + {per_sample:.4f} s/spp)")
    assert 0 < quick < full and per_sample > 0
    quick_samples = runner.CompareSettings.quick_settings().cycles_pixel_samples()
    assert runner.CompareSettings().cycles_pixel_samples() > 10 * quick_samples
    operator = __import__(tr.__name__ + ".operators.compare", fromlist=["x"])
    assert not bpy.data.filepath
    folder = operator._output_folder(bpy.context, "//translucent_compare")
    assert not folder.startswith(os.getcwd()) and folder.startswith(tempfile.gettempdir())
    assert folder.endswith(os.path.join("translucent", "translucent_compare"))

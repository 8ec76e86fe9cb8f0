"""The README's five-minute tutorial, step by step, as an artist would click it (operators and
properties only): demo bunny, preset, real size, bake, move the light, paint blur, compare."""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import render  # noqa: E402
from conftest import ext_module  # noqa: E402


def test_five_minute_tutorial(tr, scene, tmp_path):
    presets = ext_module(tr, "translucent_addon.core.physics.presets")
    inputs = ext_module(tr, "translucent_addon.blender.bake_inputs")
    # 1. Scene: Add Demo Scene.
    assert bpy.ops.translucent.add_demo_scene(kind="BUNNY") == {"FINISHED"}
    scene = bpy.context.scene
    bunny = scene.objects["Bunny"]
    key = scene.objects["Key Light"]
    bpy.context.view_layer.objects.active = bunny
    # 2. Material and size: the Skin1 preset, a 5 cm bunny.
    bunny.translucent.preset = "skin1"
    assert tuple(bunny.translucent.sigma_s_prime) == pytest.approx(presets.load_presets()["skin1"].sigma_s_prime)
    assert bpy.ops.translucent.set_physical_size(size=0.05) == {"FINISHED"}
    assert max(bunny.dimensions) * bunny.translucent.mm_per_unit == pytest.approx(50.0, rel=1e-5)
    # 3. Bake TEXTURE_SPACE (draft quality keeps the test short).
    assert bpy.ops.translucent.apply_quality(tier="DRAFT") == {"FINISHED"}
    bunny.translucent.method = "TEXTURE_SPACE"
    assert bpy.ops.translucent.bake() == {"FINISHED"}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    assert inputs.bake_status(bunny.evaluated_get(depsgraph), "TEXTURE_SPACE") == "OK"
    before = render(scene, 64, 48)
    assert np.isfinite(before).all() and before[..., :3].max() > 0.05
    # 4. Move the light: a new image, no new bake needed.
    key.location.x += 0.3
    moved = render(scene, 64, 48)
    assert np.abs(moved - before)[..., :3].max() > 0.01
    assert inputs.bake_status(bunny.evaluated_get(bpy.context.evaluated_depsgraph_get()), "TEXTURE_SPACE") == "OK"
    # 5. Paint blur on the ears (IMAGE_SPACE): the painted region changes the image.
    bunny.translucent.method = "IMAGE_SPACE"
    plain = render(scene, 64, 48)
    assert bpy.ops.translucent.add_paint_layer(layer="translucent_blur", enter_paint_mode=False) == {"FINISHED"}
    group = bunny.vertex_groups["translucent_blur"]
    co = np.empty(len(bunny.data.vertices) * 3, np.float32)
    bunny.data.vertices.foreach_get("co", co)
    up = co.reshape(-1, 3)[:, 1]  # the bundled meshes are Y-up (the object is turned to Z-up)
    ears = np.nonzero(up > np.percentile(up, 85))[0].tolist()
    group.add(ears, 1.0, "REPLACE")
    painted = render(scene, 64, 48)
    assert np.abs(painted - plain)[..., :3].max() > 1e-3
    # 6. Compare with Cycles (quick): the report and the chart.
    scene.render.resolution_x, scene.render.resolution_y = 48, 36
    assert bpy.ops.translucent.compare_cycles(output_dir=str(tmp_path), quick=True) == {"FINISHED"}
    assert (tmp_path / "report.json").exists() and (tmp_path / "chart.png").stat().st_size > 10_000

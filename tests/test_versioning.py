"""A file saved before the move to layers (the 0.1.0 layout: one flat property group, methods in
``render/methods``) opens with every setting as it was saved: the property names and the method numbers
are kept; its millimetres become the scattering scale and scene units on opening (``versioning``).
``data/translucent_0_1_0.blend`` was saved by that code (commit cade8a3) with settings away from their
defaults."""
from __future__ import annotations

import importlib
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")

FILE = Path(__file__).parent / "data" / "translucent_0_1_0.blend"


def test_a_file_saved_by_0_1_0_keeps_every_setting(installed):
    bpy.ops.wm.open_mainfile(filepath=str(FILE))
    ob = bpy.data.objects["Cube"]
    s = ob.translucent
    assert s.method == "QUADGRAPH" and s.preset == "skin1"
    assert s.mm_per_unit == pytest.approx(2.0) and s.quadgraph_K == pytest.approx(0.5)
    assert s.scattering_scale == pytest.approx(500.0)  # 2 mm per unit: scatters 500 times as far as in metres
    assert s.veins_scale * s.mm_per_unit == pytest.approx(20.0)  # 20 mm (0.1's default), now in scene units
    assert s.veins == pytest.approx(0.3) and s.atlas_resolution == 384 and s.geocube_steps == 20
    assert s.caustics_caster == "REFRACTIVE" and s.caustics_ior == pytest.approx(1.45)
    assert s.grass_blades == 321 and s.grass_resolution == "64"
    assert s.relief == "INTERVAL" and s.relief_depth == pytest.approx(0.02)
    t = bpy.context.scene.translucent
    assert t.splat_overlap == pytest.approx(12.0) and t.texture_product == "CPU"
    assert t.quadgraph_iterations == 777 and t.caustics_grid == 96 and t.temporal_coherence
    assert bpy.data.lights["Lamp"].translucent.caustics is False
    bpy.ops.wm.read_homefile(use_empty=True)


def test_a_file_written_without_the_save_handler_is_not_taken_for_0_1(installed, tmp_path):
    """Autosave and quit.blend are written without save_pre: the stamp made on opening must already be there,
    or the file would reopen as 0.1's and have its lengths divided again."""
    versioning = importlib.import_module(f"{installed}.translucent_addon.blender.versioning")
    bpy.ops.wm.read_homefile(use_empty=True)
    assert bpy.context.scene.translucent.file_version == versioning.FILE_VERSION  # stamped on opening
    assert not bpy.data.is_dirty, "stamping on opening must not mark a file just opened as changed"
    mesh = bpy.data.meshes.new("Plate")
    ob = bpy.data.objects.new("Plate", mesh)
    bpy.context.scene.collection.objects.link(ob)
    ob.translucent.method = "IMAGE_SPACE"
    ob.translucent.scattering_scale = 2.0
    ob.translucent.veins_scale = 0.03
    path = tmp_path / "autosaved.blend"
    bpy.app.handlers.save_pre.remove(versioning.stamp)  # as autosave writes
    try:
        bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    finally:
        bpy.app.handlers.save_pre.append(versioning.stamp)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    s = bpy.data.objects["Plate"].translucent
    assert s.scattering_scale == pytest.approx(2.0) and s.veins_scale == pytest.approx(0.03)
    bpy.ops.wm.read_homefile(use_empty=True)

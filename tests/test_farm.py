"""Bakes that travel (issue 58): bake files that Blender's file tools and a farm's packer see, Bake All, Purge.

A bake keeps its arrays in an OpenEXR file referred to by an image data block (blender/bake_files.py), so the
Blender Asset Tracer's pack (``bat pack``, the farm managers' packer) carries it and *Pack Resources* packs it: the
packed copy, rendered from another folder in a fresh Blender with the original folder gone, draws the frame drawn
here. Bake All bakes exactly the objects whose bakes are missing or stale in one job, and from the command line
exits non-zero naming the object whose bake failed. Purge leaves one file per object.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import add_camera, add_light, add_plane, render  # noqa: E402
from conftest import ext_module  # noqa: E402

HERE = Path(__file__).resolve().parent
SIZE = 48
# Small settings: these tests are about where bakes live, not their accuracy.
SETTINGS = {"TEXTURE_SPACE": dict(atlas_resolution=64), "QUADGRAPH": dict(quadgraph_levels=1, quadgraph_K=0.5),
            "GEOCUBE": dict(geocube_resolution=16)}


def _ball(name, method, x, y=0.0):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.35, location=(x, y, 0.4))
    ob = bpy.context.object
    ob.name = name
    ob.translucent.method = method
    ob.translucent.mm_per_unit = 40.0
    for key, value in SETTINGS[method].items():
        setattr(ob.translucent, key, value)
    return ob


def _stage(scene):
    add_plane(scene, size=4.0)
    add_light(scene, "POINT", (1.5, -2.0, 2.5), energy=300.0)
    add_camera(scene, (0.0, -4.5, 2.2), (0.0, 0.0, 0.4), lens=40)


def _select(*objects):
    for o in bpy.context.view_layer.objects:
        o.select_set(o in objects)
    bpy.context.view_layer.objects.active = objects[0]


def _status(tr, ob):
    inputs = ext_module(tr, "translucent_addon.blender.bake_inputs")
    return inputs.bake_status(ob.evaluated_get(bpy.context.evaluated_depsgraph_get()))


def _record(tr, ob):
    """The object's bake record, where it is held (its mesh, or itself when it holds its own)."""
    holder = ext_module(tr, "translucent_addon.blender.bake_files").owner(ob, ob.translucent.method)
    return holder["translucent_bake"][ob.translucent.method]


def _child(*args, timeout=600):
    return subprocess.run([sys.executable, str(HERE / "farm_child.py"), str(HERE.parent / "scripts"), *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def _render_fresh(blend: Path, out: Path) -> np.ndarray:
    """The frame a fresh Blender process draws of ``blend`` (a lost object fails it)."""
    proc = _child("render", blend, out, SIZE)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return np.load(out)


def _forget_gpu_data(tr):
    ext_module(tr, "translucent_addon.gpu.bake_cache").clear()
    ext_module(tr, "translucent_addon.blender.session").current().final_pipeline = None


@pytest.fixture
def every_bake_in_a_file(tr, monkeypatch):
    """Bakes of any size in image files (small ones stay in the ID properties, and a QUADGRAPH bake's size varies
    with its tetrahedra): these tests are about the files."""
    monkeypatch.setattr(ext_module(tr, "translucent_addon.core.bake_store"), "SIDECAR_MIN_BYTES", 1024)


def test_bake_all_bakes_the_missing_and_stale_then_bat_and_pack_resources_carry_them(tr, scene, tmp_path, capfd,
                                                                                      every_bake_in_a_file):
    """Six objects of three methods: one baked and current, one baked and then made stale, four never baked. Bake
    All bakes exactly those five in one job. Then the farm: ``bat pack`` copies the .blend with its bake files; the
    copy renders in a fresh Blender from another folder, the original project gone, equal to the frame here
    (1e-5), no object lost. Then Pack Resources: the bake folder deleted, the frame is still equal; Unpack writes
    the files back."""
    _stage(scene)
    balls = [_ball(f"{method.title()}{i}", method, x=-1.2 + 0.8 * j + 0.4 * i, y=0.6 * i)
             for j, method in enumerate(SETTINGS) for i in range(2)]
    project = tmp_path / "project"
    project.mkdir()
    blend = project / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    current, stale = balls[2], balls[0]  # a QUADGRAPH ball baked and current, a TEXTURE_SPACE one made stale
    for ob in (current, stale):
        _select(ob)
        assert bpy.ops.translucent.bake() == {"FINISHED"}
    stale.translucent.mm_per_unit = 50.0
    before = {ob.name: _status(tr, ob) for ob in balls}
    assert sorted(before.values()) == ["MISSING"] * 4 + ["OK", "STALE"]
    kept = str(_record(tr, current)["data_hash"])
    capfd.readouterr()
    assert bpy.ops.translucent.bake_all() == {"FINISHED"}
    out = capfd.readouterr().out
    baked = sorted(line.split("'")[1] for line in out.splitlines() if line.startswith("Translucent Bake All: '")
                   and " baked in " in line)
    assert baked == sorted(ob.name for ob in balls if ob != current), out[-3000:]
    assert "Bake All: 5 of 5 object(s) baked" in out
    assert all(_status(tr, ob) == "OK" for ob in balls) and str(_record(tr, current)["data_hash"]) == kept
    held = {ob.name: (sorted(_record(tr, ob).keys()), _record(tr, ob)["meta"][:300]) for ob in balls}
    assert all("image" in _record(tr, ob) for ob in balls), (held, out[-4000:])
    assert all(_record(tr, ob)["image"].filepath.startswith("//scene_translucent/") for ob in balls)  # files, not IDs
    bpy.ops.wm.save_mainfile()
    paths = bpy.utils.blend_paths()
    assert all(_record(tr, ob)["image"].filepath in paths for ob in balls)  # what Blender's file tools list
    good = render(scene, SIZE, SIZE)
    assert np.isfinite(good).all() and good[..., :3].std() > 0.01

    farm = tmp_path / "farm"
    proc = subprocess.run([str(Path(sys.executable).with_name("bat")), "--", "pack", str(blend), str(farm)],
                          capture_output=True, text=True, timeout=300, env=dict(os.environ, VIRTUAL_ENV=sys.prefix))
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    shipped = sorted(p.name for p in (farm / "scene_translucent").iterdir())
    assert shipped == sorted({Path(_record(tr, ob)["image"].filepath).name for ob in balls})
    project.rename(tmp_path / "gone")  # the worker has only the pack
    try:
        elsewhere = tmp_path / "worker" / "job"
        shutil.copytree(farm, elsewhere)
        shipped_frame = _render_fresh(elsewhere / "scene.blend", tmp_path / "farm.npy")
        print(f"bat pack: max |difference| {np.abs(shipped_frame - good).max():.3g}")
        np.testing.assert_allclose(shipped_frame, good, atol=1e-5)
    finally:
        (tmp_path / "gone").rename(project)

    assert bpy.ops.file.pack_all() == {"FINISHED"}  # File > External Data > Pack Resources
    assert all(_record(tr, ob)["image"].packed_file is not None for ob in balls)
    bpy.ops.wm.save_mainfile()
    shutil.rmtree(project / "scene_translucent")
    packed_frame = _render_fresh(blend, tmp_path / "packed.npy")
    print(f"Pack Resources: max |difference| {np.abs(packed_frame - good).max():.3g}")
    np.testing.assert_allclose(packed_frame, good, atol=1e-6)
    _forget_gpu_data(tr)
    np.testing.assert_allclose(render(scene, SIZE, SIZE), good, atol=1e-6)
    assert bpy.ops.file.unpack_all(method="WRITE_ORIGINAL") == {"FINISHED"}
    assert all(_record(tr, ob)["image"].packed_file is None for ob in balls)
    assert set(shipped) <= {p.name for p in (project / "scene_translucent").glob("*.exr")}
    _forget_gpu_data(tr)
    np.testing.assert_allclose(render(scene, SIZE, SIZE), good, atol=1e-6)
    bpy.ops.wm.read_homefile(use_empty=True)


def test_bake_all_on_the_command_line_exits_non_zero_naming_the_object_that_failed(tr, scene, tmp_path):
    """The render node's command (README, *Render farms*): exit 0 with every bake made and saved; exit 1 and the
    failing object's name when one bake fails (a cube scaled to zero along an axis has no volume to bake)."""
    _stage(scene)
    _ball("Ball", "TEXTURE_SPACE", 0.0)
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(1.0, 0.0, 0.3))
    flat = bpy.context.object
    flat.name = "Flat"
    flat.translucent.method = "TEXTURE_SPACE"
    flat.scale = (1.0, 0.0, 1.0)
    blend = tmp_path / "node.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    proc = _child("bake_all", blend)
    assert proc.returncode == 1, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "'Flat': its scale is zero" in proc.stderr and "Bake All: 1 bake(s) failed" in proc.stderr
    flat.scale = (1.0, 1.0, 1.0)
    bpy.ops.wm.save_mainfile()
    proc = _child("bake_all", blend)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "Bake All: 2 of 2 object(s) baked" in proc.stdout
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    assert _status(tr, bpy.data.objects["Ball"]) == "OK" and _status(tr, bpy.data.objects["Flat"]) == "OK"
    bpy.ops.wm.read_homefile(use_empty=True)


def test_five_rebakes_then_purge_leave_one_file_per_object_and_saving_purges_older_leftovers(tr, scene, tmp_path,
                                                                                             capfd):
    """Every re-bake writes a file named by its hash; Purge removes those no object refers to and says how much it
    freed. Saving removes on its own only what nothing referred to in this session (Undo cannot need it). Then
    Blender's path tools handle the bake as a file: Make Paths Absolute and Relative, Find Missing Files."""
    _stage(scene)
    ball = _ball("Ball", "TEXTURE_SPACE", 0.0)
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    folder = tmp_path / "scene_translucent"
    _select(ball)
    for resolution in (64, 80, 96, 112, 128):
        ball.translucent.atlas_resolution = resolution
        assert bpy.ops.translucent.bake() == {"FINISHED"}
    bpy.ops.wm.save_mainfile()
    assert len(list(folder.glob("*.exr"))) == 5  # each was this session's: Undo may bring any back
    last = folder / Path(_record(tr, ball)["image"].filepath).name
    sizes = sum(p.stat().st_size for p in folder.glob("*.exr")) - last.stat().st_size
    capfd.readouterr()
    assert bpy.ops.translucent.purge_bakes() == {"FINISHED"}
    said = capfd.readouterr().out
    assert [p.name for p in folder.glob("*.exr")] == [Path(_record(tr, ball)["image"].filepath).name]
    assert f"4 unused bake file(s) deleted, {sizes / 2**20:.1f} MB freed" in said, said
    assert _status(tr, ball) == "OK"

    leftover = folder / ("0" * 32 + ".exr")  # left by an earlier session
    leftover.write_bytes(b"an old bake")
    (folder / "notes.txt").write_text("not a bake file: never touched")
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    bpy.ops.wm.save_mainfile()
    assert not leftover.exists() and (folder / "notes.txt").exists()
    assert "removed 1 bake file(s) no longer used" in capfd.readouterr().out
    session = ext_module(tr, "translucent_addon.blender.session").current()
    session.bake_files_seen = None  # as when the extension is enabled with a file open: Undo may reach any bake
    leftover.write_bytes(b"an old bake")
    bpy.ops.wm.save_mainfile()
    assert leftover.exists()
    leftover.unlink()
    ball = bpy.data.objects["Ball"]
    assert _status(tr, ball) == "OK"

    # Blender's own path tools: Make Paths Absolute / Relative, and Find Missing Files after the folder moved.
    image = _record(tr, ball)["image"]
    name = Path(image.filepath).name
    assert bpy.ops.file.make_paths_absolute() == {"FINISHED"} and image.filepath == str(folder / name)
    assert bpy.ops.file.make_paths_relative() == {"FINISHED"} and image.filepath == f"//scene_translucent/{name}"
    moved = tmp_path / "elsewhere"
    folder.rename(moved)
    assert bpy.ops.file.find_missing_files(directory=str(moved)) == {"FINISHED"}
    assert bpy.path.abspath(image.filepath) == str(moved / name)
    _forget_gpu_data(tr)
    assert _status(tr, ball) == "OK" and np.isfinite(render(bpy.context.scene, SIZE, SIZE)).all()
    bpy.ops.wm.read_homefile(use_empty=True)


def test_bakes_kept_in_npz_files_are_converted_once_on_opening(tr, scene, tmp_path, capfd):
    """A file from before image files: its bake's arrays in ``<hash>.npz`` named by a custom property. Opened, it
    is converted with one console line, draws the same frame, and its bake is then an image Blender's tools see."""
    bake_exr = ext_module(tr, "translucent_addon.core.bake_exr")
    _stage(scene)
    ball = _ball("Ball", "TEXTURE_SPACE", 0.0)
    blend = tmp_path / "old.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    _select(ball)
    assert bpy.ops.translucent.bake() == {"FINISHED"}
    good = render(scene, SIZE, SIZE)
    group = _record(tr, ball)
    exr = tmp_path / group["image"].filepath[2:]
    npz = exr.with_suffix(".npz")
    np.savez(npz, **bake_exr.read(exr))  # the earlier format: the stored arrays, a path string
    del group["image"]
    group["file"] = "//old_translucent/" + npz.name
    bpy.ops.wm.save_mainfile()
    exr.unlink()
    capfd.readouterr()
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    lines = [line for line in capfd.readouterr().out.splitlines() if "moved from .npz" in line]
    assert len(lines) == 1 and lines[0].startswith("Translucent: 1 bake(s) of this file moved from .npz")
    ball = bpy.data.objects["Ball"]
    group = _record(tr, ball)
    assert "file" not in group and group["image"].filepath == "//old_translucent/" + exr.name and exr.is_file()
    assert _status(tr, ball) == "OK"
    np.testing.assert_allclose(render(bpy.context.scene, SIZE, SIZE), good, atol=1e-6)
    bpy.ops.wm.save_mainfile()
    capfd.readouterr()
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    assert "moved from .npz" not in capfd.readouterr().out  # once
    bpy.ops.wm.read_homefile(use_empty=True)

"""The artist's workflow: the size helper, quality tiers and the preferences' default, last-frame
timings, a bake that fails inside a stage reporting one line and leaving the object as it was."""
from __future__ import annotations

import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import add_camera, add_cube, add_light, add_mesh, render, set_world  # noqa: E402
from conftest import ext_module  # noqa: E402


def _select(ob):
    bpy.context.view_layer.objects.active = ob
    ob.select_set(True)


def test_size_helper_sets_millimetres_per_unit(tr, scene):
    cube = add_cube(scene, size=2.0)
    _select(cube)
    assert bpy.ops.translucent.set_physical_size(size=0.05) == {"FINISHED"}
    assert cube.translucent.mm_per_unit == pytest.approx(25.0)
    assert cube.translucent.scattering_scale == pytest.approx(40.0)  # 2 m scatters as 5 cm
    # In a scene measured in centimetres the same real size gives the same millimetres per unit of the medium.
    scene.unit_settings.scale_length = 0.01
    assert cube.translucent.mm_per_unit == pytest.approx(0.25)
    assert bpy.ops.translucent.set_physical_size(size=5.0) == {"FINISHED"}  # 5 units: 5 cm
    assert cube.translucent.scattering_scale == pytest.approx(0.4)
    assert cube.translucent.mm_per_unit == pytest.approx(25.0)
    scene.unit_settings.scale_length = 1.0
    point = add_mesh(scene, "Point", [(0, 0, 0), (0, 0, 0), (0, 0, 0)], [(0, 1, 2)])
    _select(point)
    with pytest.raises(RuntimeError, match="'Point' has no extent"):
        bpy.ops.translucent.set_physical_size(size=0.01)


def test_quality_tiers_and_the_preferences_default(tr, scene):
    quality = ext_module(tr, "translucent_addon.core.quality")
    cube = add_cube(scene)
    _select(cube)
    assert bpy.ops.translucent.apply_quality(tier="DRAFT") == {"FINISHED"}
    assert scene.translucent.shadow_resolution == 512 and cube.translucent.atlas_resolution == 256
    assert bpy.ops.translucent.apply_quality(tier="HIGH") == {"FINISHED"}
    assert scene.translucent.caustics_grid == 256 and cube.translucent.quadgraph_K == pytest.approx(0.5)
    assert cube.translucent.proxy_spacing == pytest.approx(2.4)  # High refines TEXTURE_SPACE's proxy
    with pytest.raises(ValueError, match="unknown quality 'ULTRA'"):
        quality.apply(scene.translucent, quality.SCENE, "ULTRA")
    prefs = ext_module(tr, "translucent_addon.blender.preferences").get()
    assert prefs is not None and prefs.default_quality == "STANDARD"
    prefs.default_quality = "DRAFT"
    try:
        other = add_cube(scene, name="Other")
        other.translucent.method = "TEXTURE_SPACE"  # choosing a method applies the default quality
        assert other.translucent.atlas_resolution == 256
        assert bpy.ops.translucent.apply_quality() == {"FINISHED"}  # DEFAULT: the preferences' tier
        assert scene.translucent.shadow_resolution == 512
    finally:
        prefs.default_quality = "STANDARD"


def test_last_frame_timings_per_pass(tr, scene):
    set_world(scene, (0.1, 0.1, 0.1))
    add_cube(scene)
    add_light(scene, "SUN", (1, -1, 2), energy=2.0)
    add_camera(scene, (3, -3, 3), (0, 0, 0))
    render(scene, 32, 32)
    draw_handler = ext_module(tr, "translucent_addon.blender.draw_handler")
    t = dict(ext_module(tr, "translucent_addon.blender.session").current().timings)
    assert t["source"] == "F12" and t["total"] > 0 and {"world", "lights", "shadow_maps"} <= set(t)
    lines = draw_handler.timing_lines(t)
    assert lines[0].startswith("Translucent (F12): ") and lines[0].endswith(" ms")
    assert len(lines) == len([k for k in t if k not in {"total", "source"}]) + 1


def test_a_stage_failure_reports_one_line_and_changes_nothing(tr, scene):
    """A bake whose stage refuses the mesh (here: no volume for the tetrahedra) ends with one line and
    no bake stored; in batch mode the operator does not raise a traceback."""
    store = ext_module(tr, "translucent_addon.blender.bake_files")
    sheet = add_mesh(scene, "Sheet", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2, 3)])
    _select(sheet)
    sheet.translucent.method = "QUADGRAPH"
    with pytest.raises(RuntimeError) as err:
        bpy.ops.translucent.bake()
    message = str(err.value)
    assert "Traceback" not in message and "'Sheet'" in message and message.count("\n") <= 1, message
    assert store.read_meta(sheet, "QUADGRAPH") is None


def _settings(ob) -> dict:
    s = ob.translucent
    return {p.identifier: (tuple(v) if hasattr(v := getattr(s, p.identifier), "__len__") and not isinstance(v, str)
                           else v) for p in s.bl_rna.properties if not p.is_readonly}


def test_an_auto_bake_that_fails_leaves_every_setting_as_it_was(tr, scene):
    """Auto writes its resolutions before the bake reads them; a bake that then fails puts them back."""
    sheet = add_mesh(scene, "Sheet", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2, 3)])
    _select(sheet)
    sheet.translucent.method = "QUADGRAPH"
    sheet.translucent.quality = "AUTO"
    sheet.translucent.quadgraph_K = 0.77  # not what Auto would choose
    before = _settings(sheet)
    with pytest.raises(RuntimeError, match="'Sheet'"):
        bpy.ops.translucent.bake()
    assert _settings(sheet) == before
    # Choose Resolutions writes them (so the failing bake did have something to put back).
    assert bpy.ops.translucent.auto_quality() == {"FINISHED"}
    assert sheet.translucent.quadgraph_K != pytest.approx(0.77) and sheet.translucent.auto_summary
    # ... and what it chose is forgotten once the method or the target changes.
    sheet.translucent.target_error = 0.1
    assert sheet.translucent.auto_summary == ""


def test_choose_resolutions_for_every_auto_object_passes_over_those_with_nothing_to_choose(tr, scene):
    cubes = [add_cube(scene, size=0.05, location=(0.1 * i, 0, 0)) for i in range(3)]
    for cube, method in zip(cubes, ("TEXTURE_SPACE", "OFF", "QUADGRAPH")):
        cube.translucent.method = method
        cube.translucent.quality = "AUTO"
    _select(cubes[0])
    assert bpy.ops.translucent.auto_quality(all_objects=True) == {"FINISHED"}
    assert [bool(c.translucent.auto_summary) for c in cubes] == [True, False, True]


def test_user_presets_are_saved_listed_applied_and_removed(tr, scene):
    cube = add_cube(scene)
    _select(cube)
    s = cube.translucent
    s.sigma_a, s.sigma_s_prime, s.eta, s.g = (0.01, 0.02, 0.03), (1.0, 1.5, 2.0), 1.4, 0.1
    assert bpy.ops.translucent.save_preset(name="Wax test") == {"FINISHED"}
    assert s.preset == "USER:Wax test"
    other = add_cube(scene, name="Other")
    other.translucent.preset = "USER:Wax test"  # listed, and applied like a measured one
    assert tuple(other.translucent.sigma_s_prime) == pytest.approx((1.0, 1.5, 2.0))
    assert other.translucent.eta == pytest.approx(1.4) and other.translucent.g == pytest.approx(0.1)
    _select(other)
    assert bpy.ops.translucent.remove_preset() == {"FINISHED"}
    props = ext_module(tr, "translucent_addon.blender.props")
    assert "USER:Wax test" not in [i[0] for i in props._preset_items(None, None)]
    with pytest.raises(RuntimeError, match="only user presets can be removed"):
        bpy.ops.translucent.remove_preset()
    s.sigma_s_prime = (1.0, 1.0, 1.0)
    _select(cube)
    with pytest.raises(RuntimeError, match="a preset needs a name"):
        bpy.ops.translucent.save_preset(name="  ")


def test_user_presets_live_in_the_extensions_own_folder_moved_once_from_the_old_place(tr, scene, capfd):
    """Presets were kept in Blender's configuration folder; Blender keeps an extension's user data in its own
    folder (``bpy.utils.extension_path_user``). A file in the old place is moved there once, with one line, and its
    presets are listed as before."""
    import json
    from pathlib import Path

    props = ext_module(tr, "translucent_addon.blender.props")
    prefs = ext_module(tr, "translucent_addon.blender.preferences")
    own = Path(bpy.utils.extension_path_user(prefs.ROOT_PACKAGE, create=True)) / "presets.json"
    old = Path(bpy.utils.user_resource("CONFIG", path="translucent")) / "presets.json"
    kept = own.read_bytes() if own.exists() else None
    try:
        own.unlink(missing_ok=True)
        old.parent.mkdir(parents=True, exist_ok=True)
        old.write_text(json.dumps({"old wax": {"sigma_a": [0.01, 0.02, 0.03], "sigma_s_prime": [1, 1, 1],
                                               "eta": 1.4}}))
        capfd.readouterr()
        assert props.user_presets_path() == own and own.is_file() and not old.exists()
        assert props.user_presets_path() == own  # once
        assert capfd.readouterr().out.count("user presets moved from") == 1
        props.refresh_preset_items()
        assert "USER:old wax" in [item[0] for item in props._preset_items(None, None)]
    finally:
        old.unlink(missing_ok=True)
        own.unlink(missing_ok=True)
        if kept is not None:
            own.write_bytes(kept)
        props.refresh_preset_items()


def test_saving_a_preset_leaves_the_one_another_object_shows(tr, scene):
    """Files store an enum's number: a user preset's was its position in the list, so saving 'Apple' moved the
    object showing 'Zebra' to whatever came next. Now it is a number of the preset's name."""
    props = ext_module(tr, "translucent_addon.blender.props")
    cube = add_cube(scene)
    _select(cube)
    s = cube.translucent
    s.sigma_a, s.sigma_s_prime = (0.5, 0.5, 0.5), (1.0, 1.0, 1.0)
    assert bpy.ops.translucent.save_preset(name="Zebra test") == {"FINISHED"}
    assert s.preset == "USER:Zebra test" and s.get("preset") == props.user_preset_number("Zebra test")
    other = add_cube(scene, name="Other")
    _select(other)
    other.translucent.sigma_a = (0.1, 0.1, 0.1)
    assert bpy.ops.translucent.save_preset(name="Apple test") == {"FINISHED"}
    assert s.preset == "USER:Zebra test" and tuple(s.sigma_a) == pytest.approx((0.5, 0.5, 0.5))
    assert other.translucent.preset == "USER:Apple test"
    assert bpy.ops.translucent.remove_preset() == {"FINISHED"}
    assert s.preset == "USER:Zebra test"
    # A file stamped before the numbers stored the position: reopened, it names the preset at that position.
    versioning = ext_module(tr, "translucent_addon.blender.versioning")
    users = sorted(n for n in [i[0] for i in props._preset_items(None, None)] if n.startswith("USER:"))
    s["preset"] = versioning.FIRST_USER_POSITION + users.index("USER:Zebra test")
    scene.translucent.file_version = 2
    versioning.version_loaded()
    assert s.preset == "USER:Zebra test" and scene.translucent.file_version == versioning.FILE_VERSION
    _select(cube)
    assert bpy.ops.translucent.remove_preset() == {"FINISHED"}


def test_user_presets_file_skips_entries_that_are_not_media(tmp_path):
    """A hand-edited presets file with a bad entry still lists the good ones (pure)."""
    import json
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from translucent_addon.core.physics import presets

    path = tmp_path / "presets.json"
    path.write_text(json.dumps({"good": {"sigma_a": [0, 0, 0], "sigma_s_prime": [1, 1, 1], "eta": 1.3},
                                "negative": {"sigma_a": [-1, 0, 0], "sigma_s_prime": [1, 1, 1], "eta": 1.3},
                                "broken": {"eta": 1.3}}))
    problems = []
    assert list(presets.load_user_presets(path, problems)) == ["good"]
    assert len(problems) == 2 and "'negative'" in problems[0]
    assert "'broken'" in problems[1] and "no 'sigma_a'" in problems[1]
    with pytest.raises(presets.CoefficientError, match="sigma_s_prime.R = 0.0 mm\\^-1, must be > 0"):
        presets.save_user_preset(path, presets.Material("zero", (0, 0, 0), (0.0, 1, 1), 1.3))
    assert presets.remove_user_preset(path, "good") and not presets.remove_user_preset(path, "good")


@pytest.mark.parametrize("text", ["{not json", "[1, 2, 3]", "\udcff", ""])
def test_a_damaged_user_presets_file_gives_none_says_why_and_is_not_overwritten(tmp_path, text):
    """A user presets file that is not JSON, or not an object of presets, lists no user preset and one line
    saying so (the built-in list is kept); saving into it is refused rather than losing what it held."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from translucent_addon.core.physics import presets

    path = tmp_path / "presets.json"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    problems = []
    assert presets.load_user_presets(path, problems) == {}
    assert len(problems) == 1 and "fix or remove it" in problems[0]
    assert len(presets.load_presets()) >= 12
    with pytest.raises(presets.PresetFileError):
        presets.save_user_preset(path, presets.Material("new", (0.1, 0.1, 0.1), (1.0, 1.0, 1.0), 1.3))
    assert path.read_bytes() == text.encode("utf-8", "surrogateescape")


def test_editing_a_coefficient_makes_the_preset_custom(tr, scene):
    cube = add_cube(scene)
    s = cube.translucent
    s.preset = "marble"
    assert s.preset == "marble"  # applying the preset's own values keeps its name
    s.preset = "skin1"
    assert s.preset == "skin1"
    s.eta = 1.45
    assert s.preset == "CUSTOM" and s.eta == pytest.approx(1.45)


def test_undo_after_bake_and_after_clear(tr, scene):
    """Ctrl+Z after Bake leaves the object unbaked; after Clear it has its bake back."""
    store = ext_module(tr, "translucent_addon.blender.bake_files")
    cube = add_cube(scene, name="Undo cube")
    _select(cube)
    cube.translucent.method = "GEOCUBE"
    cube.translucent.geocube_resolution = 16
    bpy.ops.ed.undo_push(message="before bake")
    assert bpy.ops.translucent.bake() == {"FINISHED"}
    bpy.ops.ed.undo_push(message="baked")
    assert store.read_meta(bpy.data.objects["Undo cube"], "GEOCUBE") is not None
    bpy.ops.ed.undo()
    assert store.read_meta(bpy.data.objects["Undo cube"], "GEOCUBE") is None
    bpy.ops.ed.redo()
    cube = bpy.data.objects["Undo cube"]
    assert store.read_meta(cube, "GEOCUBE") is not None
    _select(cube)
    assert bpy.ops.translucent.clear_bake() == {"FINISHED"}
    bpy.ops.ed.undo_push(message="cleared")
    assert store.read_meta(bpy.data.objects["Undo cube"], "GEOCUBE") is None
    bpy.ops.ed.undo()
    assert store.read_meta(bpy.data.objects["Undo cube"], "GEOCUBE") is not None


def test_stale_bake_and_modifiers_are_said_in_full(tr, scene, capfd):
    """DESIGN.md section 6, exact messages: a bake made before the mesh changed is not drawn and the
    frame says so; baking an object with modifiers says that editing them stales the bake."""
    extract = ext_module(tr, "translucent_addon.blender.extract")
    cube = add_cube(scene, name="Stale cube")
    _select(cube)
    cube.translucent.method = "GEOCUBE"
    cube.translucent.geocube_resolution = 16
    cube.modifiers.new("Bevel", "BEVEL")
    assert bpy.ops.translucent.bake() == {"FINISHED"}
    assert "'Stale cube': baked with its modifiers applied; editing them marks the bake stale" in capfd.readouterr().out
    cube.modifiers["Bevel"].width = 0.2
    add_camera(scene, (3, -3, 3), (0, 0, 0))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, 16, 16))
    assert "'Stale cube': GEOCUBE bake is stale; drawn with its base colour. Press Bake" in frame.warnings


def test_add_grass_field_with_settings_it_cannot_grow_leaves_the_field_off(tr, scene):
    ground = add_mesh(scene, "Ground", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)])
    _select(ground)
    ground.translucent.grass_blade_height = 0.99 * ground.translucent.grass_tile  # blades taller than 60 %
    with pytest.raises(RuntimeError, match="'Ground': blade height must be 5-60 % of the tile"):
        bpy.ops.translucent.add_grass_field()
    assert not ground.translucent.grass


def test_the_overlay_over_other_engines_draws_with_the_scene_s_settings(tr, scene):
    """Objects drawn over EEVEE's viewport took the defaults (splat overlap, QUADGRAPH tolerance, ...), not the
    scene's: the overlay's frame now carries them, as the engine's viewport frame does."""
    draw_handler = ext_module(tr, "translucent_addon.blender.draw_handler")
    extract = ext_module(tr, "translucent_addon.blender.extract")
    cube = add_cube(scene)
    cube.translucent.method = "IMAGE_SPACE"
    add_camera(scene, (0, -4, 1), (0, 0, 0))
    scene.translucent.splat_overlap = 23.0
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = draw_handler.overlay_frame(depsgraph, extract.render_camera(depsgraph, 32, 32))
    assert [m.name for m in frame.meshes] == [cube.name]
    assert frame.settings.techniques["IMAGE_SPACE"].overlap == pytest.approx(23.0)

"""The medium on the Material (issue 38, point 2): a Principled BSDF with subsurface is our medium with nothing
to set, coefficients set on a material are shared by its objects, an object without either keeps its own, and
files from 0.1 (the medium on the Object) open with the look they were saved with."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

from blender_helpers import add_camera, add_cube, add_light, add_plane, diffuse_material, render, set_world  # noqa: E402
from conftest import ext_module  # noqa: E402

DATA = Path(__file__).parent / "data"
SKIN_SCALE = 0.05  # Subsurface Scale of the test material (Blender's default)


def _source(tr):
    return ext_module(tr, "translucent_addon.blender.medium_source")


def _skin_principled(tr, name="Skin", mm_per_unit=1000.0):
    """A Principled BSDF set by the tested conversion (ours -> Principled) from the skin1 preset."""
    conversion = ext_module(tr, "translucent_addon.core.physics.cycles_conversion")
    skin = ext_module(tr, "translucent_addon.core.physics.presets").load_presets()["skin1"]
    rw = conversion.random_walk_inputs(skin.sigma_a, skin.sigma_s_prime, skin.eta, skin.g, mm_per_unit)
    mat = diffuse_material(name, rw.base_color)
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Radius"].default_value = tuple(r / SKIN_SCALE for r in rw.radius)
    bsdf.inputs["Subsurface Scale"].default_value = SKIN_SCALE
    bsdf.inputs["Subsurface Anisotropy"].default_value = rw.anisotropy
    bsdf.inputs["IOR"].default_value = rw.ior
    return mat, skin


def test_a_principled_skin_material_is_our_skin_with_nothing_to_set(tr, scene):
    """Principled -> ours: the medium of a Cycles skin material is skin1 within the conversion's round trip
    (1 %), and a frame drawn with it matches one drawn with skin1 set by hand."""
    source = _source(tr)
    mat, skin = _skin_principled(tr)
    by_material = add_cube(scene, "ByMaterial", color=None)
    by_material.data.materials.append(mat)
    m = source.resolve(by_material)
    assert m.source == "PRINCIPLED" and m.material == "Skin" and m.profile == "EXACT" and not m.notes
    np.testing.assert_allclose(m.sigma_a, skin.sigma_a, rtol=0.01)
    np.testing.assert_allclose(m.sigma_s_prime, skin.sigma_s_prime, rtol=0.01)
    assert m.eta == pytest.approx(skin.eta) and m.g == pytest.approx(skin.g)
    # The same frame with the coefficients set by hand on the object, its material gone.
    set_world(scene, (0.03, 0.03, 0.04))
    add_plane(scene, color=(0.5, 0.5, 0.5))
    add_light(scene, "POINT", (0.0, 2.0, 1.5), target=(0, 0, 0.5), energy=200.0)  # behind: light through it
    add_light(scene, "SUN", (2, -3, 4), energy=1.0)
    add_camera(scene, (1.5, -4.0, 2.0), (0, 0, 0.5))
    by_material.translucent.method = "IMAGE_SPACE"
    by_material.translucent.preset = "marble"  # the object's own, unused while the material holds the medium
    images = [render(scene, 96, 96)[..., :3]]
    by_material.data.materials.clear()
    by_material.data.materials.append(diffuse_material("Grey", rw_base := tuple(mat.node_tree.nodes[
        "Principled BSDF"].inputs["Base Color"].default_value)[:3]))  # the same base colour, no subsurface
    by_material.translucent.preset = "skin1"
    assert source.resolve(by_material).source == "OBJECT"
    images.append(render(scene, 96, 96)[..., :3])
    a, b = images
    assert rw_base and np.isfinite(a).all() and a.max() > 0.05
    lit = b.max(axis=-1) > 0.05 * b.max()
    assert lit.sum() > 500
    difference = np.abs(a[lit] - b[lit]).mean() / b[lit].mean()
    print(f"Principled skin vs skin1 by hand: {100 * difference:.2f} % mean difference over {lit.sum()} pixels")
    assert difference < 0.01


def test_coefficients_on_a_material_are_shared_by_its_objects(tr, scene):
    source = _source(tr)
    mat = bpy.data.materials.new("Wax")
    mat.translucent.source = "MATERIAL"
    mat.translucent.preset = "potato"
    obs = [add_cube(scene, f"C{i}", location=(2 * i, 0, 0.5), color=None) for i in range(2)]
    for ob in obs:
        ob.data.materials.append(mat)
        ob.translucent.preset = "marble"  # the object's own: not used while the material holds the medium
    potato = ext_module(tr, "translucent_addon.core.physics.presets").load_presets()["potato"]
    for ob in obs:
        m = source.resolve(ob)
        assert m.source == "MATERIAL" and m.sigma_a == pytest.approx(potato.sigma_a)
        assert source.editable(ob) == mat.translucent
    mat.translucent.preset = "ketchup"
    assert {source.resolve(ob).sigma_s_prime for ob in obs} == {tuple(mat.translucent.sigma_s_prime)}
    # A bake's inputs follow the material: editing it makes a bake of the object stale.
    bake_inputs = ext_module(tr, "translucent_addon.blender.bake_inputs")
    obs[0].translucent.method = "TEXTURE_SPACE"
    ev = obs[0].evaluated_get(bpy.context.evaluated_depsgraph_get())
    before = bake_inputs.inputs_hash(bake_inputs.gather(ev))
    mat.translucent.sigma_a = (0.1, 0.2, 0.3)
    assert bake_inputs.inputs_hash(bake_inputs.gather(ev)) != before
    mat.translucent.source = "OBJECT"  # each object's own again
    assert source.resolve(obs[0]).sigma_a == pytest.approx(tuple(obs[0].translucent.sigma_a))


def test_objects_keep_their_own_medium_where_the_material_has_none(tr, scene):
    """No material, a Principled BSDF without subsurface, a material without a Principled BSDF: the object's
    own coefficients, and the panel's line says why."""
    source = _source(tr)
    ob = add_cube(scene, "Plain", color=None)
    ob.translucent.preset = "marble"
    assert source.resolve(ob).reason == "The object's own: it has no material"
    ob.data.materials.append(diffuse_material("Grey", (0.5, 0.5, 0.5)))  # Subsurface Weight 0
    m = source.resolve(ob)
    assert m.source == "OBJECT" and "Subsurface Weight 0" in m.reason
    assert m.sigma_a == pytest.approx(tuple(ob.translucent.sigma_a))
    mat = ob.data.materials[0]
    mat.node_tree.nodes.remove(next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"))
    assert "has no Principled BSDF" in source.resolve(ob).reason


def test_what_the_principled_bsdf_cannot_say_is_said_in_the_frame(tr, scene):
    """A texture on Base Color, a partial Subsurface Weight, an IOR below 1: drawn with stated stand-ins."""
    source = _source(tr)
    mat, _ = _skin_principled(tr)
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    noise = mat.node_tree.nodes.new("ShaderNodeTexNoise")
    mat.node_tree.links.new(noise.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Subsurface Weight"].default_value = 0.5
    bsdf.inputs["IOR"].default_value = 0.8
    ob = add_cube(scene, "Textured", color=None)
    ob.data.materials.append(mat)
    m = source.resolve(ob)
    assert m.source == "PRINCIPLED" and m.eta == 1.0
    text = " | ".join(m.notes)
    assert "Base Color is linked" in text and "Subsurface Weight 0.5 is drawn as 1" in text and "IOR 0.8" in text
    ob.translucent.method = "IMAGE_SPACE"
    extract = ext_module(tr, "translucent_addon.blender.extract")
    warnings = []
    method, medium = extract.medium_of(ob, "IMAGE_SPACE", warnings)
    assert method == "IMAGE_SPACE" and medium.eta == 1.0
    assert any("Base Color is linked" in w for w in warnings)


def test_a_file_from_0_1_opens_with_each_objects_medium(tr, scene, tmp_path):
    """Saved by 0.1.0 (commit 516a283): two objects with their own presets (potato, skin1) share a material
    whose Principled BSDF has subsurface, which would now convert. The versioning keeps each object's medium;
    a file saved now is not versioned again."""
    source = _source(tr)
    presets = ext_module(tr, "translucent_addon.core.physics.presets").load_presets()
    path = tmp_path / "old.blend"
    shutil.copy(DATA / "translucent_0_1_0_materials.blend", path)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    left, right = bpy.data.objects["Left"], bpy.data.objects["Right"]
    assert bpy.data.materials["Wax"].translucent.source == "OBJECT"
    for ob, preset in ((left, "potato"), (right, "skin1")):
        m = source.resolve(ob)
        assert m.source == "OBJECT" and m.sigma_a == pytest.approx(presets[preset].sigma_a, rel=1e-6)
    # The object without a method is left alone: its material converts as any new one.
    assert bpy.data.materials["Unused weight"].translucent.source == "PRINCIPLED"
    bpy.ops.wm.save_mainfile()
    bpy.data.materials["Wax"].translucent.source = "PRINCIPLED"
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=str(path))
    versioning = ext_module(tr, "translucent_addon.blender.versioning")
    assert bpy.context.scene.translucent.file_version == versioning.FILE_VERSION
    assert bpy.data.materials["Wax"].translucent.source == "PRINCIPLED"  # a choice made now is kept
    assert source.resolve(bpy.data.objects["Left"]).source == "PRINCIPLED"
    bpy.ops.wm.read_homefile(use_empty=True)


def test_the_preset_buttons_act_on_the_material_that_holds_the_medium(tr, scene, tmp_path, monkeypatch):
    props = ext_module(tr, "translucent_addon.blender.props")
    monkeypatch.setattr(props, "user_presets_path", lambda: tmp_path / "presets.json")
    props.refresh_preset_items()
    mat = bpy.data.materials.new("Shared")
    mat.translucent.source = "MATERIAL"
    mat.translucent.sigma_s_prime = (1.0, 1.5, 2.0)
    ob = add_cube(scene, "Holder", color=None)
    ob.data.materials.append(mat)
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.translucent.save_preset(name="Shared wax") == {"FINISHED"}
    assert mat.translucent.preset == "USER:Shared wax" and ob.translucent.preset != "USER:Shared wax"
    assert bpy.ops.translucent.remove_preset() == {"FINISHED"}
    assert mat.translucent.preset == "CUSTOM"
    principled, _ = _skin_principled(tr, "Converted")
    ob.data.materials[0] = principled
    assert not bpy.ops.translucent.save_preset.poll()  # converted: edited on the Principled BSDF
    props.refresh_preset_items()


def test_a_scattering_scale_a_file_holds_at_zero_is_not_drawn(tr, scene):
    """A file or a script can store 0 (or NaN) where the property's range forbids it: millimetres per unit
    would be infinite. The frame refuses the medium (the object drawn with its base colour) and says so."""
    ob = add_cube(scene, "Scaled", color=None)
    ob.translucent["scattering_scale"] = 0.0
    extract = ext_module(tr, "translucent_addon.blender.extract")
    warnings = []
    assert extract.medium_of(ob, "IMAGE_SPACE", warnings) == ("OFF", None)
    assert any("'Scaled': scattering scale 0.0, must be a positive number" in w for w in warnings), warnings


def test_a_layer_over_a_base_reaches_only_the_method_that_draws_it(tr, scene):
    """The other methods draw the top layer with the exact profile: their medium has no layer, so they take
    that profile's entry shift (a layered medium keeps the multipole's, none)."""
    oblique_entry = ext_module(tr, "translucent_addon.core.physics.oblique_entry")
    extract = ext_module(tr, "translucent_addon.blender.extract")
    ob = add_cube(scene, "Layered")
    ob.translucent.preset = "skin1"
    ob.translucent.profile = "MULTIPOLE"
    ob.translucent.layer_thickness = 0.002
    _, layered = extract.medium_of(ob, "IMAGE_SPACE", [])
    assert layered.layer_thickness_mm == pytest.approx(2.0) and layered.profile == "EXACT"
    assert not oblique_entry.medium_shift_mm(layered).any()
    _, top = extract.medium_of(ob, "TEXTURE_SPACE", [])
    assert top.layer_thickness_mm is None and top.profile == "EXACT"
    np.testing.assert_allclose(oblique_entry.medium_shift_mm(top),
                               1.0 / (np.array(top.sigma_a) + np.array(top.sigma_s_prime)))

"""Where artists look (issue 38, point 3): for our engine the Render tab shows only panels that act, our scene
settings are there and the object's in the Object tab; every operator greys out with the reason instead of
failing after the click; every setting says what it does in one short sentence."""
from __future__ import annotations

import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import add_camera, add_cube  # noqa: E402

ENGINE = "TRANSLUCENT_RT"
# What the Render tab holds for our engine: ours, and of Blender's what the engine reads.
RENDER_TAB = {
    "RENDER_PT_translucent", "RENDER_PT_translucent_image_space", "RENDER_PT_translucent_texture_space",
    "RENDER_PT_translucent_quadgraph_solver", "RENDER_PT_translucent_caustics", "RENDER_PT_translucent_last_frame",
    "RENDER_PT_color_management", "RENDER_PT_color_management_advanced", "RENDER_PT_color_management_curves",
    "RENDER_PT_color_management_white_balance", "RENDER_PT_color_management_working_space",
    "RENDER_PT_simplify", "RENDER_PT_simplify_render", "RENDER_PT_simplify_viewport",
}


def _panels(context: str) -> set[str]:
    """The Properties editor's panels of a tab that show for our engine."""
    return {p.__name__ for p in bpy.types.Panel.__subclasses__()
            if getattr(p, "bl_space_type", "") == "PROPERTIES" and getattr(p, "bl_context", "") == context
            and ENGINE in (getattr(p, "COMPAT_ENGINES", None) or set())}


def test_the_render_tab_lists_only_panels_that_act(tr, scene):
    """It listed 29 of EEVEE's (Sampling, Raytracing, Volumes...) and none of ours."""
    render = _panels("render")
    versions = {n for n in RENDER_TAB if n.startswith(("RENDER_PT_color_management_working_space",
                                                       "RENDER_PT_color_management_white_balance"))}
    assert RENDER_TAB - versions <= render <= RENDER_TAB, sorted(render ^ RENDER_TAB)
    print(f"Render tab for {ENGINE}: {len(render)} panels, {len([n for n in render if 'translucent' in n])} ours")


def test_object_light_world_and_material_tabs_keep_what_the_engine_reads(tr, scene):
    assert "OBJECT_PT_translucent" in _panels("object") and "OBJECT_PT_shading" not in _panels("object")
    data = _panels("data")
    assert {"DATA_PT_EEVEE_light", "DATA_PT_spot", "DATA_PT_lens", "DATA_PT_vertex_groups"} <= data
    assert not data & {"DATA_PT_EEVEE_light_shadow", "DATA_PT_EEVEE_light_influence", "DATA_PT_lightprobe",
                       "DATA_PT_camera_dof"}
    assert "EEVEE_WORLD_PT_surface" in _panels("world") and "EEVEE_WORLD_PT_mist" not in _panels("world")
    material = _panels("material")
    assert {"EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface"} <= material
    assert "EEVEE_MATERIAL_PT_settings" not in material
    assert "MATERIAL_PT_translucent" in material  # the medium its objects share (issue 38, point 2)
    # Our panels show only while our engine renders the scene.
    scene.render.engine = ENGINE
    ctx = bpy.context
    assert bpy.types.RENDER_PT_translucent.poll(ctx)
    scene.render.engine = "CYCLES"
    assert not bpy.types.RENDER_PT_translucent.poll(ctx)


def _poll(name: str):
    return getattr(bpy.ops.translucent, name).poll()


def test_every_operator_has_a_poll_that_says_why(tr, scene):
    """No operator had a poll: buttons never greyed out and errors came only after a click."""
    for name in dir(bpy.ops.translucent):
        cls = getattr(bpy.types, getattr(bpy.ops.translucent, name).idname(), None)
        assert cls is not None and "poll" in cls.__dict__, f"translucent.{name} has no poll"
    for name in ("bake", "clear_bake", "add_paint_layer", "bake_grass_btf", "add_grass_field", "save_preset",
                 "remove_preset", "set_physical_size"):
        assert not _poll(name), f"translucent.{name} runs with no active object"
    assert not _poll("compare_cycles")  # no camera
    with pytest.raises(RuntimeError, match="no active object: select a mesh object to bake"):
        bpy.ops.translucent.bake()  # the poll's message is the error's
    assert _poll("add_demo_scene") and _poll("apply_quality") and _poll("auto_quality")
    cube = add_cube(scene)
    bpy.context.view_layer.objects.active = cube
    assert _poll("add_paint_layer") and _poll("set_physical_size") and _poll("save_preset")
    assert not _poll("bake") and not _poll("clear_bake") and not _poll("remove_preset")
    cube.translucent.method = "TEXTURE_SPACE"
    assert _poll("bake") and not _poll("clear_bake")
    add_camera(scene, (0, -4, 1), (0, 0, 0))
    assert _poll("compare_cycles")


def _visible(rna):
    return [p for p in rna.properties if p.identifier != "rna_type" and not p.is_hidden]


def test_every_setting_says_what_it_does_in_one_short_sentence(tr, scene):
    """12 had no description, 4 ran past 200 characters of citations (those are in the docs now)."""
    groups = [getattr(bpy.types, t).bl_rna.properties["translucent"].fixed_type for t in ("Object", "Material", "Scene", "Light")]
    operators = [getattr(bpy.ops.translucent, n).get_rna_type() for n in dir(bpy.ops.translucent)]
    for rna in groups + operators:
        for p in _visible(rna):
            text = p.description
            assert text, f"{rna.identifier}.{p.identifier} has no description"
            assert len(text) <= 200, f"{rna.identifier}.{p.identifier}: {len(text)} characters"
    assert all(op.description for op in operators)

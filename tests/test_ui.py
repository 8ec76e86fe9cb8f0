"""Where artists look (issue 38, point 3): for our engine the Render tab shows only panels that act, our scene
settings are there and the object's in the Object tab; every operator greys out with the reason instead of
failing after the click; every setting says what it does in one short sentence."""
from __future__ import annotations

import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import add_camera, add_cube, render  # noqa: E402
from conftest import ext_module  # noqa: E402

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
    groups = [getattr(bpy.types, t).bl_rna.properties["translucent"].fixed_type
              for t in ("Object", "Material", "Scene", "Light")]
    operators = [getattr(bpy.ops.translucent, n).get_rna_type() for n in dir(bpy.ops.translucent)]
    for rna in groups + operators:
        for p in _visible(rna):
            text = p.description
            assert text, f"{rna.identifier}.{p.identifier} has no description"
            assert len(text) <= 200, f"{rna.identifier}.{p.identifier}: {len(text)} characters"
    assert all(op.description for op in operators)


# What belongs in the docs and code comments, not in a tooltip: citations, equations, technique ids, paths.
_NOT_FOR_ARTISTS = (r"\b(Eqs?|Figs?|Sec|ch)\. ?\d|\b(Lensch|Shah|Jensen|Donner|Mertens|Wang|Chan|Jakob|et al)\b"
                    r"|\.py\b|\b\w+/\w+\.\w+|\bsigma_|_prime\b|\^|\b[A-Z]{2,}(_[A-Z]+)+\b")


def _ui_strings(tr) -> list[tuple[str, str]]:
    """Every string an artist reads: the settings' and operators' names, tooltips and choices, the presets', the
    preferences'."""
    prefs = ext_module(tr, "translucent_addon.blender.preferences")
    groups = [getattr(bpy.types, t).bl_rna.properties["translucent"].fixed_type
              for t in ("Object", "Material", "Scene", "Light")]
    operators = [getattr(bpy.ops.translucent, n).get_rna_type() for n in dir(bpy.ops.translucent)]
    addon = bpy.context.preferences.addons[prefs.ROOT_PACKAGE].preferences.bl_rna
    found = [(f"{op.identifier}", text) for op in operators for text in (op.name, op.description)]
    for rna in groups + operators + [addon]:
        for p in rna.properties:
            if p.identifier in ("rna_type", "bl_idname") or (rna in groups and p.is_hidden):
                continue
            where = f"{rna.identifier}.{p.identifier}"
            found += [(where, p.name), (where, p.description)]
            if p.type == "ENUM":
                found += [(f"{where}[{i.identifier}]", text) for i in p.enum_items for text in (i.name, i.description)]
    props = ext_module(tr, "translucent_addon.blender.props")
    found += [(f"preset {item[0]}", text) for item in props._preset_items(None, None) for text in item[1:3]]
    return found


def test_no_tooltip_quotes_an_equation_an_id_or_a_path(tr, scene):
    """Tooltips quoted equations and internal ids ("F^0 E (Lensch Eq. 11)", "TEXTURE_SPACE: ...", "Shah Eq. 6.16");
    citations belong in the docs and the code. Every name, tooltip and choice an artist reads, checked."""
    import re

    techniques = ext_module(tr, "translucent_addon.techniques")
    technique_ids = {t.id for t in techniques.REGISTRY}
    strings = _ui_strings(tr)
    assert len(strings) > 250
    ui = ext_module(tr, "translucent_addon.blender.ui")  # and what the panels write, for every method
    ob = add_cube(scene)
    bpy.context.view_layer.objects.active = ob
    for method in techniques.method_ids():
        ob.translucent.method = method
        for draw, args in ((ui.draw_object, (ob,)), (ui.draw_material, (ob.active_material,)),
                           (ui._scene_general, ()), *((d, ()) for _, d in ui.SCENE_SECTIONS)):
            layout = _Layout()
            draw(layout, bpy.context, *args)
            strings += [(f"panel ({method})", text) for text in layout.labels()]
    bad = [(where, text) for where, text in strings if text and (
        re.search(_NOT_FOR_ARTISTS, text) or any(re.search(rf"\b{i}\b", text) for i in technique_ids))]
    assert not bad, "\n".join(f"{where}: {text}" for where, text in bad)


class _Layout:
    """A stand-in for ``UILayout`` that records what a panel draws and refuses what Blender would: a property
    the data does not have, an operator that does not exist (panels cannot draw without a window)."""

    def __init__(self, record=None):
        self.record = record if record is not None else []
        self.scale_y = 1.0
        self.use_property_split = self.enabled = self.active = True

    def _child(self, *args, **kwargs):
        return _Layout(self.record)

    row = column = box = grid_flow = split = _child

    def prop(self, data, name, **kwargs):
        assert name in data.bl_rna.properties, f"{data.bl_rna.identifier} has no property {name}"
        self.record.append(("prop", data.bl_rna.identifier, name, data))

    def label(self, text="", icon="NONE", **kwargs):
        self.record.append(("label", text))

    def operator(self, idname, **kwargs):
        group, name = idname.split(".")
        assert hasattr(getattr(bpy.ops, group), name), idname
        self.record.append(("operator", idname))
        return type("Properties", (), {})()

    def progress(self, factor=0.0, type="BAR", text=""):
        self.record.append(("progress", factor, text))

    def operator_menu_enum(self, idname, prop, **kwargs):
        self.operator(idname)

    def context_pointer_set(self, name, data):
        self.record.append(("context", name, data))

    def template_ID(self, data, name, **kwargs):
        self.prop(data, name)

    def labels(self):
        return [r[1] for r in self.record if r[0] == "label"]

    def props(self):
        return [(r[1], r[2]) for r in self.record if r[0] == "prop"]


def test_the_panels_draw_the_medium_where_it_is_set(tr, scene):
    """The Object panel says where the object's medium comes from and edits it there (the material's group or
    the object's); the Material panel shows each source; every property and operator drawn exists."""
    ui = ext_module(tr, "translucent_addon.blender.ui")
    ctx = bpy.context
    ob = add_cube(scene, color=None)
    ob.translucent.method = "TEXTURE_SPACE"
    bpy.context.view_layer.objects.active = ob

    def drawn(draw, *args):
        layout = _Layout()
        draw(layout, ctx, *args)
        return layout

    layout = drawn(ui.draw_object, ob)
    assert "The object's own: it has no material" in layout.labels()
    assert ("TranslucentObjectSettings", "sigma_a") in layout.props()
    mat = bpy.data.materials.new("Wax")
    ob.data.materials.append(mat)
    mat.translucent.source = "MATERIAL"
    layout = drawn(ui.draw_object, ob)
    assert "Material 'Wax': its coefficients" in layout.labels()
    edited = [r[3] for r in layout.record if r[0] == "prop" and r[2] == "sigma_a"]
    assert edited == [mat.translucent]  # the material's coefficients, not the object's
    assert ("context", "translucent_medium", mat.translucent) in layout.record
    for source in ("MATERIAL", "OBJECT", "PRINCIPLED"):
        mat.translucent.source = source
        layout = drawn(ui.draw_material, mat)
        assert ("TranslucentMaterialSettings", "source") in layout.props()
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    assert "Subsurface Weight 0: each object keeps its own coefficients" in drawn(ui.draw_material, mat).labels()
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    labels = drawn(ui.draw_material, mat).labels()
    assert any(t.startswith("Absorption: ") for t in labels) and any(t.startswith("IOR 1.5") for t in labels)
    layout = drawn(ui.draw_object, ob)
    assert "Material 'Wax': from its Principled BSDF" in layout.labels()
    assert not [p for p in layout.props() if p[1] == "sigma_a"]  # set on the Principled BSDF, not here
    for draw in (ui._scene_general, *(draw for _, draw in ui.SCENE_SECTIONS)):
        drawn(draw)


def test_sizes_in_the_panel_follow_the_scene_s_unit_system(tr, scene):
    """*Scatters as* said mm / cm / m whatever the scene's units: an imperial scene shows inches and feet, through
    Blender's own unit formatting; a metric one metric units."""
    ui = ext_module(tr, "translucent_addon.blender.ui")
    ob = add_cube(scene, size=1.0, color=None)
    ob.scale = (0.05, 0.05, 2.0)  # 5 cm x 5 cm x 2 m
    ob.translucent.scattering_scale = 1.0
    bpy.context.view_layer.update()

    def scatters_as():
        layout = _Layout()
        ui.draw_object(layout, bpy.context, ob)
        return next(t for t in layout.labels() if t.startswith("Scatters as: "))

    scene.unit_settings.system = "IMPERIAL"
    assert scatters_as() == 'Scatters as: 1.97" x 1.97" x 6.56\''
    scene.unit_settings.system = "METRIC"
    assert scatters_as() == "Scatters as: 5 cm x 5 cm x 2 m"


def test_the_object_settings_are_collapsible_sub_panels_shown_where_they_act(tr, scene):
    """The object's settings were one long panel (method, medium, quality, bake, Compare, caustics, grass, height
    field, paint); now the method heads it and each section is a sub-panel, in the Object properties and in the
    sidebar, shown only where it acts (no Quality for Off, Paint only for the methods that draw paint)."""
    import types

    ui = ext_module(tr, "translucent_addon.blender.ui")
    ob = add_cube(scene)
    bpy.context.view_layer.objects.active = ob
    scene.render.engine = ENGINE
    ctx = bpy.context
    for parent in ("OBJECT_PT_translucent", "VIEW3D_PT_translucent_object"):
        children = {label: getattr(bpy.types, f"{parent}_{label.lower().replace(' ', '_')}")
                    for label, *_ in ui.OBJECT_SECTIONS}
        assert all(c.bl_parent_id == parent for c in children.values())
        assert "DEFAULT_CLOSED" in children["Grass"].bl_options and not children["Medium"].bl_options
        ob.translucent.method = "OFF"
        assert children["Medium"].poll(ctx) and children["Bake"].poll(ctx)
        assert not children["Quality"].poll(ctx) and not children["Paint"].poll(ctx)
        ob.translucent.method = "IMAGE_SPACE"
        assert children["Quality"].poll(ctx) and children["Paint"].poll(ctx)
        drawn = {}
        for label, child in children.items():
            layout = _Layout()
            child.draw(types.SimpleNamespace(layout=layout), ctx)
            drawn[label] = layout
        assert ("TranslucentObjectSettings", "sigma_a") in drawn["Medium"].props()
        assert ("TranslucentObjectSettings", "quality") in drawn["Quality"].props()
        assert ("operator", "translucent.bake") in drawn["Bake"].record
        assert ("TranslucentObjectSettings", "caustics_caster") in drawn["Caustics"].props()
        assert ("operator", "translucent.add_paint_layer") in drawn["Paint"].record
        head = _Layout()
        getattr(bpy.types, parent).draw(types.SimpleNamespace(layout=head), ctx)
        assert head.props() == [("TranslucentObjectSettings", "method")]  # the head: the method, what it is


def test_the_demo_button_says_which_scene_it_adds(tr, scene):
    import types

    cls = bpy.types.TRANSLUCENT_OT_add_demo_scene
    assert cls.description(bpy.context, types.SimpleNamespace(kind="BUNNY")) == (
        "Add a new scene: a back-lit marble stanford bunny on a ground plane")
    assert "glass ball" in cls.description(bpy.context, types.SimpleNamespace(kind="GLASS_BALL"))
    # Where a new user finds it: first in the sidebar's tab, atop the Render panel, and with no mesh selected (it
    # sat under Last Frame, in a closed panel).
    for panel in (bpy.types.VIEW3D_PT_translucent_demo, bpy.types.RENDER_PT_translucent):
        layout = _Layout()
        panel.draw(types.SimpleNamespace(layout=layout), bpy.context)
        assert ("operator", "translucent.add_demo_scene") in layout.record[:2], panel
    assert "DEFAULT_CLOSED" not in getattr(bpy.types.VIEW3D_PT_translucent_demo, "bl_options", set())
    layout = _Layout()
    ext_module(tr, "translucent_addon.blender.ui").draw_object(layout, bpy.context, None)
    assert ("operator", "translucent.add_demo_scene") in layout.record


def test_a_job_in_progress_greys_out_the_bake_buttons(tr, scene):
    bake = ext_module(tr, "operators.bake")
    cube = add_cube(scene)
    bpy.context.view_layer.objects.active = cube
    cube.translucent.method = "TEXTURE_SPACE"
    add_camera(scene, (0, -4, 1), (0, 0, 0))
    assert _poll("bake") and _poll("bake_grass_btf") and _poll("compare_cycles")
    bake.ModalJob.running.add(object())  # a bake started from the UI, not finished
    try:
        assert not _poll("bake") and not _poll("bake_grass_btf") and not _poll("compare_cycles")
        with pytest.raises(RuntimeError, match="a bake or comparison is in progress: wait for it, or press Esc"):
            bpy.ops.translucent.bake()
    finally:
        bake.ModalJob.running.clear()
    assert _poll("bake")


def test_a_long_job_shows_a_progress_bar_in_the_status_bar(tr, scene):
    """A bake in the UI showed a percentage by the cursor and a line of text; the status bar now draws a bar of the
    share done, with what runs now and Esc (``ModalJob._draw_status``, Blender's ``UILayout.progress``)."""
    import types

    job = ext_module(tr, "operators.bake").ModalJob
    layout = _Layout()
    fake = types.SimpleNamespace(_progress=(0.4, "QUADGRAPH: graph of level 1/1"), _title="Translucent bake")
    job._draw_status(fake, types.SimpleNamespace(layout=layout), bpy.context)
    assert layout.record == [("progress", 0.4, "Translucent bake: 40 %"),
                             ("label", "QUADGRAPH: graph of level 1/1 (Esc to cancel)")]
    assert "progress" in bpy.types.UILayout.bl_rna.functions  # what the status bar draws it with (Blender 4.0 on)


def test_the_last_frame_panel_says_the_frame_s_warnings(tr, scene):
    """The viewport has no report line: what the last frame (F12 or viewport) said is listed in the Last Frame
    panel, above its timings."""
    ui = ext_module(tr, "translucent_addon.blender.ui")
    add_cube(scene)
    add_camera(scene, (3, -3, 3), (0, 0, 0))
    render(scene, 16, 16)  # no lights in the scene: the frame says so
    layout = _Layout()
    ui._scene_last_frame(layout, bpy.context)
    labels = layout.labels()
    said = "the scene has no lights: objects are lit by the world only"
    assert said in labels and labels.index(said) < next(i for i, t in enumerate(labels) if t.startswith("Translucent"))
    ext_module(tr, "translucent_addon.blender.session").current().warnings[:] = [f"line {i}" for i in range(9)]
    layout = _Layout()
    ui._scene_last_frame(layout, bpy.context)
    assert "line 5" in layout.labels() and "line 6" not in layout.labels()
    assert "... and 3 more (F12 reports every one)" in layout.labels()

"""The "Translucent" sidebar tab and our engine in Blender's own property panels."""
from __future__ import annotations

import bpy

from .. import techniques
from ..techniques.grass import bake as grass_btf
from . import bake_files, medium_source, session
from .bake_inputs import bake_status
from .draw_handler import timing_lines
from .extract import grass_status
from .props import preset_problems
from .versions import EEVEE_IDS

_STATUS_ICON = {"OK": "CHECKMARK", "STALE": "ERROR", "MISSING": "X", "NONE": "DOT"}
_STATUS_TEXT = {
    "OK": "Bake up to date",
    "STALE": "Bake is stale: the object changed since it was baked",
    "MISSING": "Not baked yet",
    "NONE": "This method needs no bake",
}


def draw_object(layout, context, ob) -> None:
    """An object's method, medium, quality and bake, all of it (the panels draw the same in collapsible
    sub-panels, ``OBJECT_SECTIONS``)."""
    if not _object_head(layout, ob):
        return
    for _, shows, draw, _ in OBJECT_SECTIONS:
        if shows is None or shows(ob):
            draw(layout, context, ob)


def _object_head(layout, ob) -> bool:
    """The top of the object's panel: a light's caustics switch, or a mesh's method; False when nothing more
    belongs under it."""
    if ob is not None and ob.type == "LIGHT":
        layout.prop(ob.data.translucent, "caustics")
        return False
    if ob is None or ob.type != "MESH":
        layout.label(text="Select a mesh object, or start from a demo scene", icon="INFO")
        _demo_buttons(layout)
        return False
    _method(layout, ob)
    return True


def _draw_medium(layout, context, ob) -> None:
    _medium(layout, ob)
    _size(layout, context, ob)


def _shows_quality(ob) -> bool:
    return ob.translucent.method != "OFF" or ob.translucent.grass


def _draw_quality(layout, context, ob) -> None:
    """Quality tiers or Auto, then the method's own settings as it lays them out."""
    s = ob.translucent
    technique = techniques.get(s.method)
    _quality(layout, ob, technique)
    if technique is not None:
        for names in technique.panel:
            col = layout.column(align=True)
            for name in names:
                col.prop(s, name)


def _shows_paint(ob) -> bool:
    technique = techniques.get(ob.translucent.method)
    return technique is not None and technique.draws_paint


# The object settings' sections, each a collapsible sub-panel as Cycles' material panels are: (label, whether it
# shows for the object (None: always), how it draws, open at first).
OBJECT_SECTIONS = (
    ("Medium", None, _draw_medium, True),
    ("Quality", _shows_quality, _draw_quality, True),
    ("Bake", None, lambda layout, context, ob: _bake(layout, context, ob, techniques.get(ob.translucent.method)),
     True),
    ("Caustics", None, lambda layout, context, ob: _caustics_box(layout, ob.translucent), False),
    ("Grass", None, lambda layout, context, ob: _grass_box(layout, ob), False),
    ("Height Field", None, lambda layout, context, ob: _relief_box(layout, ob), False),
    ("Paint", _shows_paint, lambda layout, context, ob: _paint_box(layout), False),
)


def _method(layout, ob) -> None:
    """The method, what it is, and how the last frame found the mesh's winding."""
    s = ob.translucent
    layout.prop(s, "method")
    layout.label(text=techniques.method_description(s.method))
    turned = session.current().turned.get(ob.name, 0)
    if turned:  # as the last frame found it (extract.frame_inputs): the panel reads no mesh
        parts = "the mesh is" if turned == 1 else f"{turned} closed parts are"
        layout.label(text=f"{parts.capitalize()} wound inward: drawn turned outward", icon="ERROR")
        layout.label(text="Mesh > Normals > Recalculate Outside fixes the mesh")


def _size(layout, context, ob) -> None:
    """The scattering scale and the size helper: scattering depends on the real size."""
    s = ob.translucent
    layout.prop(s, "scattering_scale")
    if max(ob.dimensions) > 0:
        row = layout.row(align=True)
        mm = medium_source.mm_per_unit(s, context.scene)
        row.label(text="Scatters as: " + " x ".join(_length(d * mm, context.scene) for d in ob.dimensions),
                  icon="DRIVER_DISTANCE")
        row.operator("translucent.set_physical_size", text="", icon="FULLSCREEN_ENTER")


def _quality(layout, ob, technique) -> None:
    """Quality tiers; under Auto its target, what it chose, and what the method says of the last frame."""
    s = ob.translucent
    box = layout.box()
    row = box.row(align=True)
    row.prop(s, "quality", expand=True)
    if s.quality != "AUTO":
        return
    row = box.row(align=True)
    row.prop(s, "target_error")
    row.operator("translucent.auto_quality", text="", icon="FILE_REFRESH")
    for line in _wrap(s.auto_summary or "Chosen at the next bake, or now with the button", 60):
        box.label(text=line)
    if technique is not None:
        for line in technique.panel_notes(session.current().results.get(technique.id, {}), ob.name):
            box.label(text=line, icon="CAMERA_DATA")


def _bake(layout, context, ob, technique) -> None:
    """The bake's status, what it holds (the method says), Bake, Clear and Compare."""
    s = ob.translucent
    status = bake_status(ob.evaluated_get(context.evaluated_depsgraph_get()), s.method)
    layout.label(text=_STATUS_TEXT[status], icon=_STATUS_ICON[status])
    if status in {"OK", "STALE"} and technique is not None:
        meta = bake_files.read_meta(ob, s.method)  # read without loading the arrays
        if meta is not None:
            col = layout.column(align=True)
            col.scale_y = 0.8
            for line in technique.bake_summary(meta):
                col.label(text=line)
    row = layout.row(align=True)
    row.operator("translucent.bake", icon="RENDER_STILL")
    row.operator("translucent.clear_bake", icon="TRASH")
    layout.operator("translucent.compare_cycles", icon="IMAGE_REFERENCE")


def _caustics_box(layout, s) -> None:
    box = layout.box()
    box.prop(s, "caustics_caster")
    if s.caustics_caster == "NONE":
        return
    col = box.column(align=True)
    if s.caustics_caster == "REFRACTIVE":
        for name in ("caustics_ior", "caustics_surfaces", "caustics_dispersion", "caustics_color",
                     "caustics_distance"):
            col.prop(s, name)
    else:
        col.prop(s, "caustics_color", text="Reflectance")


def _relief_box(layout, ob) -> None:
    s = ob.translucent
    box = layout.box()
    box.prop(s, "relief")
    if s.relief == "OFF":
        return
    col = box.column(align=True)
    col.template_ID(s, "relief_image", open="image.open")
    for name in ("relief_depth", "relief_linear_steps", "relief_iterations", "relief_shadows"):
        col.prop(s, name)
    if not ob.data.uv_layers:
        box.label(text="Needs a UV map", icon="ERROR")


def _paint_box(layout) -> None:
    """Buttons adding the painted layers (Shah ch. 7) the method draws."""
    box = layout.box()
    box.label(text="Paint translucency", icon="BRUSH_DATA")
    grid = box.grid_flow(columns=2, align=True)
    for layer, label in (("translucent_blur", "Blur"), ("translucent_glow", "Glow"),
                         ("translucent_mask", "Mask"), ("translucent_tint", "Tint")):
        op = grid.operator("translucent.add_paint_layer", text=label)
        op.layer = layer


def _coefficients(layout, group, multipole: bool = True) -> None:
    """A property group's medium: preset (with the user preset buttons), coefficients, profile and layer."""
    col = layout.column(align=True)
    row = col.row(align=True)
    row.context_pointer_set("translucent_medium", group)  # the preset buttons act on this group
    row.prop(group, "preset")
    row.operator("translucent.save_preset", text="", icon="ADD")
    row.operator("translucent.remove_preset", text="", icon="REMOVE")
    for line in preset_problems()[:2]:  # the user presets file's entries that were skipped, and why
        col.label(text=line, icon="ERROR")
    for name in ("sigma_a", "sigma_s_prime", "eta", "g"):
        col.prop(group, name)
    layout.prop(group, "profile")
    if multipole and group.profile == "MULTIPOLE":
        col = layout.column(align=True)
        for name in ("layer_thickness", "base_sigma_a", "base_sigma_s_prime"):
            col.prop(group, name)


def _converted(layout, m) -> None:
    """A medium converted from a Principled BSDF, read-only: the coefficients the engine draws."""
    col = layout.column(align=True)
    col.scale_y = 0.8
    col.label(text="Absorption: " + " ".join(f"{v:.4g}" for v in m.sigma_a) + " /mm")
    col.label(text="Reduced scattering: " + " ".join(f"{v:.4g}" for v in m.sigma_s_prime) + " /mm")
    col.label(text=f"IOR {m.eta:.3g}, anisotropy {m.g:.2g}; exact profile")
    for note in m.notes:
        col.label(text=note, icon="ERROR")


def _medium(layout, ob) -> None:
    """Where the object's medium comes from, and its settings where they are edited."""
    m = medium_source.resolve(ob)
    box = layout.box()
    box.label(text=m.reason, icon="MATERIAL" if m.source != "OBJECT" else "OBJECT_DATA")
    if m.source == "PRINCIPLED":
        _converted(box, m)
    elif m.source == "MATERIAL":
        _coefficients(box, medium_source.medium_material(ob).translucent)
    else:
        _coefficients(box, ob.translucent)
    _surface(box, ob)


def _surface(layout, ob) -> None:
    """What the last frame drew of the object's materials' surface (colour textures, gloss, normal maps) and what
    of them it could not draw (read from the session: the panel does not read meshes or images)."""
    known = [entry for key, entry in session.current().surfaces.items() if key[1] == ob.name]
    if not known:
        return
    surface = known[-1][1]
    parts = ["colour texture" if surface.albedo_map is not None else "",
             "normal map" if surface.normal_map is not None else "",
             "gloss" if surface.glossy else ""]
    drawn = ", ".join(p for p in parts if p)
    layout.label(text=f"Surface: {drawn or 'plain colour, no gloss'}", icon="SHADING_TEXTURE")
    for note in surface.notes:
        for line in _wrap(note, 60):
            layout.label(text=line, icon="ERROR")
    if any("Bake Textures" in note for note in surface.notes):
        layout.operator("translucent.bake_textures", icon="TEXTURE")


def draw_material(layout, context, mat) -> None:
    """A material's medium: where it comes from and its coefficients (the Material properties' panel)."""
    s = mat.translucent
    layout.prop(s, "source", expand=True)
    if s.source == "MATERIAL":
        _coefficients(layout, s)
    elif s.source == "OBJECT":
        layout.label(text="Each object's own coefficients, in its Object properties", icon="OBJECT_DATA")
    else:
        p, why = medium_source.principled_of(mat)
        if p is None:
            layout.label(text=f"{why[0].upper()}{why[1:]}: each object keeps its own coefficients", icon="INFO")
            if why == "Subsurface Weight 0":
                layout.label(text="Raise Subsurface Weight to convert the material's subsurface")
            return
        ob = context.object
        if ob is not None and ob.type == "MESH" and medium_source.medium_material(ob) == mat:
            _converted(layout, medium_source.resolve(ob))
        else:
            for note in p.notes:
                layout.label(text=note, icon="ERROR")


def _wrap(text: str, width: int) -> list[str]:
    """A long line in panel-sized pieces (a label does not wrap)."""
    import textwrap

    return textwrap.wrap(text, width) or [""]


def _grass_box(layout, ob) -> None:
    """Grass field: settings, BTF status and statistics, bake."""

    s = ob.translucent
    box = layout.box()
    box.prop(s, "grass")
    if not s.grass:
        box.operator("translucent.add_grass_field", icon="OUTLINER_OB_CURVES")
        return
    col = box.column(align=True)
    for name in ("grass_tile", "grass_blade_height", "grass_blades", "grass_seed", "grass_resolution",
                 "grass_target_error", "grass_lod"):
        col.prop(s, name)
    status, detail = grass_status(ob)
    if status == "INVALID":
        box.label(text=detail, icon="ERROR")
    elif status == "STALE":  # the grass's own settings changed, not the object
        box.label(text="Grass BTF is stale: the grass settings changed since it was baked", icon=_STATUS_ICON[status])
    else:
        box.label(text=_STATUS_TEXT[status], icon=_STATUS_ICON[status])
    meta = bake_files.read_meta(ob, grass_btf.BAKE_KEY)
    if meta is not None:
        col = box.column(align=True)
        col.scale_y = 0.8
        col.label(text=f"Eigen-textures: {meta['counts'][0]} Y, {meta['counts'][1]} Cb/Cr "
                       f"(error {meta.get('total_error', 0.0):.2f})")
        col.label(text=f"Stored: {meta['storage']['total'] / 2**20:.1f} MB of "
                       f"{meta['uncompressed_bytes'] / 2**20:.0f} MB; baked in {meta.get('seconds', 0.0):.0f} s")
    box.operator("translucent.bake_grass_btf", icon="RENDER_STILL")


def _length(mm: float, scene=None) -> str:
    """A length as the scene's unit system writes it (Blender's own units: inches and feet in an imperial scene),
    in the metric unit an artist would say it in when the scene has none."""
    system = scene.unit_settings.system if scene is not None else "NONE"
    if system != "NONE":
        return bpy.utils.units.to_string(system, "LENGTH", mm / 1000.0, precision=3)
    if mm >= 1000.0:
        return f"{mm / 1000.0:.3g} m"
    if mm >= 10.0:
        return f"{mm / 10.0:.3g} cm"
    return f"{mm:.3g} mm"


LAST_FRAME_WARNINGS = 6  # the last frame's warnings the panel lists; more are counted


def _last_frame(layout) -> None:
    """The last frame's warnings (the viewport has no other place to say them) and milliseconds per pass (F12 or
    viewport)."""
    held = session.current()
    lines = timing_lines(held.timings)
    box = layout.box()
    if not lines:
        box.label(text="Last frame: none drawn yet", icon="TIME")
        return
    col = box.column(align=True)
    for warning in held.warnings[:LAST_FRAME_WARNINGS]:
        for i, line in enumerate(_wrap(warning, 70)):
            col.label(text=line, icon="ERROR" if i == 0 else "BLANK1")
    if len(held.warnings) > LAST_FRAME_WARNINGS:
        col.label(text=f"... and {len(held.warnings) - LAST_FRAME_WARNINGS} more (F12 reports every one)",
                  icon="BLANK1")
    box.label(text=lines[0].strip(), icon="TIME")
    col = box.column(align=True)
    col.scale_y = 0.75
    for line in lines[1:9]:
        col.label(text=line.strip())


def _scene_general(layout, context) -> None:
    s = context.scene.translucent
    col = layout.column(align=True)
    col.prop(s, "shadow_resolution")
    col.prop(s, "area_light_samples")
    layout.prop(context.scene.render, "film_transparent")
    layout.prop(s, "bake_storage")
    row = layout.row(align=True)
    row.operator("translucent.bake_all", icon="RENDER_STILL")
    row.operator("translucent.bake_all", text="Bake Selected").selected_only = True
    layout.operator("translucent.purge_bakes", icon="TRASH")
    layout.prop(s, "instance_method")
    layout.prop(s, "fail_on_lost_objects")
    layout.prop(s, "light_passes")
    layout.prop(s, "overlay_other_engines")
    layout.operator_menu_enum("translucent.apply_quality", "tier", icon="PREFERENCES")


def _scene_technique(layout, context, technique) -> None:
    """A technique's Scene.translucent properties as it lays them out, what it says of the last frame after the
    first column."""
    for i, names in enumerate(technique.scene_panel):
        col = layout.column(align=True)
        for name in names:
            col.prop(context.scene.translucent, name)
        if i == 0:
            for line in technique.scene_panel_notes(session.current().results.get(technique.id, {})):
                col.label(text=line, icon="INFO")


def _technique_section(technique):
    return technique.scene_panel_label or technique.label, lambda layout, context: _scene_technique(
        layout, context, technique)


def scene_sections() -> list:
    """(label, draw) of the scene's settings in sections: each technique's that has any, then the last frame."""
    return [_technique_section(t) for t in techniques.REGISTRY if t.scene_panel] + [("Last Frame", _scene_last_frame)]


def _scene_last_frame(layout, context) -> None:
    _last_frame(layout)


def _demo_buttons(layout) -> None:
    """The demo scenes: where a new user starts (the top of the sidebar's tab, the Render panel, an empty
    selection)."""
    row = layout.row(align=True)
    row.operator("translucent.add_demo_scene", icon="SCENE_DATA").kind = "BUNNY"
    row.operator("translucent.add_demo_scene", text="Caustics Demo", icon="LIGHT_POINT").kind = "GLASS_BALL"


# The scene's settings in sections: each a sub-panel of the Render properties (those registered with the
# extension), all of them in the sidebar (a technique registered later too).
SCENE_SECTIONS = tuple(scene_sections())


class _InSidebar:
    """A panel of the 3D viewport sidebar's Translucent tab."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Translucent"


class VIEW3D_PT_translucent_demo(_InSidebar, bpy.types.Panel):
    """The first thing in the sidebar's tab: the demo scenes a new user starts from."""

    bl_label = "Demo Scenes"

    def draw(self, context):
        _demo_buttons(self.layout)


class VIEW3D_PT_translucent_object(_InSidebar, bpy.types.Panel):
    """The sidebar's shortcut to the Object properties' Translucent panel (its sections as sub-panels)."""

    bl_label = "Translucent Object"

    def draw(self, context):
        _object_head(self.layout, context.active_object)


class VIEW3D_PT_translucent_scene(_InSidebar, bpy.types.Panel):
    """The sidebar's shortcut to the Render properties' Translucent panels."""

    bl_label = "Translucent Scene"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        _scene_general(self.layout, context)
        for label, draw in scene_sections():
            self.layout.label(text=label)
            draw(self.layout, context)


class _OursInProperties:
    """A panel of the Properties editor shown only while our engine renders the scene."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {"TRANSLUCENT_RT"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class RENDER_PT_translucent(_OursInProperties, bpy.types.Panel):
    bl_label = "Translucent"
    bl_context = "render"

    def draw(self, context):
        _demo_buttons(self.layout)
        self.layout.use_property_split = True
        _scene_general(self.layout, context)


class _Section(_OursInProperties):
    """A sub-panel of RENDER_PT_translucent drawing one of SCENE_SECTIONS."""

    bl_context = "render"
    bl_parent_id = "RENDER_PT_translucent"
    bl_options = {"DEFAULT_CLOSED"}
    section = None

    def draw(self, context):
        self.layout.use_property_split = True
        type(self).section(self.layout, context)


def _section_panel(label: str, draw) -> type:
    return type(f"RENDER_PT_translucent_{label.lower().replace(' ', '_')}", (_Section, bpy.types.Panel),
                {"bl_label": label, "section": staticmethod(draw)})


class MATERIAL_PT_translucent(_OursInProperties, bpy.types.Panel):
    bl_label = "Translucent Medium"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and getattr(context, "material", None) is not None

    def draw(self, context):
        draw_material(self.layout, context, context.material)


class OBJECT_PT_translucent(_OursInProperties, bpy.types.Panel):
    bl_label = "Translucent"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        ob = context.object
        return super().poll(context) and ob is not None and ob.type in {"MESH", "LIGHT"}

    def draw(self, context):
        _object_head(self.layout, context.object)


def _object_section_panel(parent: type, section) -> type:
    """A sub-panel of ``parent`` drawing one of OBJECT_SECTIONS for the parent's object (the Properties editor's
    object, or the sidebar's active one)."""
    label, shows, draw, is_open = section
    in_properties = parent.bl_space_type == "PROPERTIES"

    def object_of(context):
        return context.object if in_properties else context.active_object

    def poll(cls, context):
        ob = object_of(context)
        if ob is None or ob.type != "MESH" or (in_properties and not parent.poll(context)):
            return False
        return shows is None or shows(ob)

    attributes = {"bl_label": label, "bl_parent_id": parent.__name__, "bl_space_type": parent.bl_space_type,
                  "bl_region_type": parent.bl_region_type, "bl_options": set() if is_open else {"DEFAULT_CLOSED"},
                  "poll": classmethod(poll),
                  "draw": lambda self, context: draw(self.layout, context, object_of(context))}
    for name in ("bl_context", "bl_category", "COMPAT_ENGINES"):
        if hasattr(parent, name):
            attributes[name] = getattr(parent, name)
    name = f"{parent.__name__}_{label.lower().replace(' ', '_')}"
    return type(name, (bpy.types.Panel,), attributes)


classes = (VIEW3D_PT_translucent_demo, VIEW3D_PT_translucent_object,
           *(_object_section_panel(VIEW3D_PT_translucent_object, section) for section in OBJECT_SECTIONS),
           VIEW3D_PT_translucent_scene, RENDER_PT_translucent,
           *(_section_panel(label, draw) for label, draw in SCENE_SECTIONS), OBJECT_PT_translucent,
           *(_object_section_panel(OBJECT_PT_translucent, section) for section in OBJECT_SECTIONS),
           MATERIAL_PT_translucent)

# Blender's own panels show only for the engines in their COMPAT_ENGINES. Ours is added beside EEVEE's where the
# panel acts for it: everything generic (output, object data, physics, particles, textures) and, of the render-
# specific ones, what the engine reads: colour management and simplify, the lights' type, colour, power, size and
# spot shape, the world's and the materials' surface nodes and slots. EEVEE's own settings (sampling, raytracing,
# volumes, light probes, its light and shadow options, material blend modes, passes) do nothing here, so these
# stay EEVEE's (by name prefix; a child of a panel left out is left out with it).
NOT_OURS = ("RENDER_PT_eevee", "RENDER_PT_freestyle", "RENDER_PT_gpencil", "RENDER_PT_grease_pencil",
            "RENDER_PT_simplify_greasepencil", "RENDER_PT_stereoscopy", "RENDER_PT_output_views",
            "VIEWLAYER_PT_eevee", "VIEWLAYER_PT_freestyle", "VIEWLAYER_PT_layer_passes", "VIEWLAYER_PT_filter",
            "DATA_PT_EEVEE_light_", "DATA_PT_lightprobe", "DATA_PT_context_lightprobe", "DATA_PT_camera_dof",
            "DATA_PT_camera_stereoscopy", "DATA_PT_preview", "DATA_PT_volume_render", "EEVEE_MATERIAL_PT_settings",
            "EEVEE_MATERIAL_PT_displacement", "EEVEE_MATERIAL_PT_thickness", "EEVEE_MATERIAL_PT_volume",
            "MATERIAL_PT_preview", "MATERIAL_PT_freestyle", "EEVEE_WORLD_PT_mist", "EEVEE_WORLD_PT_settings",
            "EEVEE_WORLD_PT_sun", "EEVEE_WORLD_PT_volume", "EEVEE_WORLD_PT_lightprobe", "OBJECT_PT_shading",
            "OBJECT_PT_shadow_terminator", "SCENE_PT_eevee", "NODE_EEVEE", "VIEW3D_PT_shading_render_pass")
_ENGINE = "TRANSLUCENT_RT"


def _eevee_panels():
    """Blender's panels shown for EEVEE that act for our engine too (their COMPAT_ENGINES, a set)."""
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if not panel.__name__.startswith(NOT_OURS) and isinstance(engines, set) and engines.intersection(EEVEE_IDS):
            yield panel


def register_compat_panels() -> None:
    for panel in _eevee_panels():
        panel.COMPAT_ENGINES.add(_ENGINE)


def unregister_compat_panels() -> None:
    """Our engine out of every panel it was added to (found again: no list of them is kept)."""
    for panel in _eevee_panels():
        panel.COMPAT_ENGINES.discard(_ENGINE)

"""translucent.set_physical_size, translucent.apply_quality and translucent.auto_quality: the size helper,
quality tiers and AUTO quality."""
import bpy

from ..translucent_addon import techniques
from ..translucent_addon.blender import medium_source, preferences, props
from ..translucent_addon.blender.quality_apply import apply_auto
from ..translucent_addon.core import quality
from ..translucent_addon.core.physics import presets
from ..translucent_addon.techniques.registry import BakeInputError
from . import polls


class TRANSLUCENT_OT_set_physical_size(bpy.types.Operator):
    """Say how big the active object really is: sets its scattering scale so that light scatters in it as in
    an object of this size (a 5 cm bunny is not a 5 m one)"""

    bl_idname = "translucent.set_physical_size"
    bl_label = "Set Real Size"
    bl_options = {"REGISTER", "UNDO"}

    size: bpy.props.FloatProperty(name="Longest side", min=1e-6, soft_max=10.0, default=0.05, subtype="DISTANCE",
                                  unit="LENGTH", description="How long the object's longest side is in reality")

    @classmethod
    def poll(cls, context):
        if not polls.mesh(cls, context, "size"):
            return False
        ob = context.active_object
        return max(ob.dimensions) > 0.0 or polls.refuse(cls, f"'{ob.name}' has no extent")

    def invoke(self, context, event):
        ob = context.active_object
        if ob is not None and max(ob.dimensions) > 0 and ob.translucent.scattering_scale > 0:
            self.size = max(ob.dimensions) / ob.translucent.scattering_scale
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        ob = context.active_object
        if ob is None or ob.type != "MESH":
            self.report({"ERROR"}, "no active mesh: select the object whose size you know")
            return {"CANCELLED"}
        longest = max(ob.dimensions)
        if longest <= 0.0:
            self.report({"ERROR"}, f"'{ob.name}' has no extent (all its vertices are in one point)")
            return {"CANCELLED"}
        # Light scatters in the model as in the real object: lengths in the medium scale by longest / size.
        ob.translucent.scattering_scale = longest / self.size
        size_mm = self.size * medium_source.unit_mm(context.scene)
        self.report({"INFO"}, f"'{ob.name}': scattering scale {ob.translucent.scattering_scale:.4g}, longest side "
                              f"{size_mm:g} mm")
        return {"FINISHED"}


class TRANSLUCENT_OT_apply_quality(bpy.types.Operator):
    """Set the scene's and the active object's resolutions to a quality tier (Draft, Standard, High)"""

    bl_idname = "translucent.apply_quality"
    bl_label = "Apply Quality"
    bl_options = {"REGISTER", "UNDO"}

    tier: bpy.props.EnumProperty(
        name="Quality", items=[(t, t.capitalize(), "") for t in quality.TIERS] + [("DEFAULT", "Default",
                                                                                    "The preferences' default")],
        default="DEFAULT", description="The tier whose resolutions to set",
    )

    @classmethod
    def poll(cls, context):
        return context.scene is not None or polls.refuse(cls, "no scene")

    def execute(self, context):
        tier = self.tier
        if tier == "DEFAULT":
            prefs = preferences.get(context)
            tier = prefs.default_quality if prefs is not None else "STANDARD"
        quality.apply(context.scene.translucent, techniques.tier_table("scene"), tier)
        ob = context.active_object
        if ob is not None and ob.type == "MESH":
            quality.apply(ob.translucent, techniques.tier_table("object"), tier)
        self.report({"INFO"}, f"quality {tier.capitalize()} applied")
        return {"FINISHED"}


class TRANSLUCENT_OT_auto_quality(bpy.types.Operator):
    """Choose resolutions for the objects whose quality is Auto (the active one, or every one in the scene):
    the least cost that reaches each object's target error, from its material, its size on the camera's image
    and the benchmark's measured curves"""

    bl_idname = "translucent.auto_quality"
    bl_label = "Choose Resolutions"
    bl_options = {"REGISTER", "UNDO"}

    all_objects: bpy.props.BoolProperty(name="Every Auto object", default=False,
                                        description="Every mesh of the scene whose quality is Auto, not only the "
                                                    "active one")

    @classmethod
    def poll(cls, context):
        return context.scene is not None or polls.refuse(cls, "no scene")

    def execute(self, context):
        if self.all_objects:  # those with something to choose: a method, or a grass field
            objects = [o for o in context.scene.objects if o.type == "MESH" and o.translucent.quality == "AUTO"
                       and (o.translucent.method != "OFF" or o.translucent.grass)]
        else:
            ob = context.active_object
            objects = [ob] if ob is not None and ob.type == "MESH" else []
        if not objects:
            self.report({"ERROR"}, "no mesh to choose resolutions for: select one, or set an object's Quality to Auto")
            return {"CANCELLED"}
        chosen = 0
        for ob in objects:  # one object's problem is reported and the others still get theirs
            try:
                choice = apply_auto(context, ob)
            except BakeInputError as err:
                self.report({"ERROR"} if not self.all_objects else {"WARNING"}, str(err))
                continue
            chosen += 1
            self.report({"INFO"}, f"'{ob.name}' {choice.method}: {choice.summary()}")
        return {"FINISHED"} if chosen else {"CANCELLED"}


def _medium_group(context):
    """(the property group whose preset the button acts on, None) or (None, why not): the group the panel
    drew the button for (``translucent_medium`` in the layout's context: a material's or an object's), else the
    active object's medium where it is edited (``medium_source.editable``)."""
    group = getattr(context, "translucent_medium", None)
    if group is not None:
        return group, None
    ob, why = polls.active_mesh(context, "save its medium")
    if ob is None:
        return None, why
    group = medium_source.editable(ob)
    if group is None:
        return None, (f"'{ob.name}': its medium is converted from the Principled BSDF of "
                      f"'{medium_source.medium_material(ob).name}'; set it there, or choose Coefficients")
    return group, None


class TRANSLUCENT_OT_save_preset(bpy.types.Operator):
    """Save the medium's coefficients as your own preset (kept in the extension's user folder, listed under Preset
    in every file)"""

    bl_idname = "translucent.save_preset"
    bl_label = "Save Preset"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Name", default="My material", description="The preset's name in the list")

    @classmethod
    def poll(cls, context):
        group, why = _medium_group(context)
        return True if group is not None else polls.refuse(cls, why)

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        s, why = _medium_group(context)
        if s is None:
            self.report({"ERROR"}, why)
            return {"CANCELLED"}
        mat = presets.Material(self.name.strip(), tuple(s.sigma_a), tuple(s.sigma_s_prime), float(s.eta), float(s.g))
        try:
            presets.save_user_preset(props.user_presets_path(), mat)
        except (presets.CoefficientError, presets.PresetFileError) as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        props.refresh_preset_items()
        s.preset = presets.USER_PREFIX + mat.name
        self.report({"INFO"}, f"preset '{mat.name}' saved in {props.user_presets_path()}")
        return {"FINISHED"}


def _user_preset(context):
    """(the group whose preset is a user preset, None) or (None, why not)."""
    group, why = _medium_group(context)
    if group is not None and not group.preset.startswith(presets.USER_PREFIX):
        return None, "the medium's preset is not one of yours: only user presets can be removed"
    return group, why


class TRANSLUCENT_OT_remove_preset(bpy.types.Operator):
    """Remove the medium's user preset from the list (its coefficients stay where they are set)"""

    bl_idname = "translucent.remove_preset"
    bl_label = "Remove Preset"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        group, why = _user_preset(context)
        return True if group is not None else polls.refuse(cls, why)

    def execute(self, context):
        group, why = _user_preset(context)
        if group is None:
            self.report({"ERROR"}, why)
            return {"CANCELLED"}
        name = group.preset
        try:
            presets.remove_user_preset(props.user_presets_path(), name[len(presets.USER_PREFIX):])
        except presets.PresetFileError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        group.preset = "CUSTOM"  # before the list changes under it
        props.refresh_preset_items()
        self.report({"INFO"}, f"preset '{name[len(presets.USER_PREFIX):]}' removed")
        return {"FINISHED"}


classes = (TRANSLUCENT_OT_set_physical_size, TRANSLUCENT_OT_apply_quality, TRANSLUCENT_OT_auto_quality,
           TRANSLUCENT_OT_save_preset,
           TRANSLUCENT_OT_remove_preset)

"""Add-on preferences: cache folder, default quality, timing overlay, purging bake files on save (Edit >
Preferences > Add-ons)."""
import bpy

from ..core.quality import TIERS

# The extension's root package (this file is <root>.translucent_addon.blender.preferences).
ROOT_PACKAGE = __package__.rsplit(".translucent_addon", 1)[0]


class TranslucentPreferences(bpy.types.AddonPreferences):
    bl_idname = ROOT_PACKAGE

    cache_folder: bpy.props.StringProperty(
        name="Cache folder", subtype="DIR_PATH", default="",
        description="Where Compare with Cycles keeps its reference renders (empty: next to each report)",
    )
    default_quality: bpy.props.EnumProperty(
        name="Default quality",
        description="Resolutions set when a method is chosen for an object, and by Apply Quality for the scene",
        items=[(t, t.capitalize(), f"{t.capitalize()} resolutions of every method") for t in TIERS],
        default="STANDARD",
    )
    timing_overlay: bpy.props.BoolProperty(
        name="Timing overlay", default=False,
        description="Show the last frame's milliseconds per pass in the corner of the 3D viewport",
    )
    purge_on_save: bpy.props.BoolProperty(
        name="Purge bake files on save", default=True,
        description="When a file is saved, delete the files in its bake folder that its objects stopped using "
                    "before this session (those Undo could still need are kept)",
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "cache_folder")
        layout.prop(self, "default_quality")
        layout.prop(self, "timing_overlay")
        layout.prop(self, "purge_on_save")


def get(context=None):
    """The preferences, or None when the extension is not enabled under its package name."""
    context = context or bpy.context
    addon = context.preferences.addons.get(ROOT_PACKAGE)
    return addon.preferences if addon is not None else None


classes = (TranslucentPreferences,)

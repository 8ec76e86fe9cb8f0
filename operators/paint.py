"""translucent.add_paint_layer: create a paint layer for heterogeneous translucency and start painting.

Weight Paint layers (vertex groups): translucent_blur (spread, up to 4x), translucent_glow (brightness,
up to 4x), translucent_mask (where the object is translucent; absent: everywhere). Vertex Paint layer
(colour attribute): translucent_tint (RGB). They are read by IMAGE_SPACE (Shah ch. 7, Eq. 7.4) and by
QUADGRAPH, which carries them into its volume.
"""
import bpy

from ..translucent_addon import techniques
from ..translucent_addon.blender.extract import BLUR_GROUP, GLOW_GROUP, MASK_GROUP, TINT_ATTRIBUTE
from . import polls

LAYERS = (
    (BLUR_GROUP, "Blur", "Weight Paint: spread the scattering up to 4x where painted"),
    (GLOW_GROUP, "Glow", "Weight Paint: brighten the scattering up to 4x where painted"),
    (MASK_GROUP, "Mask", "Weight Paint: translucent where painted, opaque elsewhere"),
    (TINT_ATTRIBUTE, "Tint", "Vertex Paint: colour the scattered light"),
)


class TRANSLUCENT_OT_add_paint_layer(bpy.types.Operator):
    """Create the chosen paint layer on the active mesh (if missing), make it active and enter its paint mode"""

    bl_idname = "translucent.add_paint_layer"
    bl_label = "Paint Translucency"
    bl_options = {"REGISTER", "UNDO"}

    layer: bpy.props.EnumProperty(name="Layer", items=LAYERS, default=BLUR_GROUP,
                                  description="Which property of the translucency to paint")
    enter_paint_mode: bpy.props.BoolProperty(name="Enter paint mode", default=True,
                                             description="Switch to Weight or Vertex Paint for the layer")

    @classmethod
    def poll(cls, context):
        return polls.mesh(cls, context, "paint")

    def execute(self, context):
        ob = context.active_object
        if ob is None or ob.type != "MESH":
            self.report({"ERROR"}, "select a mesh object to paint")
            return {"CANCELLED"}
        if self.layer == TINT_ATTRIBUTE:
            attr = ob.data.color_attributes.get(TINT_ATTRIBUTE)
            if attr is None:
                attr = ob.data.color_attributes.new(TINT_ATTRIBUTE, "FLOAT_COLOR", "POINT")
                ones = [1.0] * (4 * len(attr.data))
                attr.data.foreach_set("color", ones)  # neutral until painted
            ob.data.color_attributes.active_color = attr
            mode = "VERTEX_PAINT"
        else:
            group = ob.vertex_groups.get(self.layer) or ob.vertex_groups.new(name=self.layer)
            ob.vertex_groups.active_index = group.index
            mode = "WEIGHT_PAINT"
        if ob.translucent.method == "OFF":
            ob.translucent.method = method = techniques.default_method()
            self.report({"INFO"}, f"'{ob.name}': method set to {techniques.method_label(method)}, which draws "
                                  f"painted translucency")
        if self.enter_paint_mode and context.mode != "PAINT_" + mode.split("_")[0]:
            if bpy.ops.object.mode_set.poll():
                bpy.ops.object.mode_set(mode=mode)
        return {"FINISHED"}


classes = (TRANSLUCENT_OT_add_paint_layer,)

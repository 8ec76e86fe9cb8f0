"""translucent.add_demo_scene: the bundled back-lit marble bunny, in a new scene."""

import bpy

from ..translucent_addon.demo import build_default_scene


class TRANSLUCENT_OT_add_demo_scene(bpy.types.Operator):
    """Add a new scene with a back-lit marble Stanford bunny rendered by Translucent"""

    bl_idname = "translucent.add_demo_scene"
    bl_label = "Add Demo Scene"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        scene = build_default_scene()
        if context.window is not None:
            context.window.scene = scene
        self.report({"INFO"}, f"Added scene '{scene.name}'")
        return {"FINISHED"}


classes = (TRANSLUCENT_OT_add_demo_scene,)

"""translucent.add_demo_scene: a bundled scene (the back-lit marble bunny, or caustics), in a new scene."""

import bpy

from ..translucent_addon.blender.demo import build_caustics_scene, build_default_scene


class TRANSLUCENT_OT_add_demo_scene(bpy.types.Operator):
    """Add a new scene with a demo rendered by Translucent"""

    bl_idname = "translucent.add_demo_scene"
    bl_label = "Add Demo Scene"
    bl_options = {"REGISTER", "UNDO"}

    KINDS = (("BUNNY", "Marble bunny", "A back-lit marble Stanford bunny on a ground plane"),
             ("GLASS_BALL", "Caustics", "A glass ball over a white floor under a small lamp"),
             ("GLASS_BUNNY", "Caustics: glass bunny", "A glass Stanford bunny throwing caustics"))
    kind: bpy.props.EnumProperty(name="Scene", description="Which demo scene to add", items=KINDS, default="BUNNY")

    @classmethod
    def description(cls, context, properties):
        """The tooltip of the button: what its scene holds."""
        return "Add a new scene: " + next(d for k, _, d in cls.KINDS if k == properties.kind).lower()

    @classmethod
    def poll(cls, context):
        return True  # a new scene can always be added

    def execute(self, context):
        if self.kind == "BUNNY":
            scene = build_default_scene()
        else:
            scene = build_caustics_scene(caster="bunny" if self.kind == "GLASS_BUNNY" else "sphere")
        if context.window is not None:
            context.window.scene = scene
        self.report({"INFO"}, f"Added scene '{scene.name}'")
        return {"FINISHED"}


classes = (TRANSLUCENT_OT_add_demo_scene,)

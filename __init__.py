"""Translucent: real-time translucency for Blender (extension root).

Registration only: every class comes from an explicit tuple of its module.
"""
from .operators import bake as _op_bake
from .operators import compare as _op_compare
from .operators import demo as _op_demo
from .operators import grass as _op_grass
from .operators import paint as _op_paint
from .operators import workflow as _op_workflow
from .translucent_addon import techniques as _techniques
from .translucent_addon.blender import bake_files as _bake_files
from .translucent_addon.blender import draw_handler as _draw_handler
from .translucent_addon.blender import engine as _engine
from .translucent_addon.blender import preferences as _preferences
from .translucent_addon.blender import props as _props
from .translucent_addon.blender import session as _session
from .translucent_addon.blender import ui as _ui
from .translucent_addon.blender import versioning as _versioning
from .translucent_addon.gpu import bake_cache as _bake_cache
from .translucent_addon.gpu import environment as _environment
from .translucent_addon.gpu import shaders as _shaders

_classes = (
    *_preferences.classes,
    *_props.classes,
    *_op_bake.classes,
    *_op_compare.classes,
    *_op_demo.classes,
    *_op_grass.classes,
    *_op_paint.classes,
    *_op_workflow.classes,
    *_engine.classes,
    *_ui.classes,
)


def register():
    import bpy

    for cls in _classes:
        bpy.utils.register_class(cls)
    _props.register_pointers()
    _ui.register_compat_panels()
    _draw_handler.register()
    _bake_files.register()
    _versioning.register()
    _session.register()


def unregister():
    import bpy

    _versioning.unregister()
    _bake_files.unregister()
    _draw_handler.unregister()
    _techniques.clear_caches()
    _bake_cache.clear()
    _environment.clear_cache()
    _shaders.free_all()
    _ui.unregister_compat_panels()
    _props.unregister_pointers()
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
    _session.unregister()  # last: what the steps above took from it goes with it

"""SpaceView3D draw handler: our objects over the viewport of other engines.

When the scene's engine is not TRANSLUCENT_RT (say EEVEE in Material Preview)
and ``Scene.translucent.overlay_other_engines`` is on, objects with a
translucency method are drawn by the same pipeline into the viewport's
framebuffer, depth-tested against what the engine drew.
"""
from __future__ import annotations

import bpy

from . import extract
from .pipeline import Pipeline

_handle = None
_pipeline: Pipeline | None = None


def _draw():
    global _pipeline
    context = bpy.context
    scene = context.scene
    if scene is None or scene.render.engine == "TRANSLUCENT_RT" or not scene.translucent.overlay_other_engines:
        return
    region, rv3d = context.region, context.region_data
    if region is None or rv3d is None:
        return
    depsgraph = context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.viewport_camera(region, rv3d), only_translucent=True)
    if not frame.meshes:
        return
    if _pipeline is None:
        _pipeline = Pipeline()
    _pipeline.forget({m.key for m in frame.meshes})
    _pipeline.draw(frame, clear=False)


def register() -> None:
    global _handle
    if _handle is None:
        _handle = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_VIEW")


def unregister() -> None:
    global _handle, _pipeline
    if _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, "WINDOW")
        _handle = None
    if _pipeline is not None:
        _pipeline.free()
        _pipeline = None


def is_registered() -> bool:
    return _handle is not None

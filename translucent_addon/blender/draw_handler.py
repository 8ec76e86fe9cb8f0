"""SpaceView3D draw handler: our objects over the viewport of other engines.

When the scene's engine is not TRANSLUCENT_RT (say EEVEE in Material Preview)
and ``Scene.translucent.overlay_other_engines`` is on, objects with a
translucency method are drawn by the same pipeline into the viewport's
framebuffer, depth-tested against what the engine drew.
"""
from __future__ import annotations

import dataclasses

import bpy

from ..pipeline import Pipeline
from . import extract, preferences
from .engine import draw_settings
from .session import current as current_session


def _draw():
    context = bpy.context
    scene = context.scene
    if scene is None or scene.render.engine == "TRANSLUCENT_RT" or not scene.translucent.overlay_other_engines:
        return
    region, rv3d = context.region, context.region_data
    if region is None or rv3d is None:
        return
    frame = overlay_frame(context.evaluated_depsgraph_get(), extract.viewport_camera(region, rv3d))
    if not frame.meshes:
        return
    session = current_session()
    if session.overlay_pipeline is None:
        session.overlay_pipeline = Pipeline()
    session.overlay_pipeline.forget({m.key for m in frame.meshes}, {m.source for m in frame.meshes})
    session.overlay_pipeline.draw(frame, clear=False)


def overlay_frame(depsgraph, camera):
    """The translucent objects of the scene for the overlay, with the scene's settings (its splat overlap and
    Auto, texture product, QUADGRAPH tolerance, temporal coherence), as the engine's viewport draws them."""
    session = current_session()
    frame = extract.frame_inputs(depsgraph, camera, only_translucent=True, session=session)
    session.overlay_frames += 1
    return dataclasses.replace(frame, settings=draw_settings(depsgraph.scene, frame, "overlay",
                                                             session.overlay_frames, False, session))


def timing_lines(timings: dict) -> list[str]:
    """The overlay's text: total first, then the passes by time spent, in milliseconds."""
    if not timings:
        return []
    passes = sorted(((k, v) for k, v in timings.items() if k not in {"total", "source"} and isinstance(v, float)),
                    key=lambda kv: -kv[1])
    lines = [f"Translucent ({timings.get('source', '')}): {1000 * timings.get('total', 0.0):.1f} ms"]
    return lines + [f"  {name}: {1000 * sec:.1f} ms" for name, sec in passes]


def _draw_overlay():
    """Timing overlay (preferences): the last frame's milliseconds per pass, top left of the viewport."""
    import blf

    prefs = preferences.get()
    if prefs is None or not prefs.timing_overlay:
        return
    region = bpy.context.region
    if region is None:
        return
    font = 0
    blf.size(font, 12)
    blf.color(font, 1.0, 1.0, 1.0, 0.9)
    y = region.height - 60
    for line in timing_lines(current_session().timings):
        blf.position(font, 20, y, 0)
        blf.draw(font, line)
        y -= 16


def register() -> None:
    handlers = current_session().handlers
    if "draw" not in handlers:
        handlers["draw"] = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_VIEW")
    if "overlay" not in handlers:
        handlers["overlay"] = bpy.types.SpaceView3D.draw_handler_add(_draw_overlay, (), "WINDOW", "POST_PIXEL")


def unregister() -> None:
    session = current_session()
    for handle in session.handlers.values():
        bpy.types.SpaceView3D.draw_handler_remove(handle, "WINDOW")
    session.handlers.clear()
    if session.overlay_pipeline is not None:
        session.overlay_pipeline.free()
        session.overlay_pipeline = None


def is_registered() -> bool:
    return bool(current_session().handlers)

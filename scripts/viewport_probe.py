"""The viewport's code path, headless: tests and the frame benchmark draw through it.

A 3D viewport cannot open without a window, and Blender's ``gpu`` module draws headless only inside
``RenderEngine.render()`` of an engine with a GPU context. ``ViewportProbe`` is such an engine: its F12 runs
what TRANSLUCENT_RT's ``view_update`` and ``view_draw`` run (``engine.Viewport.update`` with recorded depsgraph
updates, then ``Viewport.draw`` with the region's pixel-space matrices) into an offscreen the size of the
scene's resolution, and hands back its pixels. The ``Viewport`` persists between frames, as in a viewport.
"""
from __future__ import annotations

import time
import types

import numpy as np

PROBE: dict = {}  # "viewport": the engine.Viewport kept across frames; "updates" in; "pixels", "seconds" out
ENGINE_ID = "TRANSLUCENT_VIEWPORT_PROBE"


def engine_class(engine, extract, targets):
    """The probe engine, over the installed extension's ``blender.engine``, ``blender.extract`` and
    ``gpu.targets`` modules."""
    import bpy

    class ViewportProbe(bpy.types.RenderEngine):
        bl_idname = ENGINE_ID
        bl_label = "Translucent viewport probe"
        bl_use_gpu_context = True

        def render(self, depsgraph):
            import gpu
            from mathutils import Matrix

            r = depsgraph.scene.render
            w = max(1, int(r.resolution_x * r.resolution_percentage / 100))
            h = max(1, int(r.resolution_y * r.resolution_percentage / 100))
            viewport = PROBE.setdefault("viewport", engine.Viewport())
            off = gpu.types.GPUOffScreen(w, h, format="RGBA32F")
            try:
                with off.bind(), gpu.matrix.push_pop(), gpu.matrix.push_pop_projection():
                    fb = gpu.state.active_framebuffer_get()
                    fb.clear(color=(0.0, 0.0, 0.0, 0.0))
                    # The region's pixel space, as Blender sets it for view_draw.
                    gpu.matrix.load_identity()
                    gpu.matrix.load_projection_matrix(Matrix(((2 / w, 0, 0, -1), (0, 2 / h, 0, -1), (0, 0, -1, 0),
                                                              (0, 0, 0, 1))))
                    t0 = time.perf_counter()
                    viewport.update(PROBE.pop("updates", []))  # view_update
                    viewport.draw(depsgraph, extract.render_camera(depsgraph, w, h), (w, h), lambda: None,
                                  lambda: None)  # view_draw
                    with fb.bind():  # as Blender binds the region's framebuffer again for what it draws next
                        PROBE["pixels"] = targets.read_pixels(fb, w, h)
                    PROBE["seconds"] = time.perf_counter() - t0
            finally:
                off.free()
            result = self.begin_result(0, 0, w, h)
            result.layers[0].passes["Combined"].rect.foreach_set(PROBE["pixels"].reshape(-1))
            self.end_result(result)

    return ViewportProbe


def frame(scene, render, updates=()) -> np.ndarray:
    """One viewport frame of ``scene`` after ``updates`` (``update_of`` records), through ``render(scene)``
    (an F12 that returns pixels); the probe engine must be registered."""
    PROBE["updates"] = list(updates)
    engine = scene.render.engine
    scene.render.engine = ENGINE_ID
    try:
        render(scene)
    finally:
        scene.render.engine = engine
    return PROBE["pixels"]


def update_of(datablock, geometry: bool = True, transform: bool = False, shading: bool = False):
    """A recorded ``DepsgraphUpdate``: what ``view_update`` reads of one."""
    return types.SimpleNamespace(id=datablock, is_updated_geometry=geometry, is_updated_transform=transform,
                                 is_updated_shading=shading)

"""The render engine TRANSLUCENT_RT: F12, batch and the viewport, one pipeline."""
from __future__ import annotations

import contextlib
import dataclasses

import bpy
import numpy as np

from ..core.frame import DrawSettings
from ..pipeline import Pipeline, draw_to_region, render_offscreen
from ..techniques import REGISTRY
from ..techniques.image_space import quality as image_space_auto
from ..techniques.image_space.model import SamplingSettings
from . import extract

# Read-backs of the last F12's intermediate passes when Scene.translucent.capture_passes is on.
LAST_CAPTURE: dict = {}
# Seconds per pass of the last frame drawn (F12 or viewport), for the sidebar and the timing overlay.
LAST_TIMINGS: dict = {}
# IMAGE_SPACE's splat overlap of the last frame drawn, where AUTO objects chose it: {objects: {name: k},
# overlap, max_grid}; empty when none did.
LAST_AUTO_OVERLAP: dict = {}


def _keep_timings(pipeline, source: str) -> None:
    LAST_TIMINGS.clear()
    LAST_TIMINGS.update(pipeline.last_timings)
    LAST_TIMINGS["source"] = source


def auto_sampling(frame, manual: SamplingSettings) -> SamplingSettings:
    """IMAGE_SPACE's sampling for this frame: k as its AUTO objects need it seen by its camera
    (``image_space_auto``), what they asked for kept in LAST_AUTO_OVERLAP for the panel."""
    sampling, asked = image_space_auto.frame_sampling(frame, manual)
    LAST_AUTO_OVERLAP.clear()
    if asked:
        LAST_AUTO_OVERLAP.update(objects=asked, overlap=sampling.overlap, max_grid=sampling.max_grid)
    return sampling


def technique_settings(scene) -> dict:
    """Each registered technique's settings, made from the Scene.translucent properties it declares."""
    s = scene.translucent
    return {t.id: t.settings({name: getattr(s, name) for name in t.scene_properties}) for t in REGISTRY
            if t.scene_properties}


def draw_settings(scene, frame, coherence_key: str, coherence_frame: int, capture: bool) -> DrawSettings:
    """What travels with the frame: the techniques' settings (IMAGE_SPACE's k chosen for this frame's
    camera), the sample-coherence sequence (when the scene asks for it) and whether to read passes back."""
    techniques = technique_settings(scene)
    techniques["IMAGE_SPACE"] = auto_sampling(frame, techniques["IMAGE_SPACE"])
    return DrawSettings(techniques, coherence_key if scene.translucent.temporal_coherence else None,
                        coherence_frame, capture)


class TranslucentRenderEngine(bpy.types.RenderEngine):
    bl_idname = "TRANSLUCENT_RT"
    bl_label = "Translucent"
    bl_use_gpu_context = True  # a GPU context in render(), also headless (-b)
    bl_use_preview = False
    bl_use_eevee_viewport = False
    bl_use_shading_nodes_custom = False  # keep Blender's material nodes

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._pipeline = None
        self._viewport_frame = 0  # the viewport's frames, for IMAGE_SPACE's sample coherence
        self.last_frame = None

    def __del__(self):
        # GPU objects are freed by their own destructors; drop references only (Blender may have
        # removed the engine's struct already, at exit).
        with contextlib.suppress(ReferenceError):
            self._pipeline = None

    def _get_pipeline(self) -> Pipeline:
        if self._pipeline is None:
            self._pipeline = Pipeline()
        return self._pipeline

    # -- F12 and batch -----------------------------------------------------
    def render(self, depsgraph):
        scene = depsgraph.scene
        scale = scene.render.resolution_percentage / 100.0
        width = max(1, int(scene.render.resolution_x * scale))
        height = max(1, int(scene.render.resolution_y * scale))
        try:
            self._render_frame(depsgraph, width, height)
        except BaseException:
            # Blender 5.0.1 writes the frame after render() returns, and saving an OpenEXR frame that
            # has no result crashes it (segmentation fault in BKE_image_render_write_exr): leave an
            # empty frame, then let the error show as Blender reports it.
            self._empty_frame(width, height)
            raise

    def _empty_frame(self, width: int, height: int) -> None:
        self.end_result(self.begin_result(0, 0, width, height))

    def _render_frame(self, depsgraph, width: int, height: int) -> None:
        scene = depsgraph.scene
        try:
            camera = extract.render_camera(depsgraph, width, height)
        except LookupError as err:
            self.report({"ERROR"}, f"Translucent: {err}")
            self._empty_frame(width, height)
            return
        frame = extract.frame_inputs(depsgraph, camera)
        self.update_stats("Translucent", f"drawing {len(frame.meshes)} meshes, {len(frame.emitters)} emitters")
        frame = dataclasses.replace(frame, settings=draw_settings(
            scene, frame, f"F12:{scene.name}", scene.frame_current, scene.translucent.capture_passes))
        pipeline = self._get_pipeline()
        pixels = render_offscreen(pipeline, frame)
        _keep_timings(pipeline, "F12")
        for message in frame.warnings:  # after drawing: the passes add their own
            self.report({"WARNING"}, f"Translucent: {message}")
        LAST_CAPTURE.clear()
        if pipeline.capture is not None:
            LAST_CAPTURE.update(pipeline.capture, frame=frame, timings=dict(pipeline.last_timings))
        if not np.isfinite(pixels).all():
            self.report({"ERROR"}, "Translucent: the frame has non-finite pixels (NaN or inf)")
        result = self.begin_result(0, 0, width, height)
        try:
            result.layers[0].passes["Combined"].rect.foreach_set(pixels.reshape(-1))
        finally:
            self.end_result(result)
        self.last_frame = frame

    # -- viewport ------------------------------------------------------------
    def view_update(self, context, depsgraph):
        # Batches are keyed by a geometry hash, so edits rebuild only what changed.
        pass

    def view_draw(self, context, depsgraph):
        region, rv3d = context.region, context.region_data
        frame = extract.frame_inputs(depsgraph, extract.viewport_camera(region, rv3d))
        self._viewport_frame += 1
        frame = dataclasses.replace(frame, settings=draw_settings(
            depsgraph.scene, frame, "viewport", self._viewport_frame, capture=False))
        pipeline = self._get_pipeline()
        pipeline.forget({m.key for m in frame.meshes})
        draw_to_region(pipeline, frame, (region.width, region.height),
                       lambda: self.bind_display_space_shader(depsgraph.scene), self.unbind_display_space_shader)
        _keep_timings(pipeline, "viewport")


classes = (TranslucentRenderEngine,)

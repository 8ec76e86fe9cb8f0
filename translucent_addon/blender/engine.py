"""The render engine TRANSLUCENT_RT: F12, batch and the viewport, one pipeline."""
from __future__ import annotations

import contextlib
import dataclasses
import sys
import time

import bpy
import numpy as np

from ..core.frame import DrawSettings
from ..pipeline import Pipeline, draw_to_region, read_layer, render_offscreen
from ..techniques import REGISTRY
from . import extract
from .props import bounded
from .session import Session
from .session import current as current_session


def _keep_timings(session: Session, pipeline, drawn, source: str, **outside: float) -> None:
    """The passes' seconds, and the frame's wall time (``frame``) and reading the scene (``extract``); the warnings
    of the frame ``drawn``, for the panel."""
    session.warnings[:] = [str(w) for w in drawn.warnings]
    session.timings.clear()
    session.timings.update(pipeline.last_timings)
    session.timings.update(outside)
    session.timings["source"] = source


def technique_settings(scene) -> dict:
    """Each registered technique's settings, made from the Scene.translucent properties it declares."""
    s = scene.translucent
    return {t.id: t.settings({name: bounded(s, name) for name in t.scene_properties}) for t in REGISTRY
            if t.scene_properties}


def draw_settings(scene, frame, coherence_key: str, coherence_frame: int, capture: bool,
                  session: Session | None = None) -> DrawSettings:
    """What travels with the frame: the techniques' settings, each adjusted to this frame by its technique
    (IMAGE_SPACE's k chosen for this frame's camera; what the panels say of it left in ``session.results``), the
    sample-coherence sequence (when the scene asks for it) and whether to read passes back."""
    session = session or current_session()
    settings = technique_settings(scene)
    for t in REGISTRY:
        settings[t.id] = t.frame_settings(frame, settings.get(t.id), session.results.setdefault(t.id, {}),
                                          session.technique_caches.setdefault(t.id, {}))
    return DrawSettings({k: v for k, v in settings.items() if v is not None},
                        coherence_key if scene.translucent.temporal_coherence else None, coherence_frame, capture)


LIGHT_PASSES = ("Subsurface", "Specular", "Diffuse")  # Scene.translucent.light_passes: they sum to Combined


def wanted_passes(scene, view_layer) -> list[tuple[str, int, str]]:
    """(name, channels, channel ids) of the passes the frame writes besides Combined: Depth and Normal when the
    view layer asks for them (its Data passes), the light passes when the scene does."""
    passes = []
    if view_layer.use_pass_z:
        passes.append(("Depth", 1, "Z"))
    if view_layer.use_pass_normal:
        passes.append(("Normal", 3, "XYZ"))
    if scene.translucent.light_passes:
        passes += [(name, 3, "RGB") for name in LIGHT_PASSES]
    return passes


def pass_images(combined: np.ndarray, layer: dict | None) -> dict[str, np.ndarray]:
    """Every pass the engine can write, from the frame and its surface layer (``pipeline.read_layer``): the light
    passes split Combined without remainder, Combined = Subsurface + Specular + Diffuse."""
    h, w = combined.shape[:2]
    if layer is None:  # nothing drawn over the world
        zero = np.zeros((h, w, 3), np.float32)
        layer = {"specular": zero, "subsurface_mask": np.zeros((h, w), np.float32), "normal": zero,
                 "depth": np.full((h, w), 1.0e10, np.float32)}
    below = combined[..., :3] - layer["specular"]
    mask = (layer["subsurface_mask"] > 0.5)[..., None]
    return {"Depth": layer["depth"][..., None], "Normal": layer["normal"], "Specular": layer["specular"],
            "Subsurface": np.where(mask, below, 0.0), "Diffuse": np.where(mask, 0.0, below)}


def final_pipeline(session: Session | None = None) -> Pipeline:
    """The pipeline of F12 and batch renders, whose uploads (vertex batches, targets) outlive one render
    (Blender makes an engine per frame): the session's."""
    session = session or current_session()
    if session.final_pipeline is None:
        session.final_pipeline = Pipeline()
    return session.final_pipeline


class Viewport:
    """The viewport's state between redraws: its pipeline and what the depsgraph updates said changed.

    Blender's engines work this way: ``view_update`` hands over ``depsgraph.updates``, ``view_draw`` draws;
    an object whose geometry no update named is not read again. Until the first draw, and after an update
    of anything but an object (a mesh datablock, a collection, the scene: a frame change), every mesh is read
    and compared (``mesh_read``), which is still sound, only slower."""

    def __init__(self):
        self.pipeline = Pipeline()
        self.frames = 0  # for IMAGE_SPACE's sample coherence
        self.changed: set[str] = set()
        self.read_all = True

    def update(self, updates) -> None:
        """Note what ``depsgraph.updates`` say changed (``DepsgraphUpdate``-like records)."""
        for u in updates:
            if not u.is_updated_geometry:
                continue
            if isinstance(u.id, bpy.types.Object):
                self.changed.add(u.id.original.name)
            else:
                self.read_all = True

    def draw(self, depsgraph, camera, size, bind_display, unbind_display):
        """One viewport frame into the bound framebuffer (``draw_to_region``): returns the frame drawn."""
        t0 = time.perf_counter()
        read_all, changed = self.read_all, self.changed
        frame = extract.frame_inputs(depsgraph, camera,
                                     trusted=None if read_all else (lambda name: name not in changed))
        self.read_all, self.changed = False, set()
        self.frames += 1
        frame = dataclasses.replace(frame, settings=draw_settings(
            depsgraph.scene, frame, "viewport", self.frames, capture=False))
        t1 = time.perf_counter()
        self.pipeline.forget({m.key for m in frame.meshes}, {m.source for m in frame.meshes})
        draw_to_region(self.pipeline, frame, size, bind_display, unbind_display)
        _keep_timings(current_session(), self.pipeline, frame, "viewport", extract=t1 - t0,
                      frame=time.perf_counter() - t0)
        return frame


class TranslucentRenderEngine(bpy.types.RenderEngine):
    bl_idname = "TRANSLUCENT_RT"
    bl_label = "Translucent"
    bl_use_gpu_context = True  # a GPU context in render(), also headless (-b)
    bl_use_preview = False
    bl_use_eevee_viewport = False
    bl_use_shading_nodes_custom = False  # keep Blender's material nodes

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._viewport = None
        self.last_frame = None

    def __del__(self):
        # GPU objects are freed by their own destructors; drop references only (Blender may have
        # removed the engine's struct already, at exit).
        with contextlib.suppress(ReferenceError):
            self._viewport = None

    def _get_viewport(self) -> Viewport:
        if self._viewport is None:
            self._viewport = Viewport()
        return self._viewport

    # -- F12 and batch -----------------------------------------------------
    def render(self, depsgraph):
        scene = depsgraph.scene
        width, height = extract.output_size(scene.render)
        try:
            self._render_frame(depsgraph, width, height)
        except BaseException:
            # Blender 5.0.1 writes the frame after render() returns, and saving an OpenEXR frame that
            # has no result crashes it (segmentation fault in BKE_image_render_write_exr): leave an
            # empty frame, then let the error show as Blender reports it.
            self._empty_frame(width, height)
            raise

    def update_render_passes(self, scene=None, renderlayer=None):
        """Declare the passes the frame writes (Blender's compositor and the view layer's pass list read these)."""
        if scene is None or renderlayer is None:
            return
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        for name, channels, ids in wanted_passes(scene, renderlayer):
            self.register_pass(scene, renderlayer, name, channels, ids, "VALUE" if channels == 1 else
                               ("VECTOR" if name == "Normal" else "COLOR"))

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
        session = current_session()
        t0 = time.perf_counter()
        frame = extract.frame_inputs(depsgraph, camera, session=session)
        t1 = time.perf_counter()
        self.update_stats("Translucent", f"drawing {len(frame.meshes)} meshes, {len(frame.emitters)} emitters")
        frame = dataclasses.replace(frame, settings=draw_settings(
            scene, frame, f"F12:{scene.name}", scene.frame_current, scene.translucent.capture_passes, session))
        pipeline = final_pipeline(session)
        pipeline.forget({m.key for m in frame.meshes}, {m.source for m in frame.meshes})
        wanted = wanted_passes(scene, depsgraph.view_layer)
        if wanted:
            frame = dataclasses.replace(frame, settings=dataclasses.replace(frame.settings, passes=True))
        pixels = render_offscreen(pipeline, frame)
        extra = pass_images(pixels, read_layer(pipeline, width, height)) if wanted else {}
        session.passes = extra  # what the render passes hold (the tests read them here too)
        _keep_timings(session, pipeline, frame, "F12", extract=t1 - t0, frame=time.perf_counter() - t0)
        for message in frame.warnings:  # after drawing: the passes add their own
            self.report({"WARNING"}, f"Translucent: {message}")
        lost = frame.lost
        if lost and bpy.app.background and scene.translucent.fail_on_lost_objects:
            # A batch render nobody watches: say so on stderr and fail, rather than FINISHED with a wrong frame.
            for message in lost:
                print(f"Translucent: frame {scene.frame_current}: {message}", file=sys.stderr, flush=True)
            self.report({"ERROR"}, f"Translucent: frame {scene.frame_current} lost {len(lost)} object(s): {lost[0]}")
        session.capture.clear()
        if pipeline.capture is not None:
            session.capture.update(pipeline.capture, frame=frame, timings=dict(pipeline.last_timings))
        if not np.isfinite(pixels).all():
            self.report({"ERROR"}, "Translucent: the frame has non-finite pixels (NaN or inf)")
        result = self.begin_result(0, 0, width, height, layer=depsgraph.view_layer.name)
        try:
            passes = result.layers[0].passes
            passes["Combined"].rect.foreach_set(pixels.reshape(-1))
            for name, _, _ in wanted:
                if passes.find(name) != -1:  # declared by update_render_passes
                    passes[name].rect.foreach_set(np.ascontiguousarray(extra[name], np.float32).reshape(-1))
        finally:
            self.end_result(result)
        self.last_frame = frame

    # -- viewport ------------------------------------------------------------
    def view_update(self, context, depsgraph):
        self._get_viewport().update(depsgraph.updates)

    def view_draw(self, context, depsgraph):
        region, rv3d = context.region, context.region_data
        self._get_viewport().draw(depsgraph, extract.viewport_camera(region, rv3d), (region.width, region.height),
                                  lambda: self.bind_display_space_shader(depsgraph.scene),
                                  self.unbind_display_space_shader)


classes = (TranslucentRenderEngine,)

"""The one GPU render pipeline: a sequence of passes drawing a FrameInputs.

Both callers share it: ``RenderEngine.render`` (F12, batch; into an RGBA32F offscreen) and the viewport
(``view_draw`` and the SpaceView3D draw handler; into the bound framebuffer). Passes:

1. base, world term: clear to the world colour (or draw the world's environment image), rho * L_world, depth;
   then each technique's ``world`` hook;
2. per emitter: shadow distances into an R32F atlas (``shadow_distance``), then rho / pi * E * V added
   (``base_lighting``, additive blending) and each technique's ``emitter_surface`` hook into the target, then
   each technique's ``emitter`` hook with that emitter's shadow atlas;
3. each technique's ``finish``: what it draws over the base.

The pipeline names no technique: it loops over ``techniques.REGISTRY`` (``techniques/protocol.py`` says what
each hook is for). An object whose method draws nothing yet keeps the base. A technique the GPU backend cannot run
(a shader it does not compile, a texture it refuses, a driver error) falls back the same way, with one line naming
its objects and the reason (``_guarded``); it is not tried again until the pipeline is made anew.
"""
from __future__ import annotations

import time

import numpy as np

from .core.frame import FrameInputs, MeshInstance
from .core.physics import oblique_entry
from .gpu import blocks, draw_state, shaders
from .gpu.environment import environment
from .gpu.frame_context import FrameContext
from .gpu.surface_layer import FAR_DEPTH, SurfaceLayer
from .gpu.targets import clear_target, read_pixels, screen_quad
from .techniques import REGISTRY, get


class Pipeline:
    """GPU resources that outlive one frame: vertex batches and the shadow atlas."""

    def __init__(self):
        self._batches: dict[tuple, tuple] = {}  # (mesh key, shape operators on) -> (base batch, shadow batch)
        self._shapes: dict[str, tuple] = {}  # mesh source -> (corner positions, on, shape_attributes) when computed
        self._atlas = None  # (texels, color texture, depth texture, framebuffer)
        self.targets: dict = {}  # method render targets by (name, size), reused across frames
        self.last_timings: dict[str, float] = {}
        self.capture = None  # read-backs of intermediate passes for the last frame (frame.settings.capture)
        self.unavailable: dict[str, str] = {}  # technique id -> why this GPU backend cannot run it
        self._failed_now: set[str] = set()  # technique ids that failed in the frame being drawn
        self.state_leaks: list[str] = []  # GPU state a technique hook left changed (put back; ``_guarded``)
        self.surface = SurfaceLayer()  # the materials' gloss and colour over what the methods draw
        self.layer = None  # the last frame's surface layer (its targets: the Specular, Normal and Depth passes)

    def free(self) -> None:
        self._batches.clear()
        self._shapes.clear()
        self._atlas = None
        self.targets.clear()
        self.surface.free()
        self.layer = None

    def forget(self, keys_alive: set[str], names_alive: set[str] | None = None) -> None:
        """Drop batches of meshes that are no longer drawn (and the shape operators of sources no longer drawn:
        ``MeshInstance.source``)."""
        for key in list(self._batches):
            if key[0] not in keys_alive:
                del self._batches[key]
        for name in list(self._shapes) if names_alive is not None else ():
            if name not in names_alive:
                del self._shapes[name]

    # -- resources ---------------------------------------------------------
    def _batch(self, mesh: MeshInstance):
        """(base batch, shadow batch) of a mesh, built once per geometry key and whether its shape operators are
        drawn (they follow the method and the medium, which the key does not cover)."""
        key = (mesh.key, shapes_drawn(mesh))
        cached = self._batches.get(key)
        if cached is None:
            from gpu_extras.batch import batch_for_shader

            pos = np.ascontiguousarray(mesh.positions, dtype=np.float32)
            base = batch_for_shader(
                shaders.get("base_lighting"),
                "TRIS",
                {
                    "pos": pos,
                    "nor": np.ascontiguousarray(mesh.normals, dtype=np.float32),
                    "col": np.ascontiguousarray(mesh.colors, dtype=np.float32),
                    "paint": np.ascontiguousarray(mesh.paint, dtype=np.float32),
                    "tint": np.ascontiguousarray(mesh.tint, dtype=np.float32),
                    **self._shape(mesh),
                },
            )
            shadow = batch_for_shader(shaders.get("shadow_distance"), "TRIS", {"pos": pos})
            cached = self._batches[key] = (base, shadow)
        return cached

    def _shape(self, mesh: MeshInstance) -> dict:
        """``shape_attributes`` of a mesh, reused for a new geometry of the same name (a deforming mesh: a new
        batch every frame) while its corners have moved less than ``SHAPE_REUSE`` of its size in the mean."""
        known = self._shapes.get(mesh.source)
        on = shapes_drawn(mesh)
        if known is not None and len(known[0]) == len(mesh.positions) and known[1] == on:
            size = float(np.ptp(mesh.positions, axis=0).max()) if len(mesh.positions) else 0.0
            if float(np.abs(mesh.positions - known[0]).mean()) <= SHAPE_REUSE * size:
                return known[2]
        attributes = shape_attributes(mesh)
        self._shapes[mesh.source] = (np.array(mesh.positions, np.float32), on, attributes)
        return attributes

    def _shadow_atlas(self, texels: int):
        if self._atlas is None or self._atlas[0] != texels:
            import gpu

            size = (3 * texels, 2 * texels)
            color = gpu.types.GPUTexture(size, format="R32F")
            depth = gpu.types.GPUTexture(size, format="DEPTH_COMPONENT32F")
            fb = gpu.types.GPUFrameBuffer(depth_slot=depth, color_slots=color)
            self._atlas = (texels, color, depth, fb)
        return self._atlas

    # -- passes --------------------------------------------------------------
    def draw(self, frame: FrameInputs, *, clear: bool = True) -> None:
        """Draw the frame into the currently bound framebuffer."""
        import gpu

        t0 = time.perf_counter()
        timings = {}
        self.capture = {} if frame.settings.capture else None
        registered = {t.id for t in REGISTRY}
        for gone in set(self.unavailable) - registered:  # unregistered since: registered again, it is tried anew
            del self.unavailable[gone]
        fb = gpu.state.active_framebuffer_get()
        cam = frame.camera
        frame_ubo = gpu.types.GPUUniformBuf(blocks.frame_block(cam.view, cam.projection, frame.world_color,
                                                               frame.world_sh()))
        if clear:
            alpha = 0.0 if frame.film_transparent else 1.0
            clear_target(fb, (*map(float, frame.world_color), alpha))
            if frame.environment is not None and not frame.film_transparent:
                self._draw_environment(frame, frame_ubo)
        if not frame.meshes:
            self.last_timings = {"total": time.perf_counter() - t0}
            return
        texels = int(frame.shadow_resolution)
        atlas = self._shadow_atlas(texels)
        ctx = FrameContext(frame, fb, frame_ubo, [], [self._batch(m) for m in frame.meshes], atlas[1], self)
        states = [(t, self._guarded(t, ctx, t.prepare, ctx)) for t in REGISTRY]
        # One that failed before still gives the base pass its inputs (IMAGE_SPACE's placeholders) but draws nothing.
        lighting = [t.base_lighting(state) for t, state in states if state is not None]
        active = [(t, state) for t, state in states if state is not None and t.id not in self.unavailable]
        materials_ubo, near_lut, slots = next(x for x in lighting if x is not None)
        ctx.objects[:] = [gpu.types.GPUUniformBuf(blocks.object_block(m.model, m.normal_matrix, slots.get(k, 0)))
                          for k, m in enumerate(frame.meshes)]
        skip = set().union(*(t.replaces_base(state) for t, state in active))
        centre, radius = frame.bounds()
        timings["setup"] = time.perf_counter() - t0

        gpu.state.face_culling_set("NONE")
        # A light block is bound in every mode; the world pass ignores it.
        placeholder = gpu.types.GPUUniformBuf(bytes(blocks.LIGHT_FLOATS * 4))
        base_inputs = (ctx.batches, ctx.objects, frame_ubo, materials_ubo, near_lut, atlas[1])
        with draw_state.draw_pass(fb, depth_test="LESS_EQUAL", depth_write=True):
            self._draw_base(*base_inputs, placeholder, mode=0, skip=skip)
            for t, state in list(active):
                self._guarded(t, ctx, t.world, ctx, state, placeholder, active=active)
        timings["world"] = time.perf_counter() - t0 - sum(timings.values())
        # The surface layer over an image of its own: not over another engine's viewport (``clear`` False), whose
        # depth it does not see.
        layer = self.layer = self.surface.begin(
            frame, self, lambda m: surface_drawn(m) and m.method not in self.unavailable,
            frame.settings.passes) if clear else None
        spent_layer = 0.0
        if layer is not None:
            t1 = time.perf_counter()
            self.surface.world(layer, frame, ctx.objects, frame_ubo, placeholder, atlas[1])
            spent_layer += time.perf_counter() - t1

        spent = {"shadow_maps": 0.0, "lights": 0.0}
        for e in frame.emitters:
            t1 = time.perf_counter()
            unfitted = any(t.unfitted_shadow(state, e) for t, state in active)
            faces, origin, n_faces, tan_half = blocks.shadow_faces(e, centre, radius, fit_spot=not unfitted)
            face_texels = blocks.face_texels(texels, n_faces)
            light_ubo = gpu.types.GPUUniformBuf(blocks.light_block(e, faces, origin, face_texels, radius,
                                                                   tan_half=tan_half))
            self._draw_shadow(n_faces, face_texels, ctx.batches, ctx.objects, light_ubo, atlas)
            t2 = time.perf_counter()
            spent["shadow_maps"] += t2 - t1
            with draw_state.draw_pass(fb, blend="ADDITIVE_PREMULT", depth_test="LESS_EQUAL"):  # ONE, ONE
                self._draw_base(*base_inputs, light_ubo, mode=1, skip=skip)
                for t, state in list(active):
                    self._guarded(t, ctx, t.emitter_surface, ctx, state, light_ubo, active=active)
            spent["lights"] += time.perf_counter() - t2
            if layer is not None:
                t4 = time.perf_counter()
                self.surface.emitter(layer, frame, ctx.objects, frame_ubo, light_ubo, atlas[1])
                spent_layer += time.perf_counter() - t4
            for t, state in list(active):
                t3 = time.perf_counter()
                self._guarded(t, ctx, t.emitter, ctx, state, e, light_ubo, active=active)
                spent[t.emitter_timing] = spent.get(t.emitter_timing, 0.0) + time.perf_counter() - t3
        timings.update(spent)
        for t, state in list(active):
            t1 = time.perf_counter()
            steps = self._guarded(t, ctx, t.finish, ctx, state, active=active)
            if steps is not None:
                timings.update(steps)
                if t.timing:
                    timings[t.timing] = time.perf_counter() - t1
        if layer is not None:
            t1 = time.perf_counter()
            # A method that failed in this frame fell back to the base colour: its objects lose the layer too.
            fallen = [k for k, m in enumerate(frame.meshes) if m.method in self.unavailable
                      and layer.surfaces[k] is not None]
            if fallen:
                self.surface.neutralise(layer, frame, ctx.objects, frame_ubo, placeholder, atlas[1], fallen)
            self.surface.composite(layer, fb, self)
            timings["surface"] = spent_layer + time.perf_counter() - t1
        self._unavailable_warnings(frame)
        self._failed_now.clear()
        timings["total"] = time.perf_counter() - t0
        self.last_timings = timings

    def _guarded(self, t, ctx: FrameContext, hook, *args, active: list | None = None):
        """``hook(*args)``, one of technique ``t``'s, with two guards.

        A backend that lacks what the technique needs (a shader it does not compile, a format or size it refuses,
        a driver error) makes the technique fall back to the base colour: dropped from ``active`` for the rest of
        this frame, not tried again by this pipeline, and one line naming its objects and the reason in this
        frame's warnings (and every later frame's while they use it). The traceback goes to the console and a
        farm's log. An error here must not fail the whole frame: in the viewport a failed draw is a blank
        viewport, on a farm a failed frame.

        GPU state a hook leaves changed (blend, depth test, depth writes: a pass set outside ``draw_pass``) is put
        back and recorded in ``state_leaks``, so that it cannot reach the next pass (the tests require none)."""
        before = draw_state.current()
        try:
            return hook(*args)
        except Exception as err:  # noqa: BLE001 -- what a backend raises is not one type; each is reported
            import traceback

            import gpu

            if t.id not in self.unavailable:
                traceback.print_exc()
            self.unavailable[t.id] = (f"{gpu.platform.backend_type_get()} refused it "
                                      f"({type(err).__name__}: {str(err).strip() or 'no message'})")
            self._failed_now.add(t.id)
            if active is not None:
                active[:] = [(u, state) for u, state in active if u is not t]
            return None
        finally:
            after = draw_state.current()
            if after != before:
                draw_state.apply(*before)
                self.state_leaks.append(f"{t.id} {hook.__name__}: {before} -> {after}")

    def _unavailable_warnings(self, frame: FrameInputs) -> None:
        """One line per technique this pipeline gave up on (``_guarded``) that the frame asks for: a method with
        objects of its own, or a technique without objects of its own (caustics, grass) in the frame it failed."""
        for t in REGISTRY:
            why = self.unavailable.get(t.id)
            names = [m.name for m in frame.meshes if m.method == t.id]
            if why is not None and (names or t.id in self._failed_now):
                who = ", ".join(f"'{n}'" for n in names) if names else t.label
                frame.warnings.append(f"{who}: {t.label} cannot run on this GPU backend: {why}; drawn with its base "
                                      "colour")

    def _draw_environment(self, frame, frame_ubo) -> None:
        """The world image behind everything, where the world is an environment texture."""

        chain, env_tex = environment(frame)
        with draw_state.draw_pass():
            shader = shaders.pass_shader("env_background")
            shader.bind()
            shader.uniform_block("frame", frame_ubo)
            shader.uniform_sampler("env_atlas", env_tex)
            shader.uniform_int("env_res", int(chain.res))
            shader.draw(screen_quad(self, "env_background"))

    @staticmethod
    def _draw_base(batches, objects, frame_ubo, materials_ubo, near_lut, atlas_texture, light_ubo,
                   mode: int, skip=()) -> None:
        shader = shaders.bind_lit("base_lighting", frame_ubo, light_ubo, atlas_texture, mode)
        shader.uniform_block("materials", materials_ubo)
        shader.uniform_sampler("near_lut", near_lut)
        for k, ((base, _), obj) in enumerate(zip(batches, objects)):
            if k in skip:
                continue  # drawn by its own pass (height fields)
            shader.uniform_block("object", obj)
            shader.draw(base)

    @staticmethod
    def _draw_shadow(n_faces: int, texels: int, batches, objects, light_ubo, atlas) -> None:
        import gpu

        fb = atlas[3]
        shader = shaders.pass_shader("shadow_distance")
        with draw_state.draw_pass(fb, depth_test="LESS_EQUAL", depth_write=True):
            clear_target(fb, (3.0e38, 0.0, 0.0, 0.0))
            shader.bind()
            shader.uniform_block("light", light_ubo)
            for face in range(n_faces):
                gpu.state.viewport_set((face % 3) * texels, (face // 3) * texels, texels, texels)
                shader.uniform_int("face", face)
                for (_, shadow), obj in zip(batches, objects):
                    shader.uniform_block("object", obj)
                    shader.draw(shadow)


def surface_drawn(mesh: MeshInstance) -> bool:
    """Whether the surface layer covers a mesh: its method draws under it (``Technique.surface_layer``; OFF does)
    and no technique drawing it as an extra draws its surface itself (``Technique.owns_surface``)."""
    technique = get(mesh.method)
    if technique is not None and not technique.surface_layer:
        return False
    return not any(getattr(get(k), "owns_surface", False) for k in mesh.extras)


SHAPE_REUSE = 0.01  # a deforming mesh keeps its shape operators while its corners move less than this (mean)


def shapes_drawn(mesh: MeshInstance) -> bool:
    """Whether the mesh's method shifts the light entering it at an angle (``Technique.base_entry_shift``: its
    base batch carries the corners' shape operators)."""
    technique = get(mesh.method)
    return technique is not None and technique.base_entry_shift and mesh.medium is not None and bool(
        oblique_entry.medium_shift_mm(mesh.medium).any())


def shape_attributes(mesh: MeshInstance) -> dict:
    """The base batch's curv_d and curv_o: each corner's shape operator (object space, diagonal and xy, xz, yz;
    ``oblique_entry.corner_shape_operators``) where its method shifts light entering at an angle, else 0."""
    n = len(mesh.positions)
    if not shapes_drawn(mesh):
        return {"curv_d": np.zeros((n, 3), np.float32), "curv_o": np.zeros((n, 3), np.float32)}
    S = oblique_entry.corner_shape_operators(mesh.positions.reshape(-1, 3, 3), mesh.normals.reshape(-1, 3, 3))
    packed = oblique_entry.packed_shape(S.reshape(n, 3, 3))
    return {"curv_d": np.ascontiguousarray(packed[:, :3]), "curv_o": np.ascontiguousarray(packed[:, 3:])}


def render_offscreen(pipeline: Pipeline, frame: FrameInputs) -> np.ndarray:
    """Draw a frame into an RGBA32F offscreen and return its linear pixels."""
    import gpu

    cam = frame.camera
    offscreen = gpu.types.GPUOffScreen(cam.width, cam.height, format="RGBA32F")
    try:
        with offscreen.bind():
            fb = gpu.state.active_framebuffer_get()
            pipeline.draw(frame)
            return read_pixels(fb, cam.width, cam.height)
    finally:
        offscreen.free()


def read_layer(pipeline: Pipeline, width: int, height: int) -> dict | None:
    """The last frame's surface layer as render passes: ``specular`` (H, W, 3), ``subsurface_mask`` (H, W: 1 on
    subsurface objects), ``normal`` (H, W, 3, world space, 0 where nothing is) and ``depth`` (H, W: distance along
    the camera's axis, ``FAR_DEPTH`` where nothing is); None when no layer was drawn. Inside the GPU context."""
    layer = pipeline.layer
    if layer is None:
        return None
    with draw_state.draw_pass(layer.fb_world):
        specular = read_pixels(layer.fb_world, width, height, slot=0)
        factor = read_pixels(layer.fb_world, width, height, slot=2)
        gbuffer = read_pixels(layer.fb_world, width, height, slot=3)
    depth = np.where(gbuffer[..., 3] > 0.0, gbuffer[..., 3], FAR_DEPTH).astype(np.float32)
    return {"specular": specular[..., :3], "subsurface_mask": factor[..., 3], "normal": gbuffer[..., :3],
            "depth": depth}


def draw_to_region(pipeline: Pipeline, frame: FrameInputs, size, bind_display, unbind_display) -> None:
    """The viewport: draw the frame into an RGBA16F offscreen the pipeline keeps (rebuilt when the region's
    size changes), then onto the region between ``bind_display`` and ``unbind_display`` (the engine's
    display-space shader: Blender's colour management)."""
    import gpu
    from gpu_extras.presets import draw_texture_2d

    region_fb = gpu.state.active_framebuffer_get()
    off = pipeline.targets.get("viewport_offscreen")
    if off is None or (off.width, off.height) != tuple(size):
        off = pipeline.targets["viewport_offscreen"] = gpu.types.GPUOffScreen(*size, format="RGBA16F")
    with off.bind():
        pipeline.draw(frame)
    # Making an offscreen leaves no framebuffer bound (measured headless: a 0x0 viewport after it), so the first
    # frame after a resize drew its image nowhere: the region's is bound for it by name.
    # No depth test: the image covers the region whatever depth Blender's own drawing left there (EEVEE's render
    # leaves LESS_EQUAL on; the old pipeline switched it off at its end, by chance).
    with draw_state.draw_pass(region_fb, blend="ALPHA_PREMULT"):
        bind_display()
        draw_texture_2d(off.texture_color, (0, 0), *size)
        unbind_display()

"""The one GPU render pipeline: a sequence of passes drawing a FrameInputs.

Both callers share it: ``RenderEngine.render`` (F12, batch; into an RGBA32F
offscreen) and the viewport (``view_draw`` and the SpaceView3D draw handler;
into the bound framebuffer). Passes:

1. base, world term: clear to the world colour (or draw the world's environment image), rho * L_world, depth;
2. per emitter: shadow distances into an R32F cube atlas (``shadow_distance``),
   then rho / pi * E * V added (``base_lighting``, additive blending);
3. method passes: IMAGE_SPACE (``methods/image_space.py``) adds the near field of the profile in
   the lighting pass above (objects with a subsurface slot) and splats the far field after it;
   TEXTURE_SPACE (``methods/texture_space.py``) lights its illumination maps in the world pass
   and in each emitter's pass (reusing its shadow atlas), then filters, gathers and draws its
   objects over the base; QUADGRAPH (``methods/quadgraph.py``) lights q(n_s) at its surface nodes in
   the same passes, relaxes the diffusion equation coarse to fine and draws its objects over the
   base; GEOCUBE (``methods/geocube.py``) draws its objects' refraction of the world over the base;
   caustics (``caustics.py``, Shah ch. 5) follow each emitter's lighting pass and add the light
   that casters refract or mirror onto the receivers; grass fields (``grass.py``, Shah ch. 4) are
   drawn right after the base in the world pass and in each emitter's pass, writing the depth of
   the blades; meshes with a height field (``relief.py``, Shah ch. 3) are drawn by their own pass
   instead of the base, in the same world and emitter passes, writing the displaced depth;
   an object whose method draws nothing yet keeps the base.
"""
from __future__ import annotations

import time

import numpy as np

from .core.frame import FrameInputs, MeshInstance
from .gpu import blocks, shaders
from .gpu.targets import clear_target, read_pixels, screen_quad
from .techniques.caustics import passes as caustics
from .techniques.geocube import passes as geocube
from .techniques.grass import passes as grass
from .techniques.image_space import passes as image_space
from .techniques.quadgraph import passes as quadgraph
from .techniques.relief import passes as relief
from .techniques.texture_space import passes as texture_space


class Pipeline:
    """GPU resources that outlive one frame: vertex batches and the shadow atlas."""

    def __init__(self):
        self._batches: dict[str, tuple] = {}
        self._atlas = None  # (texels, color texture, depth texture, framebuffer)
        self.targets: dict = {}  # method render targets by (name, size), reused across frames
        self.last_timings: dict[str, float] = {}
        self.sampling = image_space.SamplingSettings()
        self.capture = None  # a dict to receive read-backs of intermediate passes (tests)
        # Frame-to-frame sample coherence (IMAGE_SPACE, Shah 6.5.2): a key naming the sequence (None:
        # off) and the frame number; samples of frame f - 1 are reused in frame f.
        self.coherence_key = None
        self.coherence_frame = 0
        self.texture_product = "GPU"  # TEXTURE_SPACE: F^0 E on the GPU or with scipy.sparse ("CPU")
        self.quadgraph_solver = (2e-5, 1000)  # QUADGRAPH: (relative change per step, iteration cap per level)
        self.quadgraph_mode = 0  # QUADGRAPH output: 0 colour; 1 diffusion; 2 single; 3 local multiple scattering
        self.relief_mode = 0  # height-field output: 0 colour; 1 hit uv, depth, refinements (tests)
        self.geocube_mode = 0  # GEOCUBE output: 0 colour; 1-3 intermediate values for tests (gc_refract.glsl)

    def free(self) -> None:
        self._batches.clear()
        self._atlas = None
        self.targets.clear()

    def forget(self, keys_alive: set[str]) -> None:
        """Drop batches of meshes that are no longer drawn."""
        for key in list(self._batches):
            if key not in keys_alive:
                del self._batches[key]

    # -- resources ---------------------------------------------------------
    def _batch(self, mesh: MeshInstance):
        """(base batch, shadow batch) of a mesh, built once per geometry key."""
        cached = self._batches.get(mesh.key)
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
                },
            )
            shadow = batch_for_shader(shaders.get("shadow_distance"), "TRIS", {"pos": pos})
            cached = self._batches[mesh.key] = (base, shadow)
        return cached

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
        batches = [self._batch(m) for m in frame.meshes]
        subsurface = image_space.prepare(frame, self.sampling)
        textured = texture_space.prepare(frame)
        graphs = quadgraph.prepare(frame)
        glass = geocube.prepare(frame)
        caustic_plan = caustics.prepare(frame)
        fields = grass.prepare(frame)
        reliefs = relief.indices(frame)
        slots = subsurface.plan.slot_of if subsurface.plan else {}
        objects = [
            gpu.types.GPUUniformBuf(blocks.object_block(m.model, m.normal_matrix, slots.get(k, -1)))
            for k, m in enumerate(frame.meshes)
        ]
        centre, radius = frame.bounds()
        texels = int(frame.shadow_resolution)
        atlas = self._shadow_atlas(texels)
        timings["setup"] = time.perf_counter() - t0

        gpu.state.face_culling_set("NONE")
        gpu.state.depth_mask_set(True)
        gpu.state.depth_test_set("LESS_EQUAL")
        gpu.state.blend_set("NONE")
        # A light block is bound in every mode; the world pass ignores it.
        placeholder = gpu.types.GPUUniformBuf(bytes(blocks.LIGHT_FLOATS * 4))
        base_inputs = (batches, objects, frame_ubo, subsurface.materials, subsurface.near_lut, atlas[1])
        self._draw_base(*base_inputs, placeholder, mode=0, skip=reliefs)
        if reliefs:
            relief.draw(frame, reliefs, self, frame_ubo, objects, placeholder, atlas[1], mode=0)
        if fields:
            grass.draw(fields, self, frame_ubo, objects, placeholder, atlas[1], mode=0)
        if textured:
            texture_space.illuminate(textured, objects, frame_ubo, placeholder, atlas[1], mode=0, pipeline=self)
        if graphs:
            quadgraph.illuminate(graphs, objects, frame_ubo, placeholder, atlas[1], mode=0, pipeline=self,
                                 size=(cam.width, cam.height))
        timings["world"] = time.perf_counter() - t0 - sum(timings.values())

        t_shadow = t_light = t_caustics = 0.0
        for e in frame.emitters:
            t1 = time.perf_counter()
            with_caustics = caustic_plan is not None and e.caustics
            faces, origin, n_faces, tan_half = blocks.shadow_faces(e, centre, radius, fit_spot=not with_caustics)
            face_texels = blocks.face_texels(texels, n_faces)
            light_ubo = gpu.types.GPUUniformBuf(blocks.light_block(e, faces, origin, face_texels, radius,
                                                                   tan_half=tan_half))
            self._draw_shadow(n_faces, face_texels, batches, objects, light_ubo, atlas)
            t2 = time.perf_counter()
            # The shadow pass bound the atlas: bind the target explicitly for the light pass.
            with fb.bind():
                gpu.state.depth_mask_set(False)
                gpu.state.depth_test_set("LESS_EQUAL")
                gpu.state.blend_set("ADDITIVE_PREMULT")  # ONE, ONE
                self._draw_base(*base_inputs, light_ubo, mode=1, skip=reliefs)
                if reliefs:
                    relief.draw(frame, reliefs, self, frame_ubo, objects, light_ubo, atlas[1], mode=1)
                if fields:
                    grass.draw(fields, self, frame_ubo, objects, light_ubo, atlas[1], mode=1)
                gpu.state.blend_set("NONE")
                gpu.state.depth_mask_set(True)
            if textured:
                texture_space.illuminate(textured, objects, frame_ubo, light_ubo, atlas[1], mode=1, pipeline=self)
            if graphs:
                quadgraph.illuminate(graphs, objects, frame_ubo, light_ubo, atlas[1], mode=1, pipeline=self,
                                     size=(cam.width, cam.height))
            t3 = time.perf_counter()
            if with_caustics:
                caustics.draw_emitter(caustic_plan, frame, e, light_ubo, batches, objects, frame_ubo, fb, self,
                                      atlas[1])
            t_shadow += t2 - t1
            t_light += t3 - t2
            t_caustics += time.perf_counter() - t3
        timings["shadow_maps"] = t_shadow
        timings["lights"] = t_light
        if caustic_plan is not None:
            timings["caustics"] = t_caustics
        if subsurface.plan is not None:
            t1 = time.perf_counter()
            image_space.draw(subsurface, frame, batches, objects, frame_ubo, fb, self)
            timings["IMAGE_SPACE"] = time.perf_counter() - t1
        if textured:
            t1 = time.perf_counter()
            timings.update(texture_space.finish(textured, frame, frame_ubo, objects, fb, self, self.texture_product))
            timings["TEXTURE_SPACE"] = time.perf_counter() - t1
        if graphs:
            t1 = time.perf_counter()
            timings.update(quadgraph.finish(graphs, frame, frame_ubo, objects, fb, self, *self.quadgraph_solver))
            timings["QUADGRAPH"] = time.perf_counter() - t1
        if glass:
            timings.update(geocube.draw(glass, frame, frame_ubo, objects, fb, self))
        gpu.state.depth_test_set("NONE")
        gpu.state.depth_mask_set(False)
        timings["total"] = time.perf_counter() - t0
        self.last_timings = timings

    def _draw_environment(self, frame, frame_ubo) -> None:
        """The world image behind everything, where the world is an environment texture."""
        import gpu

        chain, env_tex = geocube.environment(frame)
        gpu.state.depth_test_set("NONE")
        gpu.state.depth_mask_set(False)
        gpu.state.blend_set("NONE")
        shader = shaders.get("env_background")
        shader.bind()
        shader.uniform_block("frame", frame_ubo)
        shader.uniform_sampler("env_atlas", env_tex)
        shader.uniform_int("env_res", int(chain.res))
        screen_quad(self, "env_background").draw(shader)
        gpu.state.depth_mask_set(True)

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
            base.draw(shader)

    @staticmethod
    def _draw_shadow(n_faces: int, texels: int, batches, objects, light_ubo, atlas) -> None:
        import gpu

        fb = atlas[3]
        shader = shaders.get("shadow_distance")
        with fb.bind():
            clear_target(fb, (3.0e38, 0.0, 0.0, 0.0))
            gpu.state.depth_test_set("LESS_EQUAL")
            gpu.state.depth_mask_set(True)
            gpu.state.blend_set("NONE")
            shader.bind()
            shader.uniform_block("light", light_ubo)
            for face in range(n_faces):
                gpu.state.viewport_set((face % 3) * texels, (face // 3) * texels, texels, texels)
                shader.uniform_int("face", face)
                for (_, shadow), obj in zip(batches, objects):
                    shader.uniform_block("object", obj)
                    shadow.draw(shader)


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


def draw_to_region(pipeline: Pipeline, frame: FrameInputs, size, bind_display, unbind_display) -> None:
    """The viewport: draw the frame into an RGBA16F offscreen the pipeline keeps (rebuilt when the region's
    size changes), then onto the region between ``bind_display`` and ``unbind_display`` (the engine's
    display-space shader: Blender's colour management)."""
    import gpu
    from gpu_extras.presets import draw_texture_2d

    off = pipeline.targets.get("viewport_offscreen")
    if off is None or (off.width, off.height) != tuple(size):
        off = pipeline.targets["viewport_offscreen"] = gpu.types.GPUOffScreen(*size, format="RGBA16F")
    with off.bind():
        pipeline.draw(frame)
    gpu.state.blend_set("ALPHA_PREMULT")
    bind_display()
    draw_texture_2d(off.texture_color, (0, 0), *size)
    unbind_display()
    gpu.state.blend_set("NONE")

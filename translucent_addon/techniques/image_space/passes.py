"""IMAGE_SPACE: image-space subsurface scattering by splatting (Shah ch. 6-7) on the GPU.

Per frame: material tables (``model.plan``); the base pass adds the near field of the
profile; then a camera-view G-buffer of positions and object slots (pass 2), and per emitter the
light-view samples (pass 1, a 3x2 cube atlas for point emitters) and one camera-facing splat per
sample (pass 3) accumulating the far field into a scatter texture; world light the same way from
depth-peeled samples along the three axes (Shah 6.4.2, ``_draw_world``); with temporal coherence on, the
far field is blended with the previous frame's, reprojected through each object's motion
(``image_space/temporal_blend.glsl``); finally the composite adds F_t / pi * S to the subsurface objects.
Blender-facing (``gpu``), the maths is in ``model`` and the GLSL in ``gpu_shaders/image_space/``.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.physics.lut import TAIL_BLOCK, TAIL_REACH, TAIL_START
from ...core.properties import Prop
from ...gpu import blocks, resources, shaders
from ...gpu.draw_state import draw_pass
from ...gpu.frame_context import FrameContext
from ...gpu.targets import cached_target, clear_target, new_target, read_pixels, screen_quad, texture_from_array
from ..protocol import Technique, Variant
from . import quality as image_space_quality
from .model import TAG_SLOTS, ImageSpacePlan, SamplingSettings, materials_block, plan  # noqa: F401

# The GLSL interface of this technique's passes (one file each in gpu_shaders/), joined to the
# shader table by the registry.
SHADER_SPECS = {
    "is_world_samples": shaders.ShaderSpec(
        source="image_space/world_samples.glsl",
        libraries=("common/common.glsl", "common/world_spherical_harmonics.glsl"),
        vertex_in=shaders.SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC4", "v_paint"),
                  ("smooth", "VEC3", "v_tint")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (3, "MaterialsData", "materials")),
        samplers=((0, "FLOAT_2D", "previous_pos_id"),),
        push_constants=(("MAT4", "view_proj"), ("INT", "layer"), ("FLOAT", "depth_epsilon"), ("FLOAT", "texel_area")),
        fragment_out=((0, "VEC4", "out_pos_id"), (1, "VEC4", "out_flux")),
    ),
    "is_gbuffer": shaders.ShaderSpec(
        source="image_space/gbuffer.glsl",
        vertex_in=(("VEC3", "pos"),),
        varyings=(("smooth", "VEC3", "v_world"),),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object")),
        fragment_out=((0, "VEC4", "out_pos_id"), (1, "VEC4", "out_normal")),
    ),
    "is_samples": shaders.ShaderSpec(
        source="image_space/light_samples.glsl",
        libraries=shaders.LIGHT_LIBS + ("common/angular_law.glsl", "common/oblique_entry.glsl"),
        vertex_in=shaders.SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC4", "v_paint"),
                  ("smooth", "VEC3", "v_tint")) + shaders.CURVATURE_OUT,
        uniform_blocks=((1, "ObjectData", "object"), (2, "LightData", "light"), (3, "MaterialsData", "materials")),
        push_constants=(("INT", "face"),),
        fragment_out=((0, "VEC4", "out_pos_id"), (1, "VEC4", "out_flux")),
    ),
    "is_splat": shaders.ShaderSpec(
        source="image_space/splat.glsl",
        libraries=("common/common.glsl", "common/angular_law.glsl"),
        vertex_in=(("VEC2", "corner"),),
        varyings=(("flat", "VEC3", "v_xi"), ("flat", "VEC4", "v_flux"), ("flat", "FLOAT", "v_slot")),
        uniform_blocks=((0, "FrameData", "frame"), (3, "MaterialsData", "materials")),
        samplers=((0, "FLOAT_2D", "sample_pos_id"), (1, "FLOAT_2D", "sample_flux"), (2, "FLOAT_2D", "gbuffer"),
                  (3, "FLOAT_2D", "far_lut"), (4, "FLOAT_2D", "gbuffer_normal")),
        push_constants=(("INT", "samples_per_row"), ("INT", "world_pass"), ("INT", "tail_pass"),
                        ("FLOAT", "tail_reach"), ("FLOAT", "tail_start"), ("INT", "tail_block")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "is_temporal": shaders.ShaderSpec(
        source="image_space/temporal_blend.glsl",
        vertex_in=(("VEC2", "corner"),),
        uniform_blocks=((0, "TemporalData", "temporal"),),
        samplers=((0, "FLOAT_2D", "scatter"), (1, "FLOAT_2D", "gbuffer"), (2, "FLOAT_2D", "previous_accum"),
                  (3, "FLOAT_2D", "previous_gbuffer")),
        push_constants=(("FLOAT", "blend"),),
        fragment_out=((0, "VEC4", "out_accum"),),
    ),
    "is_composite": shaders.ShaderSpec(
        source="image_space/composite.glsl",
        libraries=("common/common.glsl", "common/angular_law.glsl"),
        vertex_in=shaders.SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC4", "v_paint")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (3, "MaterialsData", "materials")),
        samplers=((0, "FLOAT_2D", "scatter"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
}

def _histories() -> dict:
    """Temporal coherence: per sequence key, the previous frame's accumulated far field, G-buffer, camera and
    object matrices (two targets of each, used in turn). Kept with the GPU resources, not a pipeline: every
    F12 may draw with a new one."""
    return resources.current().cache("image_space/history")


def clear_history() -> None:
    _histories().clear()


@dataclasses.dataclass
class Prepared:
    plan: ImageSpacePlan | None
    materials: object  # GPUUniformBuf
    near_lut: object  # GPUTexture
    far_lut: object  # GPUTexture


def prepare(frame, settings: SamplingSettings) -> Prepared:
    """The plan and its GPU data; placeholders when no mesh uses IMAGE_SPACE (the base pass binds them)."""
    import gpu

    p = plan(frame, settings)
    if p is None:
        empty = np.zeros((2, 2, 4), np.float32)
        return Prepared(None, gpu.types.GPUUniformBuf(materials_block(None)), texture_from_array(empty),
                        texture_from_array(empty))
    return Prepared(p, gpu.types.GPUUniformBuf(materials_block(p)), texture_from_array(p.near_lut()),
                    texture_from_array(p.far_lut()))


def _target(pipeline, name: str, size, depth: bool, attachments: int = 1):
    """Float render targets reused across frames: (framebuffer, color textures).

    The depth texture is kept in the cache too: a GPUTexture that Python frees is silently
    detached from the framebuffer, which then draws without a depth test.
    """
    return cached_target(pipeline, name, size, depth, attachments)[:2]


TEMPORAL_BLEND = 0.3  # weight of the current frame in the accumulated far field
TEMPORAL_OBJECTS = 32  # objects whose motion the temporal block carries (structs.glsl TemporalData)


def _history_for(pipeline, frame, p: ImageSpacePlan, size):
    """This sequence's temporal history (created or reset as needed), or None when coherence is off."""
    key = frame.settings.coherence_key
    if key is None:
        return None
    signature = (tuple(size), tuple(sorted((frame.meshes[k].name, tag) for k, tag in p.tag_of.items())))
    histories = _histories()
    history = histories.get(key)
    if history is None or history["signature"] != signature:
        history = histories[key] = {
            "signature": signature, "parity": 0, "frame": None, "view_proj": None, "models": None,
            "gbuffer": [new_target(size, depth=True, attachments=2) for _ in range(2)],
            "accum": [new_target(size, depth=False) for _ in range(2)],
        }
    return history


def _accumulate(history, frame, p: ImageSpacePlan, scatter, gbuf, pipeline, quad):
    """Blend this frame's far field with the previous accumulation, reprojected; returns the result."""
    import gpu

    parity = history["parity"]
    models = np.tile(np.eye(4), (TEMPORAL_OBJECTS, 1, 1))
    inverse = np.tile(np.eye(4), (TEMPORAL_OBJECTS, 1, 1))
    for k, tag in p.tag_of.items():
        number = tag // TAG_SLOTS - 1  # the block's first TEMPORAL_OBJECTS objects (the others keep no history)
        if number < TEMPORAL_OBJECTS:
            models[number] = frame.meshes[k].model
            inverse[number] = np.linalg.inv(frame.meshes[k].model)
    valid = history["frame"] == frame.settings.coherence_frame - 1 and history["view_proj"] is not None
    previous_models = history["models"] if valid else models
    data = np.concatenate([
        np.concatenate([m.T.ravel() for m in inverse]), np.concatenate([m.T.ravel() for m in previous_models]),
        np.asarray(history["view_proj"] if valid else frame.camera.view_proj).T.ravel(),
        [max(p.rho_world), 0.0, 0.0, 0.0]]).astype(np.float32)
    out_fb, (out,), _ = history["accum"][1 - parity]
    _, (previous_accum,), _ = history["accum"][parity]
    _, (previous_gbuffer, _), _ = history["gbuffer"][parity]
    shader = shaders.pass_shader("is_temporal")
    temporal_ubo = gpu.types.GPUUniformBuf(data.tobytes())  # referenced until the draw: a freed UBO reads as 0
    with draw_pass(out_fb):
        shader.bind()
        shader.uniform_block("temporal", temporal_ubo)
        shader.uniform_sampler("scatter", scatter)
        shader.uniform_sampler("gbuffer", gbuf)
        shader.uniform_sampler("previous_accum", previous_accum if valid else scatter)
        shader.uniform_sampler("previous_gbuffer", previous_gbuffer if valid else gbuf)
        shader.uniform_float("blend", TEMPORAL_BLEND if valid else 1.0)
        shader.draw(quad)
    history.update(parity=1 - parity, frame=frame.settings.coherence_frame, view_proj=frame.camera.view_proj,
                   models=models)
    return out


def _splat(prepared: Prepared, frame_ubo, pos_id, flux, gbuf, size, world: bool, quad) -> None:
    """Pass 3: one splat per sample of a (pos_id, flux) pair into the bound scatter target; ``gbuf`` is
    the camera view's (positions and slots, facet normals). Light samples also get their tail splats, one
    per TAIL_BLOCK x TAIL_BLOCK block (``physics.lut.crossover``)."""
    with draw_pass(None, blend="ADDITIVE_PREMULT"):
        shader = shaders.pass_shader("is_splat")
        shader.bind()
        shader.uniform_block("frame", frame_ubo)
        shader.uniform_block("materials", prepared.materials)
        shader.uniform_sampler("sample_pos_id", pos_id)
        shader.uniform_sampler("sample_flux", flux)
        shader.uniform_sampler("gbuffer", gbuf[0])
        shader.uniform_sampler("gbuffer_normal", gbuf[1])
        shader.uniform_sampler("far_lut", prepared.far_lut)
        shader.uniform_int("samples_per_row", size[0])
        shader.uniform_int("world_pass", 1 if world else 0)
        shader.uniform_float("tail_reach", TAIL_REACH)
        shader.uniform_float("tail_start", TAIL_START)
        shader.uniform_int("tail_block", TAIL_BLOCK)
        shader.uniform_int("tail_pass", 0)
        shader.draw_instanced(quad, size[0] * size[1])
        if not world:
            shader.uniform_int("tail_pass", 1)
            tail_grid = [-(-n // TAIL_BLOCK) for n in size]
            shader.draw_instanced(quad, tail_grid[0] * tail_grid[1])


def _draw_world(prepared: Prepared, frame_ubo, batches, objects, is_subsurface, scatter_fb, gbuf, pipeline,
                quad) -> None:
    """World light (Shah 6.4.2): depth peel the subsurface meshes along each axis, ``layers`` deep,
    and splat every layer's samples. Two sample targets in turn: a layer reads the previous one's
    positions to skip what is peeled already."""
    import gpu

    w = prepared.plan.world
    size = (w.grid, w.grid)
    targets = [_target(pipeline, f"world_samples_{i}", size, depth=True, attachments=2) for i in range(2)]
    peel = shaders.pass_shader("is_world_samples")
    for axis in range(3):
        for layer in range(w.layers):
            fb, (pos_id, flux) = targets[layer % 2]
            previous = targets[(layer + 1) % 2][1][0]
            with draw_pass(fb, depth_test="LESS", depth_write=True):
                clear_target(fb)
                gpu.state.viewport_set(0, 0, w.grid, w.grid)
                peel.bind()
                peel.uniform_block("frame", frame_ubo)
                peel.uniform_block("materials", prepared.materials)
                peel.uniform_sampler("previous_pos_id", previous)
                peel.uniform_float("view_proj", [float(x) for x in w.faces[axis].T.ravel()])
                peel.uniform_int("layer", layer)
                peel.uniform_float("depth_epsilon", float(w.depth_epsilon))
                peel.uniform_float("texel_area", float(w.texel_area))
                for (full, _), obj, sss in zip(batches, objects, is_subsurface):
                    if sss:
                        peel.uniform_block("object", obj)
                        peel.draw(full)
                if pipeline.capture is not None:
                    pipeline.capture.setdefault("world_samples", []).append(
                        (read_pixels(fb, *size, slot=0), read_pixels(fb, *size, slot=1)))
            with scatter_fb.bind():
                _splat(prepared, frame_ubo, pos_id, flux, gbuf, size, True, quad)


def draw(prepared: Prepared, frame, batches, objects, frame_ubo, target_fb, pipeline) -> None:
    import gpu

    p = prepared.plan
    cam = frame.camera
    size = (cam.width, cam.height)
    is_subsurface = [k in p.slot_of for k in range(len(frame.meshes))]

    history = _history_for(pipeline, frame, p, size)
    # Pass 2: camera-view positions and slots of every surface (others occlude with slot 0).
    if history is not None:
        gbuf_fb, (gbuf, gbuf_normal), _ = history["gbuffer"][1 - history["parity"]]
    else:
        gbuf_fb, (gbuf, gbuf_normal) = _target(pipeline, "gbuffer", size, depth=True, attachments=2)
    shader = shaders.pass_shader("is_gbuffer")
    with draw_pass(gbuf_fb, depth_test="LESS_EQUAL", depth_write=True):
        clear_target(gbuf_fb)
        shader.bind()
        shader.uniform_block("frame", frame_ubo)
        for (_, pos_only), obj in zip(batches, objects):
            shader.uniform_block("object", obj)
            shader.draw(pos_only)
        if pipeline.capture is not None:
            pipeline.capture["gbuffer"] = read_pixels(gbuf_fb, *size)
            pipeline.capture["gbuffer_normal"] = read_pixels(gbuf_fb, *size, slot=1)

    scatter_fb, (scatter,) = _target(pipeline, "scatter", size, depth=False)
    with scatter_fb.bind():
        clear_target(scatter_fb, depth=None)

    samples_shader = shaders.pass_shader("is_samples")
    quad = screen_quad(pipeline, "is_splat")
    for sampling in p.samplings:
        n = sampling.grid
        atlas_size = (3 * n, 2 * n) if sampling.n_faces == 6 else (n, n)
        light_ubo = gpu.types.GPUUniformBuf(
            blocks.light_block(sampling.emitter, sampling.faces, sampling.origin, n, sampling.texel_measure,
                               normal_offset_texels=sampling.tan_half))
        samples_fb, (pos_id, flux) = _target(pipeline, "samples", atlas_size, depth=True, attachments=2)
        # Pass 1: light-view samples x_i with the power entering through each texel.
        with draw_pass(samples_fb, depth_test="LESS_EQUAL", depth_write=True):
            clear_target(samples_fb)
            samples_shader.bind()
            samples_shader.uniform_block("light", light_ubo)
            samples_shader.uniform_block("materials", prepared.materials)
            for face in range(sampling.n_faces):
                gpu.state.viewport_set((face % 3) * n, (face // 3) * n, n, n)
                samples_shader.uniform_int("face", face)
                for (full, _), obj in zip(batches, objects):
                    samples_shader.uniform_block("object", obj)
                    samples_shader.draw(full)
            if pipeline.capture is not None:
                pipeline.capture.setdefault("samples", []).append(
                    (read_pixels(samples_fb, *atlas_size, slot=0), read_pixels(samples_fb, *atlas_size, slot=1)))
        # Pass 3: a splat per sample into the scatter texture.
        with scatter_fb.bind():
            _splat(prepared, frame_ubo, pos_id, flux, (gbuf, gbuf_normal), atlas_size, False, quad)
    if p.world is not None:
        _draw_world(prepared, frame_ubo, batches, objects, is_subsurface, scatter_fb, (gbuf, gbuf_normal), pipeline,
                    quad)
    if pipeline.capture is not None:
        with scatter_fb.bind():
            pipeline.capture["scatter"] = read_pixels(scatter_fb, *size)
        pipeline.capture["plan"] = p

    if history is not None:
        scatter = _accumulate(history, frame, p, scatter, gbuf, pipeline, quad)

    # Final: add F_t / pi * S to the subsurface objects' visible pixels.
    composite = shaders.pass_shader("is_composite")
    with draw_pass(target_fb, blend="ADDITIVE_PREMULT", depth_test="LESS_EQUAL"):
        composite.bind()
        composite.uniform_block("frame", frame_ubo)
        composite.uniform_block("materials", prepared.materials)
        composite.uniform_sampler("scatter", scatter)
        for (full, _), obj, sss in zip(batches, objects, is_subsurface):
            if sss:
                composite.uniform_block("object", obj)
                composite.draw(full)


class ImageSpace(Technique):
    """Shah ch. 6-7: its prepare always answers (the base pass reads its materials and near-field LUT, with
    placeholders when no mesh uses it); it draws only when a mesh does."""

    scene_props = (
        Prop("splat_threshold", "FloatProperty", {
            "name": "Splat threshold",
            "description": "Share of the spread light each splat may cut off at its edge: smaller reaches further and "
                           "is slower",
            "min": 0.0001,
            "max": 0.2,
            "default": 0.01,
            "precision": 3,
        }),
        Prop("splat_overlap", "FloatProperty", {
            "name": "Splat overlap",
            "description": "Light samples per splat radius: more is smoother and slower",
            "min": 2.0,
            "max": 128.0,
            "default": 32.0,
        }),
        Prop("splat_max_grid", "IntProperty", {
            "name": "Max samples per side",
            "description": "Light samples per side of a light's view, at most: caps the cost of a light close to the "
                           "object",
            "min": 16,
            "max": 4096,
            "default": 1024,
        }),
        Prop("splat_world_layers", "IntProperty", {
            "name": "World layers",
            "description": ("Layers of each object lit by the world, per axis: more lets sky light through thin parts, "
                            "slower; 0 lights only the surface (cheaper)"),
            "min": 0,
            "max": 16,
            "default": 4,
        }),
        Prop("splat_world_overlap", "FloatProperty", {
            "name": "World overlap",
            "description": ("World light samples per splat radius (fewer than the lights' suffice: world light is "
                            "smooth)"),
            "min": 2.0,
            "max": 64.0,
            "default": 16.0,
        }),
        Prop("temporal_coherence", "BoolProperty", {
            "name": "Temporal coherence",
            "description": ("Reuse the previous frame's light samples to reduce flicker in animation and in the "
                            "viewport"),
            "default": True,
        }),
    )
    shader_specs = SHADER_SPECS
    id, label, method_number, timing = "IMAGE_SPACE", "Image Space", 1, "IMAGE_SPACE"
    description = "Light spread across the screen from each light's view: no bake, works on deforming objects"
    no_bake_reason = "IMAGE_SPACE needs no bake: it splats the profile every frame"
    scene_properties = ("splat_threshold", "splat_overlap", "splat_max_grid", "splat_world_layers",
                        "splat_world_overlap")
    draws_layers = True  # the one method that draws a layer over a base (the multipole, Shah 6.5)
    draws_paint = True
    base_entry_shift = True
    # Its one resolution, the scene's splat overlap, is chosen every frame from the camera that draws it.
    auto_note = "at the scene camera; chosen again every frame from the camera that draws it"

    def frame_settings(self, frame, settings, results: dict, cache: dict) -> SamplingSettings:
        """k as the frame's AUTO objects need it seen by its camera (``quality.frame_sampling``, their sizes kept
        in ``cache``); what they asked for goes into ``results`` ({objects: {name: k}, overlap, max_grid}; empty
        when none did)."""
        shapes = cache.setdefault("shapes", {})
        sampling, asked = image_space_quality.frame_sampling(frame, settings or SamplingSettings(), shapes)
        results.clear()
        if asked:
            results.update(objects=asked, overlap=sampling.overlap, max_grid=sampling.max_grid)
        return sampling

    scene_panel = (("splat_threshold", "splat_overlap", "splat_max_grid"),
                   ("splat_world_layers", "splat_world_overlap", "temporal_coherence"))

    def scene_panel_notes(self, results: dict) -> list[str]:
        if not results:
            return []
        return [f"Last frame: overlap {results['overlap']:g}, {results['max_grid']} per side, chosen by Auto objects"]

    compare_defaults, compare_quick = (8.0, 16.0, 32.0, 48.0), (8.0, 16.0)
    scene_tiers = {"DRAFT": {"splat_overlap": 16.0}, "STANDARD": {"splat_overlap": 32.0},
                   "HIGH": {"splat_overlap": 48.0}}

    def compare_variants(self, values: tuple) -> list[Variant]:
        """One image per splat overlap k (past 32, with up to 2048 samples a side)."""
        variants = []
        for k in values:
            scene_values = {"splat_overlap": float(k), **({"splat_max_grid": 2048} if k > 32 else {})}
            variants.append(Variant(f"k={k:g}", scene_values=scene_values, record=scene_values))
        return variants

    def panel_notes(self, results: dict, object_name: str) -> list[str]:
        k = results.get("objects", {}).get(object_name)
        if k is None:
            return []
        return [f"Last frame: splat overlap {k:g} for this object, {results['overlap']:g} in the scene"]

    def settings(self, values: dict) -> SamplingSettings:
        return SamplingSettings(epsilon=values["splat_threshold"], overlap=values["splat_overlap"],
                                max_grid=values["splat_max_grid"], world_layers=values["splat_world_layers"],
                                world_overlap=values["splat_world_overlap"])

    def auto_quality(self, view, target: float, curves: str):
        return image_space_quality.auto(view, target, curves)

    def prepare(self, ctx: FrameContext) -> Prepared:
        return prepare(ctx.frame, ctx.frame.settings.of(self.id) or SamplingSettings())

    def base_lighting(self, state: Prepared):
        return state.materials, state.near_lut, (state.plan.tag_of if state.plan else {})

    def finish(self, ctx: FrameContext, state: Prepared):
        if state.plan is None:
            return None
        draw(state, ctx.frame, ctx.batches, ctx.objects, ctx.frame_ubo, ctx.target, ctx.resources)
        return {}

    def clear_caches(self) -> None:
        clear_history()


TECHNIQUE = ImageSpace()

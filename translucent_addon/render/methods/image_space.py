"""IMAGE_SPACE: image-space subsurface scattering by splatting (Shah ch. 6-7) on the GPU.

Per frame: material tables (``image_space_data.plan``); the base pass adds the near field of the
profile; then a camera-view G-buffer of positions and object slots (pass 2), and per emitter the
light-view samples (pass 1, a 3x2 cube atlas for point emitters) and one camera-facing splat per
sample (pass 3) accumulating the far field into a scatter texture; finally the composite adds
F_t / pi * S to the subsurface objects. Blender-facing (``gpu``), the maths is in
``image_space_data`` and the GLSL in ``gpu_shaders/is_*.glsl``.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .. import blocks, shaders
from .image_space_data import FAR_SAMPLES, NEAR_SAMPLES, ImageSpacePlan, SamplingSettings, plan  # noqa: F401


@dataclasses.dataclass
class Prepared:
    plan: ImageSpacePlan | None
    materials: object  # GPUUniformBuf
    near_lut: object  # GPUTexture
    far_lut: object  # GPUTexture


def _texture(array: np.ndarray):
    import gpu

    rows, cols, _ = array.shape
    data = gpu.types.Buffer("FLOAT", array.size, np.ascontiguousarray(array, np.float32).ravel().tolist())
    return gpu.types.GPUTexture((cols, rows), format="RGBA32F", data=data)


def prepare(frame, settings: SamplingSettings) -> Prepared:
    """The plan and its GPU data; placeholders when no mesh uses IMAGE_SPACE (the base pass binds them)."""
    import gpu

    p = plan(frame, settings)
    if p is None:
        empty = np.zeros((1, 2, 4), np.float32)
        return Prepared(None, gpu.types.GPUUniformBuf(bytes(64 * 16)), _texture(empty), _texture(empty))
    return Prepared(p, gpu.types.GPUUniformBuf(p.materials_block()), _texture(p.near_lut()), _texture(p.far_lut()))


def _target(pipeline, name: str, size, depth: bool, attachments: int = 1):
    """Float render targets reused across frames: (framebuffer, color textures).

    The depth texture is kept in the cache too: a GPUTexture that Python frees is silently
    detached from the framebuffer, which then draws without a depth test.
    """
    import gpu

    key = (name, tuple(size), depth, attachments)
    found = pipeline.targets.get(key)
    if found is None:
        colors = [gpu.types.GPUTexture(size, format="RGBA32F") for _ in range(attachments)]
        depth_tex = gpu.types.GPUTexture(size, format="DEPTH_COMPONENT32F") if depth else None
        fb = gpu.types.GPUFrameBuffer(depth_slot=depth_tex, color_slots=colors if attachments > 1 else colors[0])
        pipeline.targets[key] = (fb, colors, depth_tex)
        found = pipeline.targets[key]
    return found[:2]


def _quad_batch(pipeline):
    batch = pipeline.targets.get("splat_quad")
    if batch is None:
        from gpu_extras.batch import batch_for_shader

        corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, -1), (1, 1), (-1, 1)], np.float32)
        batch = pipeline.targets["splat_quad"] = batch_for_shader(shaders.get("is_splat"), "TRIS",
                                                                  {"corner": corners})
    return batch


def draw(prepared: Prepared, frame, batches, objects, frame_ubo, target_fb, pipeline) -> None:
    import gpu

    from ..pipeline import clear_target, read_pixels

    p = prepared.plan
    cam = frame.camera
    size = (cam.width, cam.height)
    is_subsurface = [k in p.slot_of for k in range(len(frame.meshes))]

    # Pass 2: camera-view positions and slots of every surface (others occlude with slot 0).
    gbuf_fb, (gbuf,) = _target(pipeline, "gbuffer", size, depth=True)
    shader = shaders.get("is_gbuffer")
    with gbuf_fb.bind():
        clear_target(gbuf_fb)
        gpu.state.depth_test_set("LESS_EQUAL")
        gpu.state.depth_mask_set(True)
        gpu.state.blend_set("NONE")
        shader.bind()
        shader.uniform_block("frame", frame_ubo)
        for (_, pos_only), obj in zip(batches, objects):
            shader.uniform_block("object", obj)
            pos_only.draw(shader)
        if pipeline.capture is not None:
            pipeline.capture["gbuffer"] = read_pixels(gbuf_fb, *size)

    scatter_fb, (scatter,) = _target(pipeline, "scatter", size, depth=False)
    with scatter_fb.bind():
        clear_target(scatter_fb, depth=None)

    samples_shader = shaders.get("is_samples")
    splat_shader = shaders.get("is_splat")
    quad = _quad_batch(pipeline)
    centre, radius = frame.bounds()
    for sampling in p.samplings:
        n = sampling.grid
        atlas_size = (3 * n, 2 * n) if sampling.n_faces == 6 else (n, n)
        light_ubo = gpu.types.GPUUniformBuf(
            blocks.light_block(sampling.emitter, sampling.faces, sampling.origin, n, sampling.texel_measure))
        # Pass 1: light-view samples x_i with the power entering through each texel.
        samples_fb, (pos_id, flux) = _target(pipeline, "samples", atlas_size, depth=True, attachments=2)
        with samples_fb.bind():
            clear_target(samples_fb)
            gpu.state.depth_test_set("LESS_EQUAL")
            gpu.state.depth_mask_set(True)
            gpu.state.blend_set("NONE")
            samples_shader.bind()
            samples_shader.uniform_block("light", light_ubo)
            samples_shader.uniform_block("materials", prepared.materials)
            for face in range(sampling.n_faces):
                gpu.state.viewport_set((face % 3) * n, (face // 3) * n, n, n)
                samples_shader.uniform_int("face", face)
                for (full, _), obj in zip(batches, objects):
                    samples_shader.uniform_block("object", obj)
                    full.draw(samples_shader)
            if pipeline.capture is not None:
                pipeline.capture.setdefault("samples", []).append(
                    (read_pixels(samples_fb, *atlas_size, slot=0), read_pixels(samples_fb, *atlas_size, slot=1)))
        # Pass 3: a splat per sample into the scatter texture.
        with scatter_fb.bind():
            gpu.state.depth_test_set("NONE")
            gpu.state.depth_mask_set(False)
            gpu.state.blend_set("ADDITIVE_PREMULT")
            splat_shader.bind()
            splat_shader.uniform_block("frame", frame_ubo)
            splat_shader.uniform_block("materials", prepared.materials)
            splat_shader.uniform_sampler("sample_pos_id", pos_id)
            splat_shader.uniform_sampler("sample_flux", flux)
            splat_shader.uniform_sampler("gbuffer", gbuf)
            splat_shader.uniform_sampler("far_lut", prepared.far_lut)
            splat_shader.uniform_int("samples_per_row", atlas_size[0])
            quad.draw_instanced(splat_shader, instance_start=0, instance_count=atlas_size[0] * atlas_size[1])
            gpu.state.blend_set("NONE")
    if pipeline.capture is not None:
        with scatter_fb.bind():
            pipeline.capture["scatter"] = read_pixels(scatter_fb, *size)
        pipeline.capture["plan"] = p

    # Final: add F_t / pi * S to the subsurface objects' visible pixels.
    composite = shaders.get("is_composite")
    with target_fb.bind():
        gpu.state.depth_test_set("LESS_EQUAL")
        gpu.state.depth_mask_set(False)
        gpu.state.blend_set("ADDITIVE_PREMULT")
        composite.bind()
        composite.uniform_block("frame", frame_ubo)
        composite.uniform_block("materials", prepared.materials)
        composite.uniform_sampler("scatter", scatter)
        for (full, _), obj, sss in zip(batches, objects, is_subsurface):
            if sss:
                composite.uniform_block("object", obj)
                full.draw(composite)
        gpu.state.blend_set("NONE")
        gpu.state.depth_mask_set(True)

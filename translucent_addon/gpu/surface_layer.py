"""The materials' surface layer over what the methods drew (``gpu_shaders/pipeline/surface_layer.glsl``).

One pass per frame after the base's world pass (``world``: the world's gloss, the factor on the light below the
layer, the Normal and Depth passes, into the layer's own targets and depth), one per emitter after its base pass
(``emitter``: that emitter's gloss, with its shadow atlas), and at the end ``composite``: the frame times the
factor, plus the gloss. The layer keeps its gloss apart until then: the factor (a colour texture, the layering
weight) scales only what lies below the layer, and the Specular render pass is that target as it stands.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..core.frame import FrameInputs, MeshInstance
from ..core.physics import microfacet
from ..core.surface import Surface, plain
from . import draw_state, shaders
from .targets import cached_target, clear_target, screen_quad, texture_from_array

FAR_DEPTH = 1.0e10  # the Depth pass where no surface is (the layer stores 0 there)


@dataclasses.dataclass
class LayerFrame:
    """What one frame's surface layer draws: per mesh index, its surface or None (neutral: depth and passes
    only), the targets, and whether any factor or gloss needs compositing."""

    surfaces: list
    fb_world: object
    fb_light: object
    textures: list  # specular, entry, factor, gbuffer
    lit: list  # mesh indices with a rough gloss (drawn per emitter)
    factor_on: bool
    gloss_on: bool


class SurfaceLayer:
    """The layer's GPU resources for one pipeline: batches per surface, the albedo tables, images."""

    def __init__(self):
        self._batches: dict = {}
        self._images: dict = {}
        self._tables = None
        self._neutral = None
        self._plain: dict[int, Surface] = {}  # a neutral surface per corner count, made once

    def free(self) -> None:
        self._batches.clear()
        self._images.clear()
        self._tables = None
        self._neutral = None
        self._plain.clear()

    def _batch(self, mesh: MeshInstance, surface: Surface):
        key = (mesh.key, surface.key)
        batch = self._batches.get(key)
        if batch is None:
            from gpu_extras.batch import batch_for_shader

            if len(self._batches) > 256:
                self._batches.clear()
            arrays = {
                "pos": np.ascontiguousarray(mesh.positions, np.float32),
                "nor": np.ascontiguousarray(mesh.normals, np.float32),
                "uv": np.ascontiguousarray(surface.uv, np.float32),
                "tangent": np.ascontiguousarray(surface.tangent, np.float32),
                "albedo": np.ascontiguousarray(surface.albedo, np.float32),
                "gloss": np.ascontiguousarray(surface.gloss, np.float32),
            }
            batch = self._batches[key] = batch_for_shader(shaders.get("surface_world"), "TRIS", arrays)
        return batch

    def _image(self, ref):
        if ref is None:
            return self._placeholder()
        tex = self._images.get(ref.key)
        if tex is None:
            if len(self._images) > 16:
                self._images.clear()
            tex = self._images[ref.key] = texture_from_array(ref.pixels, "RGBA16F")
        return tex

    def _placeholder(self):
        if self._neutral is None:
            self._neutral = texture_from_array(np.ones((1, 1, 4), np.float32), "RGBA16F")
        return self._neutral

    def tables(self):
        if self._tables is None:
            albedo = microfacet.albedo_table()
            energy = microfacet.energy_table()
            self._tables = (texture_from_array(np.repeat(albedo[..., None], 4, -1), "RGBA32F"),
                            texture_from_array(np.repeat(energy[..., None], 4, -1), "RGBA32F"))
        return self._tables

    # -- a frame ---------------------------------------------------------------------------------------------------
    def begin(self, frame: FrameInputs, pipeline, drawn_over, passes: bool) -> LayerFrame | None:
        """The frame's layer, or None when it draws nothing (no gloss, no texture, no passes asked).
        ``drawn_over(mesh)``: whether the layer covers that mesh (its method and extras allow it)."""
        surfaces = [m.surface_or_plain() if drawn_over(m) else None for m in frame.meshes]
        factor_on = any(s is not None and (s.textured or s.normal_map is not None
                                           or (s.glossy and (s.gloss[:, 0] > 0).any())) for s in surfaces)
        gloss_on = any(s is not None and s.glossy for s in surfaces)
        if not (factor_on or gloss_on or passes):
            return None
        size = (frame.camera.width, frame.camera.height)
        fb, textures, depth = cached_target(pipeline, "surface_layer", size, depth=True, attachments=4)
        key = ("surface_layer_light", size)
        light = pipeline.targets.get(key)
        if light is None or light[1] is not textures[0]:
            import gpu

            light = pipeline.targets[key] = (gpu.types.GPUFrameBuffer(depth_slot=depth, color_slots=textures[:2]),
                                             textures[0], depth)
        # per emitter: the meshes with a rough gloss, and those with a normal map (the light it lets in)
        lit = [k for k, s in enumerate(surfaces)
               if s is not None and ((s.glossy and bool(((s.gloss[:, 0] ** 2 >= microfacet.MIN_ALPHA)
                                                         & (s.gloss[:, 3] > 0) & (s.gloss[:, 1] > 0)).any()))
                                     or s.normal_map is not None)]
        return LayerFrame(surfaces, fb, light[0], textures, lit, factor_on, gloss_on)

    def _bind(self, name: str, frame_ubo, light_ubo, shadow_atlas):
        shader = shaders.pass_shader(name).bind()
        shader.uniform_block("frame", frame_ubo)
        shader.uniform_block("light", light_ubo)
        shader.uniform_sampler("shadow_atlas", shadow_atlas)
        specular, energy = self.tables()
        shader.uniform_sampler("specular_table", specular)
        shader.uniform_sampler("energy_table", energy)
        return shader

    def _draw_mesh(self, shader, mesh: MeshInstance, surface: Surface | None, obj, world: bool) -> None:
        neutral = surface is None
        if neutral:  # factor 1, no gloss: the layer leaves it as its method drew it (its depth and normal count)
            n = len(mesh.positions)
            surface = self._plain.get(n)
            if surface is None:
                surface = self._plain[n] = plain(n)
        shader.uniform_block("object", obj)
        shader.uniform_sampler("normal_map", self._image(surface.normal_map))
        shader.uniform_int("normal_mode", -1 if surface.normal_map is None else surface.normal_map.mode)
        if world:  # what only the world pass reads
            shader.uniform_float("spread", 0.0 if neutral else diffusion_length(mesh))
            shader.uniform_sampler("albedo_map", self._image(surface.albedo_map))
            shader.uniform_int("albedo_mode", 0 if surface.albedo_map is None else surface.albedo_map.mode)
            shader.uniform_float("base_eta", 0.0 if neutral or mesh.medium is None else float(mesh.medium.eta))
        shader.draw(self._batch(mesh, surface))

    def world(self, layer: LayerFrame, frame: FrameInputs, objects, frame_ubo, placeholder_light, shadow_atlas):
        """Mode 0: the world's gloss, the factor and the passes of every mesh, with the layer's own depth."""
        with draw_state.draw_pass(layer.fb_world, depth_test="LESS_EQUAL", depth_write=True):
            # one colour clears every attachment: the factor is stored less 1 and the depth 0 where nothing is
            clear_target(layer.fb_world, (0.0, 0.0, 0.0, 0.0))
            shader = self._bind("surface_world", frame_ubo, placeholder_light, shadow_atlas)
            shader.uniform_float("pixels_y", float(frame.camera.height))
            for mesh, surface, obj in zip(frame.meshes, layer.surfaces, objects):
                self._draw_mesh(shader, mesh, surface, obj, True)

    def neutralise(self, layer: LayerFrame, frame: FrameInputs, objects, frame_ubo, placeholder_light, shadow_atlas,
                   meshes: list[int]) -> None:
        """Draw these meshes again as the layer leaves a mesh alone (factor 1, no gloss, no entering light): their
        method fell back to the base colour after the world pass."""
        with draw_state.draw_pass(layer.fb_world, depth_test="LESS_EQUAL", depth_write=True):
            shader = self._bind("surface_world", frame_ubo, placeholder_light, shadow_atlas)
            shader.uniform_float("pixels_y", float(frame.camera.height))
            for k in meshes:
                layer.surfaces[k] = None
                self._draw_mesh(shader, frame.meshes[k], None, objects[k], True)

    def emitter(self, layer: LayerFrame, frame: FrameInputs, objects, frame_ubo, light_ubo, shadow_atlas) -> None:
        """Mode 1: one emitter's gloss, added where the world pass left the nearest surface."""
        if not layer.lit:
            return
        with draw_state.draw_pass(layer.fb_light, blend="ADDITIVE_PREMULT", depth_test="LESS_EQUAL"):
            shader = self._bind("surface_light", frame_ubo, light_ubo, shadow_atlas)
            for k in layer.lit:
                self._draw_mesh(shader, frame.meshes[k], layer.surfaces[k], objects[k], False)

    def composite(self, layer: LayerFrame, target, pipeline) -> None:
        """The frame below the layer times its factor, then plus its gloss."""
        if layer.factor_on:  # the factor is stored less 1 (``offset``)
            self._composite_pass(layer, target, pipeline, "MULTIPLY", layer.textures[2], 1.0)
        if layer.gloss_on:
            self._composite_pass(layer, target, pipeline, "ADDITIVE_PREMULT", layer.textures[0], 0.0)

    @staticmethod
    def _composite_pass(layer: LayerFrame, target, pipeline, blend: str, image, offset: float) -> None:
        """One of the layer's images onto the frame, full screen, blended as ``blend``."""
        shader = shaders.pass_shader("surface_composite")
        with draw_state.draw_pass(target, blend=blend):
            shader.bind()
            shader.uniform_sampler("layer", image)
            shader.uniform_sampler("entry_map", layer.textures[1])
            shader.uniform_sampler("gbuffer_map", layer.textures[3])
            shader.uniform_float("offset", offset)
            shader.draw(screen_quad(pipeline, "surface_composite"))


def diffusion_length(mesh: MeshInstance) -> float:
    """The medium's diffusion length 1 / sigma_tr (Jensen 2001: sigma_tr = sqrt(3 sigma_a sigma_t')), the mean over
    its channels, in scene units; 0 for a Lambert object: how far the light a bump lets in spreads."""
    m = mesh.medium
    if m is None:
        return 0.0
    sa, ss = np.asarray(m.sigma_a, np.float64), np.asarray(m.sigma_s_prime, np.float64)
    sigma_tr = np.sqrt(3.0 * sa * (sa + ss))
    return float(np.mean(1.0 / np.maximum(sigma_tr, 1e-9))) / float(m.mm_per_unit)

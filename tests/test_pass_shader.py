"""``gpu.shaders.PassShader`` on the backend Blender runs: push constants survive sampler bindings in any order, and
read-backs of three channels take four floats a pixel (docs/gpu_backends.md, causes 1 and 2). Each drawn in a bare
render engine of the test's own, so that only the call under test is between the set-up and the read-back."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

from conftest import ext_module  # noqa: E402

GLSL = Path(__file__).parent / "data" / "push_after_samplers.glsl"
SAMPLERS = 7  # as ts_product: its seventh sampler overwrote vertex_width on 5.3 OpenGL


def _draw_in_engine(body):
    """Run ``body()`` inside RenderEngine.render of a throwaway engine (a GPU context, also headless)."""
    out = {}

    class Probe(bpy.types.RenderEngine):
        bl_idname = "TRANSLUCENT_TEST_PROBE"
        bl_label = "Probe (test)"
        bl_use_gpu_context = True

        def render(self, depsgraph):
            try:
                out["value"] = body()
            except Exception as err:  # noqa: BLE001 -- handed to the test, which raises it
                out["error"] = err

    bpy.utils.register_class(Probe)
    try:
        scene = bpy.context.scene
        if scene.camera is None:  # Blender renders nothing without one
            scene.camera = bpy.data.objects.new("ProbeCamera", bpy.data.cameras.new("ProbeCamera"))
            scene.collection.objects.link(scene.camera)
        scene.render.engine = Probe.bl_idname
        scene.render.resolution_x = scene.render.resolution_y = 4
        scene.render.resolution_percentage = 100
        bpy.ops.render.render()
    finally:
        bpy.utils.unregister_class(Probe)
    if "error" in out:
        raise out["error"]
    return out["value"]


def test_push_constants_set_before_samplers_reach_the_draw(tr, scene):
    """Three push constants set first, then seven samplers, then a draw: the shader reads the constants as set and
    each sampler as bound (5.3 OpenGL's bare GPUShader read the first constant as the last sampler's slot)."""
    shaders = ext_module(tr, "translucent_addon.gpu.shaders")
    targets = ext_module(tr, "translucent_addon.gpu.targets")
    name = "test_push_after_samplers"
    shaders.add_specs({name: shaders.ShaderSpec(
        source=str(GLSL), libraries=(), vertex_in=(("VEC2", "corner"),),
        samplers=tuple((k, "FLOAT_2D", f"s{k}") for k in range(SAMPLERS)),
        push_constants=(("INT", "first"), ("INT", "second"), ("FLOAT", "third")),
        fragment_out=((0, "VEC4", "out_color"),))})

    def body():
        import gpu
        from gpu_extras.batch import batch_for_shader

        fb, (color,), _ = targets.new_target((2, 2))
        textures = [targets.texture_from_array(np.full((1, 1, 4), k + 1.0, np.float32)) for k in range(SAMPLERS)]
        quad = batch_for_shader(shaders.get(name), "TRIS", {"corner": np.array(
            [(-1, -1), (1, -1), (1, 1), (-1, -1), (1, 1), (-1, 1)], np.float32)})
        with fb.bind():
            targets.clear_target(fb, depth=None)
            shader = shaders.pass_shader(name).bind()
            shader.uniform_int("first", 256)
            shader.uniform_int("second", 257)
            shader.uniform_float("third", 0.5)
            for k, texture in enumerate(textures):
                shader.uniform_sampler(f"s{k}", texture)
            shader.draw(quad)
            rgba = targets.read_pixels(fb, 2, 2)
            rgb = targets.read_pixels(fb, 2, 2, channels=3)
        return gpu.platform.backend_type_get(), rgba, rgb

    try:
        backend, rgba, rgb = _draw_in_engine(body)
    finally:
        shaders.remove_specs([name])
    expected = np.array([256.0, 257.0, 0.5, sum(range(1, SAMPLERS + 1))], np.float32)
    np.testing.assert_array_equal(rgba, np.broadcast_to(expected, (2, 2, 4)), err_msg=backend)
    assert rgb.shape == (2, 2, 3) and np.array_equal(rgb, rgba[..., :3])

"""Adding a technique is a folder and one line in the registry: a constant-colour technique, defined here,
registered at run time, chosen as an object's method, drawn by F12, and gone after unregister."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import add_camera, add_cube, add_light, render, set_world  # noqa: E402
from conftest import ext_module  # noqa: E402

COLOUR = (0.2, 0.9, 0.4, 1.0)
GLSL = Path(__file__).parent / "data" / "constant_colour.glsl"


def constant_colour_technique(tr):
    protocol = ext_module(tr, "translucent_addon.techniques.protocol")
    shaders = ext_module(tr, "translucent_addon.gpu.shaders")

    class ConstantColour(protocol.Technique):
        id, label, method_number = "CONSTANT_TEST", "Constant (test)", 100
        description = "Its meshes in one colour"
        shader_specs = {"constant_test": shaders.ShaderSpec(
            source=str(GLSL), libraries=(), vertex_in=(("VEC3", "pos"),),
            uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object")),
            push_constants=(("VEC4", "colour"),), fragment_out=((0, "VEC4", "out_color"),))}

        def prepare(self, ctx):
            return [k for k, m in enumerate(ctx.frame.meshes) if m.method == self.id] or None

        def finish(self, ctx, state):
            import gpu

            with ctx.target.bind():
                gpu.state.depth_test_set("LESS_EQUAL")
                gpu.state.depth_mask_set(False)
                gpu.state.blend_set("NONE")
                shader = shaders.pass_shader("constant_test")
                shader.bind()
                shader.uniform_block("frame", ctx.frame_ubo)
                shader.uniform_float("colour", COLOUR)
                for k in state:
                    shader.uniform_block("object", ctx.objects[k])
                    shader.draw(ctx.batches[k][0])
                gpu.state.depth_mask_set(True)
            return {}

    return ConstantColour()


def test_a_technique_registered_at_run_time_draws_and_leaves_nothing_behind(tr, scene):
    techniques = ext_module(tr, "translucent_addon.techniques")
    shaders = ext_module(tr, "translucent_addon.gpu.shaders")
    set_world(scene, (0.05, 0.05, 0.05))
    cube = add_cube(scene)
    add_light(scene, "SUN", (3, -2, 5), energy=2.0)
    add_camera(scene, (3.0, -3.0, 2.5), (0, 0, 0.5))
    plain = render(scene, 48, 48)
    with pytest.raises(TypeError):
        cube.translucent.method = "CONSTANT_TEST"

    technique = constant_colour_technique(tr)
    techniques.register(technique)
    try:
        assert "CONSTANT_TEST" in techniques.METHOD_IDS and "constant_test" in shaders.SPECS
        items = [i.identifier for i in cube.translucent.bl_rna.properties["method"].enum_items]
        assert items[-1] == "CONSTANT_TEST" and items[:5] == ["OFF", "IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH",
                                                              "GEOCUBE"]
        cube.translucent.method = "CONSTANT_TEST"
        image = render(scene, 48, 48)
        centre = image[20:28, 20:28, :3]
        assert np.abs(centre - np.array(COLOUR[:3], np.float32)).max() < 1e-3  # drawn over the base, as is
        assert np.abs(plain[20:28, 20:28, :3] - np.array(COLOUR[:3])).max() > 0.1  # the base was not that
        cube.translucent.method = "OFF"
    finally:
        techniques.unregister(technique)

    assert "CONSTANT_TEST" not in techniques.METHOD_IDS and technique not in techniques.REGISTRY
    assert "constant_test" not in shaders.SPECS
    items = [i.identifier for i in cube.translucent.bl_rna.properties["method"].enum_items]
    assert items == ["OFF", "IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE"]
    with pytest.raises(TypeError):
        cube.translucent.method = "CONSTANT_TEST"
    assert np.array_equal(render(scene, 48, 48), plain)  # the frame is as before it came


def test_the_registry_refuses_a_taken_id_or_method_number(tr):
    techniques = ext_module(tr, "translucent_addon.techniques")
    protocol = ext_module(tr, "translucent_addon.techniques.protocol")
    twin = protocol.Technique()
    twin.id = "IMAGE_SPACE"
    with pytest.raises(ValueError, match="already registered"):
        techniques.register(twin)
    clash = protocol.Technique()
    clash.id, clash.method_number = "ANOTHER", 3
    with pytest.raises(ValueError, match="method number 3 is taken"):
        techniques.register(clash)
    assert techniques.METHOD_IDS == ("OFF", "IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE")

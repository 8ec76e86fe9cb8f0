"""Adding a technique is a folder and one line in the registry: a constant-colour technique, defined here,
registered at run time, chosen as an object's method, drawn by F12, and gone after unregister."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

from blender_helpers import add_camera, add_cube, add_light, render, set_world  # noqa: E402
from conftest import ext_module  # noqa: E402

COLOUR = (0.2, 0.9, 0.4, 1.0)
GLSL = Path(__file__).parent / "data" / "constant_colour.glsl"


def constant_colour_technique(tr):
    protocol = ext_module(tr, "translucent_addon.techniques.protocol")
    shaders = ext_module(tr, "translucent_addon.gpu.shaders")
    draw_state = ext_module(tr, "translucent_addon.gpu.draw_state")

    class ConstantColour(protocol.Technique):
        id, label, method_number = "CONSTANT_TEST", "Constant (test)", 100
        description = "Its meshes in one colour"
        surface_layer = False  # unlit: no material's gloss or colour over it
        shader_specs = {"constant_test": shaders.ShaderSpec(
            source=str(GLSL), libraries=(), vertex_in=(("VEC3", "pos"),),
            uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object")),
            push_constants=(("VEC4", "colour"),), fragment_out=((0, "VEC4", "out_color"),))}

        def prepare(self, ctx):
            return [k for k, m in enumerate(ctx.frame.meshes) if m.method == self.id] or None

        def finish(self, ctx, state):
            with draw_state.draw_pass(ctx.target, depth_test="LESS_EQUAL"):
                shader = shaders.pass_shader("constant_test")
                shader.bind()
                shader.uniform_block("frame", ctx.frame_ubo)
                shader.uniform_float("colour", COLOUR)
                for k in state:
                    shader.uniform_block("object", ctx.objects[k])
                    shader.draw(ctx.batches[k][0])
            return {}

    return ConstantColour()


def _lit_cube(scene):
    """A cube under a sun, seen by a camera: (the cube, its 48 x 48 frame with method OFF)."""
    set_world(scene, (0.05, 0.05, 0.05))
    cube = add_cube(scene)
    add_light(scene, "SUN", (3, -2, 5), energy=2.0)
    add_camera(scene, (3.0, -3.0, 2.5), (0, 0, 0.5))
    return cube, render(scene, 48, 48)


def test_a_technique_registered_at_run_time_draws_and_leaves_nothing_behind(tr, scene):
    techniques = ext_module(tr, "translucent_addon.techniques")
    shaders = ext_module(tr, "translucent_addon.gpu.shaders")
    cube, plain = _lit_cube(scene)
    with pytest.raises(TypeError):
        cube.translucent.method = "CONSTANT_TEST"

    technique = constant_colour_technique(tr)
    techniques.register(technique)
    try:
        assert "CONSTANT_TEST" in techniques.method_ids() and "constant_test" in shaders.SPECS
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

    assert "CONSTANT_TEST" not in techniques.method_ids() and technique not in techniques.REGISTRY
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
    assert techniques.method_ids() == ("OFF", "IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE")


def _refused_technique(tr, how: str, tmp_path):
    """The constant-colour technique made to fail as a backend that lacks something would: a shader this backend
    does not compile, or a texture format it refuses (a three-channel float texture, refused by Metal)."""
    technique = constant_colour_technique(tr)
    targets = ext_module(tr, "translucent_addon.gpu.targets")
    if how == "shader":
        broken = tmp_path / "broken.glsl"
        broken.write_text(GLSL.read_text().replace("void main()", "void main() { undeclared_builtin(); }\nvoid _m()",
                                                   1))
        spec = technique.shader_specs["constant_test"]
        technique.shader_specs = {"constant_test": dataclasses.replace(spec, source=str(broken))}
    else:
        def prepare(ctx):
            targets.texture_from_array(np.zeros((2, 2, 3), np.float32), "RGB32F")

        technique.prepare = prepare
    return technique


@pytest.mark.parametrize("how", ["shader", "format"])
def test_a_technique_the_backend_cannot_run_falls_back_with_one_line(tr, scene, how, tmp_path):
    """A backend that lacks what a technique needs draws its objects with their base colour and says so in one
    line naming the object and the reason: the frame equals the one drawn with method OFF, nothing crashes."""
    techniques = ext_module(tr, "translucent_addon.techniques")
    engine = ext_module(tr, "translucent_addon.blender.engine")
    scene.translucent.capture_passes = True
    cube, plain = _lit_cube(scene)
    technique = _refused_technique(tr, how, tmp_path)
    techniques.register(technique)
    try:
        cube.translucent.method = "CONSTANT_TEST"
        for _ in range(2):  # refused once, then remembered: the line stays, the shader is not built again
            image = render(scene, 48, 48)
            np.testing.assert_allclose(image, plain, atol=1e-6)
            capture = ext_module(tr, "translucent_addon.blender.session").current().capture
            warnings = [w for w in capture["frame"].warnings if "cannot run" in w]
            assert len(warnings) == 1, capture["frame"].warnings
            assert warnings[0].startswith("'Cube': Constant (test) cannot run on this GPU backend: ")
            assert warnings[0].endswith("drawn with its base colour")
            assert ("Shader Compile Error" if how == "shader" else "RGB32F") in warnings[0], warnings[0]
        cube.translucent.method = "OFF"
    finally:
        techniques.unregister(technique)
    pipeline = engine.final_pipeline()
    assert "CONSTANT_TEST" in pipeline.unavailable  # remembered while it was registered
    np.testing.assert_allclose(render(scene, 48, 48), plain, atol=1e-6)
    assert "CONSTANT_TEST" not in pipeline.unavailable, "forgotten once unregistered: registered again, tried anew"


def test_gpu_state_a_technique_leaves_set_is_put_back_and_recorded(tr, scene):
    """A planted violation: the constant-colour technique's finish turns additive blending on and leaves it. The
    pipeline puts the state back after the hook (the next frame is drawn as the first) and records the leak, which
    the suite's teardown (conftest ``scene``) turns into a failure for every other test."""
    import gpu

    techniques = ext_module(tr, "translucent_addon.techniques")
    engine = ext_module(tr, "translucent_addon.blender.engine")
    cube, _ = _lit_cube(scene)
    technique = constant_colour_technique(tr)
    drawn = technique.finish

    def leaking_finish(ctx, state):
        steps = drawn(ctx, state)
        gpu.state.blend_set("ADDITIVE")  # the violation under test
        return steps

    technique.finish = leaking_finish
    techniques.register(technique)
    pipeline = engine.final_pipeline()
    try:
        cube.translucent.method = "CONSTANT_TEST"
        first = render(scene, 48, 48)
        second = render(scene, 48, 48)
        np.testing.assert_array_equal(first, second)
        assert len(pipeline.state_leaks) == 2, pipeline.state_leaks
        assert pipeline.state_leaks[0].startswith("CONSTANT_TEST leaking_finish: ('NONE', ")
        assert "('ADDITIVE', " in pipeline.state_leaks[0]
        cube.translucent.method = "OFF"
    finally:
        techniques.unregister(technique)
        pipeline.state_leaks.clear()


def baking_technique(tr):
    """The constant-colour technique grown into one that bakes: its own object property (a strength), bake
    parameter, hash part, bake stage and panel; its frame draws the colour its bake stored."""
    protocol = ext_module(tr, "translucent_addon.techniques.protocol")
    properties = ext_module(tr, "translucent_addon.core.properties")
    technique = constant_colour_technique(tr)
    drawn = type(technique)

    class Baked(drawn):
        object_props = (properties.Prop("constant_test_strength", "FloatProperty", {
            "name": "Strength", "description": "How much of the colour the bake stores", "min": 0.0, "max": 1.0,
            "default": 0.5}),)
        bake_stages = ("colour",)
        bake_properties = ("constant_test_strength",)
        panel = (("constant_test_strength",),)

        def bake_parameters(self, values):
            return {"strength": float(values.get("constant_test_strength", 0.5))}

        def hash_parts(self, inputs, geometry, material):
            return geometry, {"strength": inputs.params["strength"]}

        def bake(self, inputs, stage):
            yield 0.5, f"{self.id}: {stage}"
            colour = np.array(COLOUR[:3], np.float32) * inputs.params["strength"]
            return {"colour": colour}, {"strength": inputs.params["strength"]}

        def bake_summary(self, meta):
            return [f"Strength {meta['strength']:g} baked"]

        def prepare(self, ctx):
            return [k for k, m in enumerate(ctx.frame.meshes) if m.method == self.id and m.bake is not None] or None

        def finish(self, ctx, state):
            shaders = ext_module(tr, "translucent_addon.gpu.shaders")
            draw_state = ext_module(tr, "translucent_addon.gpu.draw_state")
            with draw_state.draw_pass(ctx.target, depth_test="LESS_EQUAL"):
                shader = shaders.pass_shader("constant_test")
                shader.bind()
                shader.uniform_block("frame", ctx.frame_ubo)
                for k in state:
                    colour = ctx.frame.meshes[k].bake.load()["colour"]
                    shader.uniform_float("colour", (*map(float, colour), 1.0))
                    shader.uniform_block("object", ctx.objects[k])
                    shader.draw(ctx.batches[k][0])
            return {}

    assert issubclass(Baked, protocol.Technique)
    return Baked()


def test_a_technique_registered_at_run_time_bakes_with_its_own_property_hash_and_panel(tr, scene):
    """What a technique declares reaches every layer without another file naming it: its property joins
    Object.translucent, the Bake operator bakes it with its parameters, its hash part stales the bake, the object
    panel lays out its property and says what its bake holds, and F12 draws from the bake."""
    from test_ui import _Layout

    techniques = ext_module(tr, "translucent_addon.techniques")
    ui = ext_module(tr, "translucent_addon.blender.ui")
    bake_inputs = ext_module(tr, "translucent_addon.blender.bake_inputs")
    cube, plain = _lit_cube(scene)
    assert "constant_test_strength" not in cube.translucent.bl_rna.properties
    technique = baking_technique(tr)
    techniques.register(technique)
    try:
        assert cube.translucent.constant_test_strength == 0.5  # its property, with its default
        cube.translucent.method = "CONSTANT_TEST"
        bpy.context.view_layer.objects.active = cube
        cube.select_set(True)

        def status():
            return bake_inputs.bake_status(cube.evaluated_get(bpy.context.evaluated_depsgraph_get()))

        assert status() == "MISSING"
        np.testing.assert_allclose(render(scene, 48, 48), plain, atol=1e-6)  # not baked: drawn as the base
        cube.translucent.constant_test_strength = 0.8
        assert bpy.ops.translucent.bake() == {"FINISHED"}
        assert status() == "OK"
        centre = render(scene, 48, 48)[20:28, 20:28, :3]
        assert np.abs(centre - 0.8 * np.array(COLOUR[:3], np.float32)).max() < 1e-3
        layout = _Layout()
        ui.draw_object(layout, bpy.context, cube)
        assert ("TranslucentObjectSettings", "constant_test_strength") in layout.props()
        assert "Strength 0.8 baked" in layout.labels() and "Bake up to date" in layout.labels()
        cube.translucent.constant_test_strength = 0.3  # its hash part: the bake is stale
        assert status() == "STALE"
        cube.translucent.method = "OFF"
    finally:
        techniques.unregister(technique)
    assert "constant_test_strength" not in cube.translucent.bl_rna.properties  # gone with it

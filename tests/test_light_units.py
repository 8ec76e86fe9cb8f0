"""Our light model (core/lights.py) against Cycles: the units the whole project relies on.

A white diffuse plane, direct light only, orthographic camera from above. For each
Blender light type, Cycles' pixels equal rho E / pi with E from
``unshadowed_irradiance`` within 2 % (Cycles' point lights are exact; the small
area light adds a little sampling noise).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import add_mesh, render  # noqa: E402
from conftest import ext_module  # noqa: E402

SIZE = 24
HALF = 1.0  # the camera sees [-1, 1]^2 of the plane


def _white_plane(scene):
    plane = add_mesh(scene, "Plane", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], [(0, 1, 2, 3)])
    mat = bpy.data.materials.new("White")
    tree = mat.node_tree if mat.node_tree else None
    if tree is None:
        mat.use_nodes = True
        tree = mat.node_tree
    tree.nodes.clear()
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (1, 1, 1, 1)
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(diffuse.outputs[0], out.inputs[0])
    plane.data.materials.append(mat)


@pytest.mark.parametrize(
    "kind, settings, location, rotation",
    [
        ("SUN", dict(energy=2.0, angle=0.0), (0, 0, 3), (0.4, 0.2, 0)),
        ("POINT", dict(energy=80.0, shadow_soft_size=0.0), (0.3, -0.2, 1.5), (0, 0, 0)),
        ("SPOT", dict(energy=80.0, shadow_soft_size=0.0, spot_size=math.radians(70), spot_blend=0.4),
         (0.2, 0.0, 1.5), (0.2, 0, 0)),
        ("AREA", dict(energy=40.0, size=0.02), (0.0, 0.3, 1.2), (0.3, 0, 0)),
    ],
)
def test_light_units_match_cycles(tr, scene, kind, settings, location, rotation):
    lights = ext_module(tr, "translucent_addon.core.lights")
    _white_plane(scene)
    light = bpy.data.lights.new("L", kind)
    for key, value in settings.items():
        setattr(light, key, value)
    lo = bpy.data.objects.new("L", light)
    lo.location, lo.rotation_euler = location, rotation
    scene.collection.objects.link(lo)
    cam = bpy.data.objects.new("C", bpy.data.cameras.new("C"))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 2 * HALF
    cam.location = (0, 0, 5)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 64
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 0
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.cycles.seed = 1
    cycles = render(scene, SIZE, SIZE)[..., 0]

    bpy.context.view_layer.update()
    emitters = lights.emitters_from_light("L", kind, np.array(lo.matrix_world), light.color, light.energy,
                                          spot_size=getattr(light, "spot_size", 0),
                                          spot_blend=getattr(light, "spot_blend", 0),
                                          area_shape=getattr(light, "shape", "SQUARE"), size=getattr(light, "size", 0),
                                          size_y=getattr(light, "size_y", 0), area_samples=1)
    c = (np.arange(SIZE) + 0.5) / SIZE * 2 * HALF - HALF
    x, y = np.meshgrid(c, c)
    pts = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    normals = np.tile([0.0, 0.0, 1.0], (len(pts), 1))
    ours = sum(lights.unshadowed_irradiance(e, pts, normals)[0][:, 0] for e in emitters) / math.pi
    ours = ours.reshape(SIZE, SIZE)
    assert cycles.max() > 0.05
    # Compare where the light is not in a spot's blend ramp edge (steep there, sampled differently).
    keep = ours > 0.05 * ours.max()
    rel = np.abs(cycles[keep] - ours[keep]) / ours[keep]
    print(kind, "median", np.median(rel), "p95", np.percentile(rel, 95))
    assert np.median(rel) < 0.02
    assert np.percentile(rel, 95) < 0.05


def _direct_light_in_cycles(scene, samples: int) -> None:
    """An orthographic camera over the plane's [-1, 1]^2 and Cycles with one seed and no bounce: a light's
    direct light alone, two renders of which differ only by the light's scale."""
    cam = bpy.data.objects.new("C", bpy.data.cameras.new("C"))
    cam.data.type, cam.data.ortho_scale, cam.location = "ORTHO", 2 * HALF, (0, 0, 5)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.use_denoising, scene.cycles.max_bounces, scene.cycles.seed = samples, False, 0, 1


def test_a_light_s_temperature_tints_it_as_in_cycles(tr, scene):
    """Blender 5 lights can take their colour from a blackbody temperature: Cycles multiplies the colour by
    it; the extraction took the colour alone (a 2000 K lamp drew white)."""
    extract = ext_module(tr, "translucent_addon.blender.extract")
    light = bpy.data.lights.new("Warm", "POINT")
    if not hasattr(light, "use_temperature"):
        pytest.skip("this Blender's lights have no temperature")
    _white_plane(scene)
    light.energy, light.shadow_soft_size = 80.0, 0.0
    lo = bpy.data.objects.new("Warm", light)
    lo.location = (0.3, -0.2, 1.5)
    scene.collection.objects.link(lo)
    _direct_light_in_cycles(scene, samples=16)
    white = render(scene, 8, 8)[..., :3].mean(axis=(0, 1))
    light.use_temperature, light.temperature = True, 2000.0
    warm = render(scene, 8, 8)[..., :3].mean(axis=(0, 1))
    tint = np.array(light.temperature_color)
    np.testing.assert_allclose(warm / white, tint, rtol=1e-3)  # what Cycles does with it
    assert tint[0] > 2 * tint[2]
    np.testing.assert_allclose(extract.light_color(light), tint * np.array(light.color), rtol=1e-6)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, 8, 8))
    (emitter,) = frame.emitters
    rgb = np.array(emitter.radiance)
    np.testing.assert_allclose(rgb / rgb.max(), tint / tint.max(), rtol=1e-6)


@pytest.mark.parametrize("kind, settings, scale", [
    ("POINT", dict(shadow_soft_size=0.3), (2.0, 2.0, 2.0)),  # 4 pi r^2, the radius unscaled
    ("POINT", dict(shadow_soft_size=0.0), (1.0, 1.0, 1.0)),  # 4
    ("SPOT", dict(shadow_soft_size=0.2, spot_size=2.5), (1.0, 1.0, 1.0)),
    ("AREA", dict(size=0.5, shape="RECTANGLE", size_y=0.2), (2.0, 1.0, 1.0)),  # the scaled rectangle's area
    ("AREA", dict(size=0.5, shape="DISK"), (1.0, 1.0, 1.0)),
    ("SUN", dict(angle=0.3), (1.0, 1.0, 1.0)),  # pi sin^2(angle / 2)
])
def test_a_light_with_normalize_off_is_as_bright_as_in_cycles(tr, scene, kind, settings, scale):
    """Normalize off: Cycles scales the light's power by its emitting area; the emitters took every light as
    normalized. Cycles' own ratio (off / on, one seed: the paths only scale) against the frame's emitters'."""
    extract = ext_module(tr, "translucent_addon.blender.extract")
    light = bpy.data.lights.new("L", kind)
    if not hasattr(light, "normalize"):
        pytest.skip("this Blender's lights are always normalized")
    _white_plane(scene)
    light.energy = 2.0 if kind == "SUN" else 10.0
    for key, value in settings.items():
        setattr(light, key, value)
    lo = bpy.data.objects.new("L", light)
    lo.location, lo.scale = (0.0, 0.0, 1.5), scale
    scene.collection.objects.link(lo)
    _direct_light_in_cycles(scene, samples=8)

    def both():
        depsgraph = bpy.context.evaluated_depsgraph_get()
        frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, 8, 8))
        return render(scene, 8, 8)[..., 0].mean(), sum(e.radiance[0] for e in frame.emitters)

    cycles_on, ours_on = both()
    light.normalize = False
    cycles_off, ours_off = both()
    assert ours_off / ours_on == pytest.approx(cycles_off / cycles_on, rel=1e-5)

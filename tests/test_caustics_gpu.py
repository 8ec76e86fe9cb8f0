"""Caustics mapping (Shah ch. 5) on the GPU: passes against the NumPy twin, energy, the image."""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

from blender_helpers import render  # noqa: E402
from conftest import ext_module  # noqa: E402


def _scene(tr, scene, **kw):
    ext_module(tr, "translucent_addon.blender.demo").build_caustics_scene(scene, **kw)
    scene.translucent.capture_passes = True
    return scene


def _capture(tr):
    return ext_module(tr, "translucent_addon.blender.session").current().capture


def _twin(tr, cap, caster_name="Glass ball"):
    """The NumPy twin over the captured maps of the first emitter and caster."""
    cm = ext_module(tr, "translucent_addon.techniques.caustics.model")
    blocks = ext_module(tr, "translucent_addon.gpu.blocks")
    caustics = ext_module(tr, "translucent_addon.techniques.caustics.passes")
    frame = cap["frame"]
    e = frame.emitters[0]
    mesh = next(m for m in frame.meshes if m.name == caster_name)
    centre, radius = caustics.bounding_sphere(mesh)
    settings = frame.settings.of("CAUSTICS")
    grid = cm.caster_grid(e, centre, radius, settings.grid)
    faces, _ = blocks.shadow_projection(e, *frame.bounds())
    N = settings.texels
    receivers = cm.atlas_lookup(e, faces, cap["caustic_receivers"][0], N)
    return cm.trace_grid(e, grid, mesh.extras["CAUSTICS"], cap["caustic_front_position"][0],
                         cap["caustic_front_normal"][0], cap["caustic_back_position"][0],
                         cap["caustic_back_normal"][0], receivers,
                         settings.iterations, settings.guard, settings.secant), grid


def _exact_on_floor(tr, scene):
    """Per channel, the flux the exact trace lands on the 40 cm floor, for the scene's lamp."""
    cs = ext_module(tr, "translucent_addon.core.reference.caustic_sphere")
    frame = _capture(tr)["frame"]
    e = frame.emitters[0]
    pts, flux, _ = cs.trace(e, cs.GlassSphere((0, 0, 0.1), 0.05, 1.5), 0.0, n=250_000)
    on = (np.abs(pts[:, :2]) < 0.2).all(1)
    return flux[on].sum(0)


def test_trace_pass_equals_its_numpy_twin(tr, scene):
    """Refraction through both surfaces and the intersection estimate on the GPU land where the NumPy
    twin lands, from the same captured maps, and carry the same flux (float32 vs float64)."""
    _scene(tr, scene)
    for estimator, iterations in (("SHAH", 2), ("SECANT", 4)):
        scene.translucent.caustics_estimator = estimator
        scene.translucent.caustics_iterations = iterations
        render(scene, 32, 32)
        cap = _capture(tr)
        (y, flux, valid), _ = _twin(tr, cap)
        landing, gflux = cap["caustic_landing"][0], cap["caustic_trace_flux"][0]
        gpu_valid = landing[..., 3] > 0.5
        assert valid.sum() > 9000
        assert (gpu_valid == valid).mean() > 0.999
        both = valid & gpu_valid
        err = np.linalg.norm(y[both] - landing[both, :3], axis=1)
        assert np.quantile(err, 0.99) < 1e-4, np.quantile(err, 0.99)  # 0.1 mm on a 40 cm floor
        np.testing.assert_allclose(gflux[..., :3].sum(), flux.sum(), rtol=2e-3)


@pytest.mark.parametrize("grid", [64, 128, 256])
def test_caustic_flux_is_the_transmitted_flux_at_every_grid(tr, scene, grid):
    """Shah 5.3.5 (flux weights): the flux splatted into the caustic map equals the flux the exact trace
    through the ball lands on the floor (silhouette flux times Fresnel in and out), within 2 %, whatever
    the grid resolution."""
    _scene(tr, scene)
    scene.translucent.caustics_grid = grid
    render(scene, 32, 32)
    splatted = _capture(tr)["caustic_flux"][0][..., :3].sum(axis=(0, 1))
    exact = _exact_on_floor(tr, scene)
    np.testing.assert_allclose(splatted, exact, rtol=0.02)
    # Where it lands: the share beyond 1.15 shadow radii (rim rays) is the exact trace's, 4.8 %.
    cap = _capture(tr)
    landing, flux = cap["caustic_landing"][0], cap["caustic_trace_flux"][0][..., 1]
    far = np.hypot(landing[..., 0], landing[..., 1]) > 1.15 * 0.5 * np.tan(np.arcsin(0.05 / 0.4))
    assert flux[far].sum() / flux.sum() == pytest.approx(0.048, abs=0.015)


def test_the_caustic_lights_the_shadow(tr, scene):
    """Caustic on minus caustic off (the light's own switch): light mostly inside the ball's shadow,
    peaking under its centre, never on the ball; off, the shadow is dark. No NaN."""
    _scene(tr, scene)
    scene.translucent.capture_passes = False
    on = render(scene, 96, 96)[..., :3]
    bpy.data.lights["Lamp"].translucent.caustics = False
    off = render(scene, 96, 96)[..., :3]
    assert np.isfinite(on).all() and np.isfinite(off).all()
    caustic = (on - off).mean(-1)
    assert caustic.min() > -1e-5
    # Floor points of each pixel (the camera looks at the floor from (0, -0.3, 0.3)).
    camera = ext_module(tr, "translucent_addon.blender.extract").render_camera(
        bpy.context.evaluated_depsgraph_get(), 96, 96)
    o, d = ext_module(tr, "translucent_addon.core.geometry.camera").pixel_rays(camera.view_proj, 96, 96)
    floor = o + (-o[..., 2] / d[..., 2])[..., None] * d
    rho = np.hypot(floor[..., 0], floor[..., 1])
    oc = o - np.array([0.0, 0.0, 0.1])
    b = np.sum(oc * d, -1)
    sees_ball = b * b - (np.sum(oc * oc, -1) - 0.05**2) > 0
    shadow_r = 0.5 * np.tan(np.arcsin(0.05 / 0.4))
    lit = caustic > 1e-3 * caustic.max()
    assert lit.sum() > 30
    assert not (lit & sees_ball).any()
    # Most of the light focuses inside the shadow; rays through the rim land far out, faintly.
    inside, outside = caustic[(rho < shadow_r) & ~sees_ball], caustic[(rho > 1.15 * shadow_r) & ~sees_ball]
    assert inside.mean() > 30 * outside.mean()
    peak = np.unravel_index(np.argmax(caustic), caustic.shape)
    assert rho[peak] < 0.01
    assert caustic.max() > 5 * off.mean(-1).max()  # a focused caustic outshines the directly lit floor
    in_shadow = (rho < 0.6 * shadow_r) & ~sees_ball
    assert in_shadow.sum() > 20
    assert off.mean(-1)[in_shadow].max() < 1e-4


def test_a_light_inside_a_caster_is_reported_not_drawn(tr, scene):
    _scene(tr, scene)
    bpy.data.objects["Lamp"].location = (0.0, 0.0, 0.1)
    img = render(scene, 32, 32)
    assert np.isfinite(img).all()
    warnings = _capture(tr)["frame"].warnings
    assert any("inside the caster" in w for w in warnings), warnings


def test_dispersion_separates_the_channels(tr, scene):
    """Three indices (Shah Fig. 5.13): blue (eta + d) bends more and focuses nearer the ball than red,
    so on the floor below the focus blue spreads wider; with one index the channels coincide."""
    _scene(tr, scene)

    def spread():
        render(scene, 32, 32)
        cap = _capture(tr)
        flux, landing = cap["caustic_trace_flux"][0], cap["caustic_landing"][0]
        G = scene.translucent.caustics_grid
        out = []
        for ch in range(3):
            tile = slice(ch * G, (ch + 1) * G) if flux.shape[1] > G else slice(0, G)
            f = flux[:, tile, ch].ravel()
            r = np.hypot(landing[:, tile, 0], landing[:, tile, 1]).ravel()
            out.append(np.sqrt((f * r * r).sum() / f.sum()))
        return np.array(out)

    r_one = spread()
    np.testing.assert_allclose(r_one, r_one[1], rtol=1e-6)
    bpy.data.objects["Glass ball"].translucent.caustics_dispersion = 0.05
    r_three = spread()
    print("dispersion spread", r_one, r_three)
    assert r_three[2] > r_three[1] * 1.02 and r_three[1] > r_three[0] * 1.02


def test_an_open_refractive_caster_falls_back_to_one_surface_with_a_warning(tr, scene):
    """Bad input (DESIGN.md 6): a single glass sheet set to refract through two surfaces has no back faces;
    it is drawn with one surface and the frame says why. Its caustic is there and finite."""
    _scene(tr, scene)
    ball = bpy.data.objects["Glass ball"]
    ball.translucent.caustics_caster = "NONE"
    from blender_helpers import add_mesh

    sheet = add_mesh(scene, "Sheet", [(-0.05, -0.05, 0.1), (0.05, -0.05, 0.1), (0.05, 0.05, 0.12),
                                      (-0.05, 0.05, 0.12)], [(0, 1, 2, 3)])
    sheet.translucent.caustics_caster = "REFRACTIVE"
    img = render(scene, 32, 32)
    cap = _capture(tr)
    assert any("open mesh" in w and "Sheet" in w for w in cap["frame"].warnings), cap["frame"].warnings
    assert np.isfinite(img).all()
    assert cap["caustic_flux"][0][..., :3].sum() > 0

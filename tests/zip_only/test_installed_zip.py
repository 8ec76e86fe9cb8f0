"""The zip as a user installs it, with nothing but Blender (bpy, its Python and NumPy) and the zip's wheels:
every operator runs and every method draws. ``make test-zip`` runs this on Blender 5.2 LTS, 5.3 and 4.5 LTS,
each in a venv holding only bpy and pytest.

In any other environment the module is skipped; with TRANSLUCENT_ZIP_ONLY=1 (set by ``make test-zip``) an
environment that holds one of the bundled libraries is an error, not a skip. Modules of the extension are
reached through the installed package (``ext_module``), never through the checkout, whose pure modules
would need SciPy from outside the zip.
"""
from __future__ import annotations

import importlib
import importlib.util
import json
import math
import os
import sys
from pathlib import Path

import pytest

BUNDLED = ("scipy", "xatlas", "moderngl", "glcontext", "pytetwild", "wildmeshing", "matplotlib")
_present = [name for name in BUNDLED if importlib.util.find_spec(name) is not None]
if _present and os.environ.get("TRANSLUCENT_ZIP_ONLY") == "1":
    raise RuntimeError(f"the zip-only venv holds {_present}: it must hold only bpy and pytest")
if _present:
    pytest.skip(f"this environment holds {_present}; `make test-zip` runs these in a venv holding only bpy",
                allow_module_level=True)

bpy = pytest.importorskip("bpy")
np = pytest.importorskip("numpy")

from blender_helpers import add_camera, add_light, add_mesh, add_plane  # noqa: E402
from conftest import ext_module  # noqa: E402

W, H = 64, 48
BAKED = ("TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE")
# Frames of these scenes rendered on Blender 5.2.4 (OpenGL, llvmpipe), each baked there: every Blender and backend
# bakes and draws them again and must land within REFERENCE_TOLERANCE (relative RMSE over the frame). A grey ball is
# 35-45 % off. Measured across 5.2.4, 5.3.0 (Vulkan, OpenGL) and 4.5.15 every frame is exact but QUADGRAPH's, whose
# tetrahedra differ from bake to bake (fTetWild; 0.2-1.7 % seen here, test_quadgraph_gpu allows 6 %): the parity
# tests (test_parity.py), which draw one bake everywhere, hold QUADGRAPH to 0.5 %. docs/gpu_backends.md.
# TRANSLUCENT_WRITE_REFERENCE=1 writes them instead (on the reference Blender only).
REFERENCE_DIR = Path(__file__).resolve().parent / "reference"
REFERENCE_TOLERANCE = {"quadgraph": 0.06}  # the rest: 0.01


def _matches_reference(image, name: str) -> None:
    """The frame equals the reference frame ``name`` within its REFERENCE_TOLERANCE relative RMSE (RGB)."""
    path = REFERENCE_DIR / f"{name}.npy"
    if os.environ.get("TRANSLUCENT_WRITE_REFERENCE") == "1":
        REFERENCE_DIR.mkdir(exist_ok=True)
        np.save(path, image.astype(np.float32))
        return
    reference = np.load(path).astype(np.float64)[..., :3]
    error = np.sqrt(np.mean((image[..., :3] - reference) ** 2)) / np.sqrt(np.mean(reference ** 2))
    print(f"{name}: relative RMSE {error:.5f} against the reference frame")
    tolerance = REFERENCE_TOLERANCE.get(name, 0.01)
    assert error < tolerance, f"{name}: relative RMSE {error:.4f} against the 5.2.4 frame (at most {tolerance})"


def _render(tr, scene, width=W, height=H):
    image, _ = ext_module(tr, "translucent_addon.blender.compare_runner").render_pixels(scene, width, height)
    assert np.isfinite(image).all()
    return image


def _ball_scene(tr, scene, method):
    """A 4 cm skin ball on a grey floor under a spot light, seen by a camera: (ball, image mask of the ball)."""
    ext_module(tr, "translucent_addon.blender.demo").uniform_world(scene, (0.03, 0.03, 0.04))
    add_plane(scene, size=0.6)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=0.02, location=(0, 0, 0.02))
    ball = bpy.context.active_object
    ball.name = "Ball"
    ball.translucent.preset = "skin1"
    ball.translucent.method = method
    add_light(scene, "SPOT", (0.1, -0.15, 0.25), (0, 0, 0.02), energy=30.0, spot_size=math.radians(50))
    add_camera(scene, (0.0, -0.22, 0.1), (0, 0, 0.02), lens=50)
    bpy.context.view_layer.objects.active = ball
    return ball


def _ball_pixels(image):
    """The ball's pixels: the central quarter of the frame (the camera looks at the ball's centre)."""
    return image[H // 2 - 6:H // 2 + 6, W // 2 - 6:W // 2 + 6, :3]


def test_the_bundled_libraries_come_from_the_zip(installed):
    """Each library the extension imports resolves to the wheels Blender unpacked from the zip, for this
    Blender's Python; matplotlib is neither bundled nor needed."""
    sites = [p for p in sys.path if f"{os.sep}.local{os.sep}" in p and p.endswith("site-packages")]
    assert sites, sys.path
    mesher = "wildmeshing" if sys.platform == "darwin" else "pytetwild"
    for name in ("scipy", "scipy.sparse.linalg", "scipy.spatial", "xatlas", "moderngl", "glcontext", mesher):
        module = importlib.import_module(name)
        assert module.__file__.startswith(sites[0]), (name, module.__file__)
    with pytest.raises(ImportError):
        importlib.import_module("matplotlib")


def test_blenders_light_world_and_material_panels_show_for_our_engine(installed):
    """Blender's own panels show for the engines in their COMPAT_ENGINES, where EEVEE is BLENDER_EEVEE_NEXT
    in 4.5 and BLENDER_EEVEE from 5.0: ours is added beside either."""
    panels = [p.__name__ for p in bpy.types.Panel.__subclasses__()
              if "TRANSLUCENT_RT" in (getattr(p, "COMPAT_ENGINES", None) or set())]
    assert len(panels) > 10, panels
    assert any("light" in name.lower() for name in panels) and any("world" in name.lower() for name in panels)


def test_blender_draws_on_the_backend_this_case_names(tr, scene):
    """``make test-zip`` runs this file once per Blender x backend: Blender really drew on the one named."""
    import gpu

    _ball_scene(tr, scene, "OFF")
    _render(tr, scene)
    expected = os.environ.get("TRANSLUCENT_EXPECT_BACKEND")
    if expected is None:
        pytest.skip("no backend named (make test-zip names one per case)")
    assert gpu.platform.backend_type_get() == expected


def test_presets_size_and_quality_operators(tr, scene):
    ball = _ball_scene(tr, scene, "IMAGE_SPACE")
    presets = ext_module(tr, "translucent_addon.core.physics.presets").load_presets()
    assert len(presets) == 12
    ball.translucent.preset = "marble"
    assert tuple(ball.translucent.sigma_s_prime) == pytest.approx(presets["marble"].sigma_s_prime)
    assert bpy.ops.translucent.set_physical_size(size=0.04) == {"FINISHED"}
    assert max(ball.dimensions) * ball.translucent.mm_per_unit == pytest.approx(40.0, rel=1e-5)
    assert bpy.ops.translucent.apply_quality(tier="DRAFT") == {"FINISHED"}
    assert bpy.ops.translucent.auto_quality() == {"FINISHED"}
    assert bpy.ops.translucent.save_preset(name="Zip test wax") == {"FINISHED"}
    assert ball.translucent.preset == "USER:Zip test wax"
    assert bpy.ops.translucent.remove_preset() == {"FINISHED"}


def test_image_space_draws_and_its_paint_layer_changes_it(tr, scene):
    ball = _ball_scene(tr, scene, "IMAGE_SPACE")
    plain = _render(tr, scene)
    assert _ball_pixels(plain).mean() > 0.01
    assert bpy.ops.translucent.add_paint_layer(layer="translucent_glow", enter_paint_mode=False) == {"FINISHED"}
    ball.vertex_groups["translucent_glow"].add(list(range(len(ball.data.vertices))), 1.0, "REPLACE")
    glowing = _render(tr, scene)
    assert _ball_pixels(glowing).mean() > 1.2 * _ball_pixels(plain).mean()
    _matches_reference(plain, "image_space")
    _matches_reference(glowing, "image_space_glow")


@pytest.mark.parametrize("method", BAKED)
def test_each_baked_method_bakes_draws_and_clears(tr, scene, method):
    """The bake runs every native library of its method from the zip (xatlas and SciPy; fTetWild; SciPy's
    tables), F12 draws the ball lit, and Clear Bake removes it."""
    ball = _ball_scene(tr, scene, method)
    assert bpy.ops.translucent.apply_quality(tier="DRAFT") == {"FINISHED"}
    off = None
    if method != "GEOCUBE":  # glass: the ball's pixels show the floor through it
        ball.translucent.method = "OFF"
        off = _ball_pixels(_render(tr, scene)).mean()
        ball.translucent.method = method
    assert bpy.ops.translucent.bake() == {"FINISHED"}
    inputs = ext_module(tr, "translucent_addon.blender.bake_inputs")
    assert inputs.bake_status(ball.evaluated_get(bpy.context.evaluated_depsgraph_get()), method) == "OK"
    image = _render(tr, scene)
    lit = _ball_pixels(image).mean()
    assert lit > 0.005, method
    if off is not None:
        assert abs(lit - off) > 1e-3, method  # the method drew, not the opaque fallback
    _matches_reference(image, method.lower())
    assert bpy.ops.translucent.clear_bake() == {"FINISHED"}
    assert inputs.bake_status(ball.evaluated_get(bpy.context.evaluated_depsgraph_get()), method) != "OK"


def test_caustics_from_a_glass_ball_light_the_floor(tr, scene):
    ball = _ball_scene(tr, scene, "OFF")
    image_off = _render(tr, scene)
    ball.translucent.caustics_caster = "REFRACTIVE"
    image_on = _render(tr, scene)
    assert np.abs(image_on - image_off)[..., :3].max() > 0.01
    _matches_reference(image_on, "caustics")


def test_grass_bakes_its_btf_and_draws_the_field(tr, scene):
    """Grass acquisition on moderngl's standalone context (EGL here) from the zip's wheels."""
    ext_module(tr, "translucent_addon.blender.demo").uniform_world(scene, (0.3, 0.35, 0.45))
    ground = add_mesh(scene, "Ground", [(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)],
                      [(0, 1, 2, 3)], (0.3, 0.2, 0.1))
    s = ground.translucent
    s.grass_tile, s.grass_blade_height, s.grass_blades, s.grass_seed = 0.1, 0.045, 300, 7
    s.grass_resolution, s.grass_target_error = "64", 0.5
    bpy.context.view_layer.objects.active = ground
    s.grass = False
    add_light(scene, "SUN", (0.4, -0.3, 1.0), energy=3.0)
    add_camera(scene, (0.0, -0.45, 0.3), (0.0, 0.0, 0.0), lens=50.0)
    ground_only = _render(tr, scene)
    assert bpy.ops.translucent.add_grass_field() == {"FINISHED"}
    assert s.grass and ext_module(tr, "translucent_addon.blender.bake_files").read(ground, "GRASS") is not None
    field = _render(tr, scene)
    assert np.abs(field - ground_only)[..., :3].mean() > 0.01
    _matches_reference(field, "grass")


def test_demo_scene_renders_with_f12(tr, scene):
    assert bpy.ops.translucent.add_demo_scene(kind="BUNNY") == {"FINISHED"}
    image = _render(tr, bpy.context.scene)
    assert image[..., :3].max() > 0.05 and image[..., :3].std() > 0.01
    _matches_reference(image, "demo_bunny")


def test_compare_quick_writes_its_report_and_chart(tr, scene, tmp_path):
    """Compare with Cycles (Quick) end to end: the report, the images and the chart, drawn without matplotlib."""
    _ball_scene(tr, scene, "IMAGE_SPACE")
    scene.render.resolution_x, scene.render.resolution_y = 40, 30
    assert bpy.ops.translucent.compare_cycles(output_dir=str(tmp_path), quick=True) == {"FINISHED"}
    report = json.loads((tmp_path / "report.json").read_text())
    assert {r["engine"] for r in report["renders"]} >= {"CYCLES", "BLENDER_EEVEE", "TRANSLUCENT_RT"}
    for r in report["renders"]:
        assert (tmp_path / r["image"]).stat().st_size > 100
    chart = tmp_path / "chart.png"
    assert chart.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and chart.stat().st_size > 10_000
    assert "matplotlib" not in sys.modules

"""Pure modules: presets, light units, uniform blocks, ray casting, mesh checks, bake store.

None of these needs Blender; the first test proves they do not import it.
"""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from translucent_addon.core import bake_store as store
from translucent_addon.core.geometry.camera import pixel_rays
from translucent_addon.core.geometry.mesh_checks import check_mesh
from translucent_addon.core.geometry.mesh_io import load_npz, load_obj
from translucent_addon.core.geometry.raycast import closest_hit
from translucent_addon.core.geometry.surface import surface_samples
from translucent_addon.core.lights import DIRECTIONAL, POINT, emitters_from_light, unshadowed_irradiance
from translucent_addon.core.physics.presets import CoefficientError, load_presets, validate_coefficients
from translucent_addon.gpu import blocks
from translucent_addon.techniques.registry import BakeInputError, BakeInputs, validate

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "translucent_addon" / "data" / "meshes"
# Pure modules: all of core/ and every technique's model (the layers test checks that no module outside
# blender/ imports bpy; this imports them and looks), and the pure helpers the tests below use.
PURE_MODULES = sorted(
    ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
    for p in [*(ROOT / "translucent_addon" / "core").rglob("*.py"),
              *(ROOT / "translucent_addon" / "techniques").glob("*/model.py")]
) + ["translucent_addon.gpu.blocks", "translucent_addon.gpu.shaders", "translucent_addon.techniques",
     "translucent_addon.techniques.registry"]


def test_pure_modules_do_not_import_bpy():
    code = ("import sys; " + "; ".join(f"import {m}" for m in PURE_MODULES)
            + "; print('bpy' in sys.modules, 'gpu' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False False"


# -- presets -------------------------------------------------------------------
def test_presets_load_with_units_mm():
    presets = load_presets()
    assert len(presets) == 12
    marble = presets["marble"]
    # Jensen 2001 Fig. 5, marble, in mm^-1
    assert marble.sigma_s_prime == (2.19, 2.62, 3.00)
    assert marble.sigma_a == (0.0021, 0.0041, 0.0071)
    assert marble.eta == 1.3
    assert marble.sigma_t_prime[0] == pytest.approx(2.1921)
    assert presets["spectralon"].sigma_a == (0.0, 0.0, 0.0)


@pytest.mark.parametrize(
    "sigma_a, sigma_s_prime, eta, g, message",
    [
        ((-0.1, 0, 0), (1, 1, 1), 1.3, 0.0, "material: sigma_a.R = -0.1 mm^-1, must be >= 0"),
        ((0, 0, 0), (1, 0, 1), 1.3, 0.0, "material: sigma_s_prime.G = 0 mm^-1, must be > 0"),
        ((0, 0, 0), (1, 1, -2), 1.3, 0.0, "material: sigma_s_prime.B = -2 mm^-1, must be > 0"),
        ((0, math.nan, 0), (1, 1, 1), 1.3, 0.0, "material: sigma_a.G is nan, not a finite number"),
        ((0, 0, 0), (1, 1, 1), 0.0, 0.0, "material: eta = 0.0, must be an index of refraction of at least 1 "
                                          "(a medium denser than the air around it)"),
        ((0, 0, 0), (1, 1, 1), 0.5, 0.0, "material: eta = 0.5, must be an index of refraction of at least 1 "
                                          "(a medium denser than the air around it)"),
        ((0, 0, 0), (1, 1, 1), 1.3, 1.0, "material: g = 1.0, must lie in (-1, 1)"),
    ],
)
def test_unphysical_coefficients_are_refused_with_reason(sigma_a, sigma_s_prime, eta, g, message):
    with pytest.raises(CoefficientError) as err:
        validate_coefficients(sigma_a, sigma_s_prime, eta, g)
    assert str(err.value) == message


# -- lights ----------------------------------------------------------------------
def _light_at(z, rot=np.eye(3)):
    m = np.eye(4)
    m[:3, :3] = rot
    m[2, 3] = z
    return m


def test_point_light_intensity_is_power_over_4pi():
    (e,) = emitters_from_light("p", "POINT", _light_at(2.0), (1, 1, 1), 100.0)
    E, _, dist = unshadowed_irradiance(e, np.zeros((1, 3)), np.array([[0, 0, 1.0]]))
    assert dist[0] == pytest.approx(2.0)
    assert E[0, 0] == pytest.approx(100 / (4 * math.pi) / 4.0)


def test_sun_strength_is_irradiance_and_follows_cosine():
    rot = np.array([[1, 0, 0], [0, math.cos(1.0), -math.sin(1.0)], [0, math.sin(1.0), math.cos(1.0)]])
    (e,) = emitters_from_light("s", "SUN", _light_at(5.0, rot), (1, 0.5, 0.25), 3.0)
    assert e.kind == DIRECTIONAL
    E, _, _ = unshadowed_irradiance(e, np.zeros((1, 3)), np.array([[0, 0, 1.0]]))
    np.testing.assert_allclose(E[0], np.array([3.0, 1.5, 0.75]) * math.cos(1.0))


def test_area_light_samples_carry_total_on_axis_intensity_p_over_pi():
    for shape in ("SQUARE", "DISK", "RECTANGLE", "ELLIPSE"):
        ems = emitters_from_light("a", "AREA", _light_at(1.0), (1, 1, 1), 50.0, area_shape=shape, size=0.5,
                                  size_y=0.2, area_samples=3)
        assert len(ems) == 9 and all(e.kind == POINT and e.cosine_lobe for e in ems)
        assert sum(e.radiance[0] for e in ems) == pytest.approx(50 / math.pi)
        offsets = np.array([e.position for e in ems])[:, :2]
        half = np.array([0.25, 0.1 if shape in ("RECTANGLE", "ELLIPSE") else 0.25])
        assert (np.abs(offsets) <= half + 1e-12).all()
        if shape in ("DISK", "ELLIPSE"):
            assert ((offsets / half) ** 2).sum(1).max() <= 1 + 1e-9


def test_spot_cone_and_blend():
    (e,) = emitters_from_light("s", "SPOT", _light_at(1.0), (1, 1, 1), 100.0, spot_size=math.radians(60),
                               spot_blend=0.5)
    cos_half = math.cos(math.radians(30))
    assert e.cos_half_angle == pytest.approx(cos_half)
    assert e.spot_smooth == pytest.approx((1 - cos_half) * 0.5)
    # On the axis: full intensity; outside the cone: nothing; inside the blend: between.
    angles = np.radians([0.0, 29.0, 31.0])
    pts = np.stack([np.tan(angles), np.zeros(3), np.zeros(3)], axis=1)
    E, _, _ = unshadowed_irradiance(e, pts, np.tile([0, 0, 1.0], (3, 1)))
    full = 100 / (4 * math.pi) * np.cos(angles) ** 3
    assert E[0, 0] == pytest.approx(full[0])
    assert 0 < E[1, 0] < full[1]
    assert E[2, 0] == 0


# -- blocks and shadow projections ----------------------------------------------
def test_block_sizes_match_the_glsl_structs():
    text = (ROOT / "gpu_shaders" / "common/structs.glsl").read_text()
    assert "mat4 face_view_proj[6]" in text
    assert "mat4 view;" in text and "vec4 shading;" in text and "vec4 params[64];" in text
    assert len(blocks.frame_block(np.eye(4), np.eye(4), (0, 0, 0), np.zeros((9, 3)))) == 3 * 64 + 3 * 16 + 9 * 16
    assert len(blocks.object_block(np.eye(4), np.eye(4))) == 2 * 64 + 16
    (e,) = emitters_from_light("p", "POINT", _light_at(1.0), (1, 1, 1), 10.0)
    faces, origin = blocks.shadow_projection(e, np.zeros(3), 1.0)
    assert len(blocks.light_block(e, faces, origin, 512, 1.0)) == 6 * 64 + 5 * 16


def test_point_shadow_faces_cover_every_direction():
    (e,) = emitters_from_light("p", "POINT", _light_at(0.5), (1, 1, 1), 10.0)
    faces, origin = blocks.shadow_projection(e, np.zeros(3), 2.0)
    rng = np.random.default_rng(1)
    for d in rng.normal(size=(500, 3)):
        p = origin + d / np.linalg.norm(d) * rng.uniform(0.1, 3.0)
        clip = faces[blocks.cube_face(p - origin)] @ np.append(p, 1.0)
        ndc = clip[:3] / clip[3]
        assert clip[3] > 0 and np.all(np.abs(ndc) <= 1.0 + 1e-9), (d, ndc)


def test_a_narrow_spot_gets_one_shadow_face_holding_its_cone():
    """A 50-degree spot: one perspective face along its axis, tan_half = tan(25.25 deg), holding every point
    of the cone within the scene sphere (NDC inside [-1, 1]); wider than 90 degrees, a point light or a spot
    whose caustics need the cube: the six cube faces (tan_half 0)."""
    rot = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0.0]])  # the light looks along +y
    (e,) = emitters_from_light("s", "SPOT", _light_at(0.0, rot), (1, 1, 1), 100.0, spot_size=math.radians(50))
    centre = np.array([0.0, 2.0, 0.0])
    faces, origin, n_faces, tan_half = blocks.shadow_faces(e, centre, 1.0)
    assert n_faces == 1 and tan_half == pytest.approx(math.tan(math.radians(25) * 1.01))
    rng = np.random.default_rng(3)
    axis = np.asarray(e.direction)
    inside = 0
    for d in rng.normal(size=(2000, 3)):
        p = centre + d / np.linalg.norm(d) * rng.uniform(0.0, 1.0)  # the scene sphere
        to_p = (p - origin) / np.linalg.norm(p - origin)
        if to_p @ axis <= e.cos_half_angle:
            continue  # outside the cone: no light, no shadow needed
        inside += 1
        clip = faces[0] @ np.append(p, 1.0)
        assert clip[3] > 0 and np.all(np.abs(clip[:3] / clip[3]) <= 1.0 + 1e-9)
    assert inside > 100
    (wide,) = emitters_from_light("w", "SPOT", _light_at(0.0, rot), (1, 1, 1), 100.0, spot_size=math.radians(100))
    (point,) = emitters_from_light("p", "POINT", _light_at(0.0, rot), (1, 1, 1), 100.0)
    for light, fit in ((wide, True), (point, True), (e, False)):
        cube, _ = blocks.shadow_projection(light, centre, 1.0)
        faces, _, n_faces, tan_half = blocks.shadow_faces(light, centre, 1.0, fit_spot=fit)
        assert n_faces == 6 and tan_half == 0.0
        np.testing.assert_array_equal(faces, cube)


def test_a_single_shadow_face_takes_a_2x2_block_of_the_atlas():
    """The atlas holds 3 x 2 tiles of ``texels``: a fitted spot's or a sun's one face gets twice the texels
    (the 2 x 2 block at tile 0 fits: 2 texels high and at most 3 wide); cube faces keep theirs."""
    for texels in (512, 1024, 2048):
        width, height = 3 * texels, 2 * texels  # pipeline._shadow_atlas
        one = blocks.face_texels(texels, 1)
        assert one == 2 * texels and one <= min(width, height)
        cube = blocks.face_texels(texels, 6)
        assert cube == texels and (5 % 3 + 1) * cube == width and (5 // 3 + 1) * cube == height  # face 5's corner


def test_directional_shadow_map_covers_the_scene_sphere():
    rot = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0.0]])
    (e,) = emitters_from_light("s", "SUN", _light_at(3.0, rot), (1, 1, 1), 1.0)
    faces, origin = blocks.shadow_projection(e, np.array([1.0, 2.0, 0.5]), 1.5)
    rng = np.random.default_rng(2)
    for d in rng.normal(size=(200, 3)):
        p = np.array([1.0, 2.0, 0.5]) + d / np.linalg.norm(d) * 1.5 * rng.uniform()
        ndc = (faces[0] @ np.append(p, 1.0))[:3]
        assert np.all(np.abs(ndc) <= 1.0 + 1e-9)


# -- camera and ray casting ------------------------------------------------------
def test_pixel_rays_hit_a_plane_where_the_projection_puts_it():
    view = blocks.look_at((0, 0, 5.0), (0, 0, -1.0), (0, 1, 0))
    proj = blocks.perspective(math.radians(40), 1.5, 0.1, 100)
    origins, dirs = pixel_rays(proj @ view, 12, 8)
    tris = np.array([[[-10, -10, 0], [10, -10, 0], [10, 10, 0]], [[-10, -10, 0], [10, 10, 0], [-10, 10, 0]]], float)
    t, idx, _, _ = closest_hit(origins.reshape(-1, 3), dirs.reshape(-1, 3), tris)
    assert (idx >= 0).all()
    hits = origins.reshape(-1, 3) + t[:, None] * dirs.reshape(-1, 3)
    np.testing.assert_allclose(hits[:, 2], 0.0, atol=1e-9)
    clip = np.c_[hits, np.ones(len(hits))] @ (proj @ view).T
    ndc = clip[:, :2] / clip[:, 3:]
    xs = (np.arange(12) + 0.5) / 12 * 2 - 1
    ys = (np.arange(8) + 0.5) / 8 * 2 - 1
    np.testing.assert_allclose(ndc[:, 0], np.tile(xs, 8), atol=1e-9)
    np.testing.assert_allclose(ndc[:, 1], np.repeat(ys, 12), atol=1e-9)


def test_closest_hit_picks_the_nearest_triangle():
    tri = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], float)
    tris = np.stack([tri + [0, 0, z] for z in (3.0, 1.0, 2.0)])
    t, idx, u, v = closest_hit(np.array([[0, 0, -1.0]]), np.array([[0, 0, 1.0]]), tris)
    assert idx[0] == 1 and t[0] == pytest.approx(2.0)
    assert u[0] + v[0] <= 1


# -- meshes --------------------------------------------------------------------
def test_bundled_meshes_match_their_sources():
    v, t = load_npz(MESHES / "bunny.npz")
    assert (len(v), len(t)) == (35947, 69451 + 213)  # the scan's five holes closed by 213 triangles
    for name in ("bunny", "spot", "cow"):
        report = check_mesh(*load_npz(MESHES / f"{name}.npz"))
        assert report.closed_manifold and report.zero_area_triangles == 0, name


def _signed_volume(v, t):
    p = v[t]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6)


def test_close_holes_caps_a_cube_wound_like_the_mesh():
    from translucent_addon.core.geometry.mesh_repair import boundary_loops, close_holes

    v, t = _cube()  # below; its first face is triangles 0 and 6
    assert _signed_volume(v, t) == pytest.approx(1.0)
    open_t = np.delete(t, [0, 6], axis=0)  # one face gone: a square hole
    (loop,) = boundary_loops(open_t)
    assert sorted(loop.tolist()) == [0, 1, 2, 3]
    v2, t2 = close_holes(v, open_t)
    assert check_mesh(v2, t2).closed_manifold
    assert len(v2) == len(v) and len(t2) == len(t)
    assert _signed_volume(v2, t2) == pytest.approx(1.0)  # outward, as the rest: not a hole turned inside out
    assert np.array_equal(close_holes(v, t)[1], t)  # closed: unchanged


def test_midpoint_subdivision_keeps_the_surface_closed_and_outward():
    """Each triangle into four: four times the triangles, one new vertex per edge (a cube's 18), the same
    area and volume (the surface unchanged), still closed and wound outward."""
    from translucent_addon.core.geometry.mesh_subdivide import midpoint_subdivision

    v, t = _cube()
    v2, t2 = midpoint_subdivision(v, t)
    assert len(t2) == 4 * len(t) and len(v2) == len(v) + 18
    assert check_mesh(v2, t2).closed_manifold
    assert _signed_volume(v2, t2) == pytest.approx(_signed_volume(v, t), rel=1e-12)
    area = lambda v, t: 0.5 * np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)  # noqa: E731
    assert area(v2, t2).sum() == pytest.approx(area(v, t).sum(), rel=1e-12)
    assert np.allclose(area(v2, t2).reshape(4, -1), area(v, t)[None] / 4)  # each child a quarter


def test_close_holes_follows_a_curved_hole_without_cutting_the_surface():
    """A tube open at both ends, bent: ear clipping closes each rim with no triangle crossing the wall."""
    from translucent_addon.core.geometry.mesh_checks import self_intersections
    from translucent_addon.core.geometry.mesh_repair import close_holes

    n, rings = 24, 6
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    v = np.array([(np.cos(s) * (1 + 0.4 * np.sin(2 * s)), np.sin(s), 0.8 * h + 0.3 * np.cos(s) ** 2)
                  for h in range(rings) for s in a])
    t = []
    for h in range(rings - 1):
        for i in range(n):
            p, q, r, w = h * n + i, h * n + (i + 1) % n, (h + 1) * n + (i + 1) % n, (h + 1) * n + i
            t += [(p, q, r), (p, r, w)]
    t = np.array(t, np.int64)
    v2, t2 = close_holes(v, t)
    assert check_mesh(v2, t2).closed_manifold
    assert self_intersections(v2, t2) == 0
    assert _signed_volume(v2, t2) > 0


def test_boundary_loops_refuse_holes_that_touch():
    from translucent_addon.core.geometry.mesh_repair import boundary_loops

    # Two triangles sharing only vertex 0: vertex 0 starts two boundary edges.
    with pytest.raises(ValueError, match="touch"):
        boundary_loops(np.array([(0, 1, 2), (0, 3, 4)]))


def test_mesh_checks_find_open_and_degenerate_and_non_manifold(tmp_path):
    obj = tmp_path / "bad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 2 5\nf 1 -4 -4\n")
    v, t = load_obj(obj)
    assert t.tolist()[-1] == [0, 1, 1]  # negative indices resolve from the end
    r = check_mesh(v, t)
    assert r.zero_area_triangles == 2  # (1,2,5) is collinear, (1,2,2) repeats a vertex
    assert r.non_manifold_edges == 1  # edge 1-2 has four faces
    assert r.boundary_edges > 0 and not r.closed_manifold


# -- bake store and validation -----------------------------------------------------
def test_bake_store_round_trip_and_stale_status():
    ob = {}
    arrays = {"a": np.arange(12, dtype=np.float32).reshape(4, 3), "i": np.arange(5, dtype=np.int32)}
    digest = store.inputs_hash({"v": np.ones(3)}, {"x": 1})
    store.write(ob, "TEXTURE_SPACE", digest, arrays, {"seconds": 1.5})
    rec = store.read(ob, "TEXTURE_SPACE")
    np.testing.assert_array_equal(rec.arrays["a"], arrays["a"])
    assert rec.arrays["i"].dtype == np.int32 and rec.meta == {"seconds": 1.5}
    assert store.status(ob, "TEXTURE_SPACE", digest) == "OK"
    assert store.status(ob, "TEXTURE_SPACE", store.inputs_hash({"v": np.ones(3) * 2}, {"x": 1})) == "STALE"
    assert store.status(ob, "TEXTURE_SPACE", store.inputs_hash({"v": np.ones(3)}, {"x": 2})) == "STALE"
    assert store.status(ob, "QUADGRAPH", digest) == "MISSING"
    with pytest.raises(TypeError, match="dtype int64"):
        store.write(ob, "X", digest, {"h": np.zeros(2, np.int64)})
    assert store.clear(ob, "TEXTURE_SPACE") and store.read(ob, "TEXTURE_SPACE") is None and ob == {}


def _inputs(method="TEXTURE_SPACE", **kw):
    v, t = load_npz(MESHES / "spot.npz")
    base = dict(name="Spot", method=method, vertices=v, triangles=t, mm_per_unit=100.0, sigma_a=(0.01,) * 3,
                sigma_s_prime=(1.0,) * 3, eta=1.3, g=0.0)
    base.update(kw)
    return BakeInputs(**base)


def test_surface_samples_conserve_area_and_scale_to_mm():
    v, t = load_npz(MESHES / "spot.npz")
    arrays = surface_samples(v, t, 100.0)
    vv = v.astype(np.float64)[t]
    area_units = 0.5 * np.linalg.norm(np.cross(vv[:, 1] - vv[:, 0], vv[:, 2] - vv[:, 0]), axis=1).sum()
    assert arrays["areas_mm2"].sum() == pytest.approx(area_units * 100.0 ** 2, rel=1e-4)
    np.testing.assert_allclose(np.linalg.norm(arrays["normals"], axis=1), 1.0, atol=1e-5)
    assert len(arrays["triangles"]) == len(t)


@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(method="IMAGE_SPACE"), "nothing to bake, IMAGE_SPACE needs no bake"),
        (dict(method="OFF"), "nothing to bake, method is Off"),
        (dict(triangles=np.zeros((0, 3), np.int32)), "the mesh is empty"),
        (dict(sigma_s_prime=(1.0, 0.0, 1.0)), r"sigma_s_prime\.G = 0\.0 mm\^-1, must be > 0"),
        (dict(sigma_a=(-1.0, 0.0, 0.0)), r"sigma_a\.R = -1\.0"),
        (dict(mm_per_unit=0.0), "mm per unit is 0.0"),
        # Issue 37: what hung xatlas (1e30, mm per unit inf or 1e11) or crashed fTetWild (scale 0) is refused first.
        (dict(mm_per_unit=np.inf), "mm per unit is inf"),
        (dict(mm_per_unit=1e11), r"mm across \(scale times mm per unit\); a bake takes 0.001 mm to 10 km"),
        (dict(vertices=np.array([[0, 0, 0], [1e30, 0, 0], [0, 1e30, 0]], np.float64),
              triangles=np.array([[0, 1, 2]], np.int32)), r"it is 1\.41e\+32 mm across"),
        (dict(stretch=np.diag([1.0, 0.0, 1.0])), "its scale is zero .* along an axis"),
        (dict(stretch=np.diag([1.0, np.nan, 1.0])), "its scale is zero .* along an axis"),
        (dict(vertices=np.zeros((3, 3), np.float32), triangles=np.array([[0, 1, 2]], np.int32)),
         "every face has zero area"),
    ],
)
def test_bake_refuses_bad_input_with_one_line(kw, message):
    with pytest.raises(BakeInputError, match=message):
        validate(_inputs(**kw))


def test_bake_warns_on_open_mesh_and_zero_area_faces():
    from translucent_addon.core.geometry.mesh_checks import check_mesh

    v, t = load_npz(MESHES / "teapot.npz")
    warnings = validate(_inputs(vertices=v, triangles=t))
    n = check_mesh(v, t).boundary_edges
    assert f"'Spot': the mesh is open ({n} boundary edges); light leaks where the surface has holes" in warnings
    t2 = np.vstack([load_npz(MESHES / "spot.npz")[1], [[0, 0, 1]]]).astype(np.int32)
    warnings = validate(_inputs(triangles=t2))
    assert "'Spot': 1 zero-area faces carry no light and are ignored" in warnings


def _cube(offset=(0.0, 0.0, 0.0), size=1.0):
    h = size / 2
    v = np.array([(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)], np.float64) + offset
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return v, np.array([(a, b, c) for a, b, c, d in quads] + [(a, c, d) for a, b, c, d in quads], np.int32)


def test_bake_warns_on_non_manifold_edges_with_the_count():
    v, t = _cube()
    fin = np.array([[0, 1, 8]], np.int32)  # a third face on the edge (0, 1)
    v = np.vstack([v, [[-0.5, -1.5, -0.5]]]).astype(np.float32)
    warnings = validate(_inputs(vertices=v, triangles=np.vstack([t, fin])))
    assert "'Spot': 1 non-manifold edges" in warnings


def test_self_intersections_are_found_and_touching_is_not():
    from translucent_addon.core.geometry.mesh_checks import self_intersections

    def two(offset):
        (v1, t1), (v2, t2) = _cube(), _cube(offset)
        return np.vstack([v1, v2]), np.vstack([t1, t2 + 8])

    assert self_intersections(*_cube()) == 0
    assert self_intersections(*two((0.5, 0.2, 0.1))) > 0  # interpenetrating
    assert self_intersections(*two((3.0, 0.0, 0.0))) == 0  # apart
    assert self_intersections(*two((1.0, 0.0, 0.0))) == 0  # face to face, touching only
    v, t = load_npz(MESHES / "spot.npz")
    assert self_intersections(v, t) == 0  # a clean scan
    v, t = two((0.5, 0.2, 0.1))
    n = self_intersections(v, t)
    warnings = validate(_inputs(vertices=v.astype(np.float32), triangles=t))
    assert f"'Spot': the surface intersects itself ({n} pairs of faces cross); its inside is ambiguous, so light " \
           "may leak or be trapped there" in warnings


def test_bake_refuses_huge_meshes_and_names_the_count():
    from translucent_addon.techniques.registry import MAX_BAKE_TRIANGLES

    huge = np.zeros((MAX_BAKE_TRIANGLES + 1, 3), np.int32)
    with pytest.raises(BakeInputError, match=r"^'Spot': 2,000,001 triangles is more than a bake takes \(2,000,000\); "
                                             r"decimate it or bake a proxy$"):
        validate(_inputs(triangles=huge))


# -- comparison metrics ------------------------------------------------------------------
def test_metrics_on_known_images():
    from translucent_addon.core.metrics import median_relative_error, relative_rmse, ssim

    rng = np.random.default_rng(0)
    ref = rng.uniform(0.2, 1.0, (32, 32, 4))
    mask = np.zeros((32, 32), bool)
    mask[8:24, 8:24] = True
    assert relative_rmse(ref, ref, mask) == 0.0
    assert ssim(ref, ref, mask) == pytest.approx(1.0)
    assert relative_rmse(ref * 1.1, ref, mask) == pytest.approx(0.1)
    # Outside the mask nothing counts.
    other = ref.copy()
    other[~mask] = 100.0
    assert relative_rmse(other, ref, mask) == 0.0
    # A firefly moves the RMSE a lot and the median not at all.
    spiky = ref.copy()
    spiky[10, 10, :3] = 1e4
    assert relative_rmse(spiky, ref, mask) > 10 and median_relative_error(spiky, ref, mask) == 0.0
    assert ssim(ref * 0.5, ref, mask) < 0.95
    with pytest.raises(ValueError, match="selects no pixel"):
        relative_rmse(ref, ref, np.zeros((32, 32), bool))


def test_reference_cache_round_trip(tmp_path):
    from translucent_addon.core.reference import cache

    desc = {"scene": "a", "samples": 64}
    assert cache.load(tmp_path, desc) is None
    img = np.arange(24, dtype=np.float32).reshape(2, 3, 4)
    cache.store(tmp_path, desc, img, 1.25)
    got, seconds = cache.load(tmp_path, desc)
    np.testing.assert_array_equal(got, img)
    assert seconds == 1.25
    assert cache.load(tmp_path, {"scene": "a", "samples": 65}) is None


def test_pareto_front_keeps_exactly_the_points_nothing_beats_in_both_time_and_error():
    from translucent_addon.core.report.report import pareto_front

    seconds = [1.0, 2.0, 2.0, 3.0, 0.5, 4.0, 3.0]
    errors = [0.30, 0.20, 0.25, 0.20, 0.50, 0.05, 0.10]
    front = pareto_front(seconds, errors)
    # 0.5 s at 0.50, 1 s at 0.30, 2 s at 0.20, 3 s at 0.10, 4 s at 0.05; (2, 0.25), (3, 0.20) are beaten.
    assert front.tolist() == [4, 0, 1, 6, 5]
    t, e = np.array(seconds), np.array(errors)
    for i in range(len(t)):
        beaten = ((t <= t[i]) & (e < e[i])).any() or ((t < t[i]) & (e <= e[i])).any()
        assert (i in front) != beaten, i
    assert pareto_front([], []).tolist() == []


def test_summary_pareto_chart_draws_a_panel_per_scene(tmp_path):
    """bench's pareto.png: drawn from report entries, not blank (the panels' lines differ from the page)."""
    from translucent_addon.core.report.png import read_png
    from translucent_addon.core.report.report import Entry, pareto_summary_chart, speed_accuracy_chart

    def imread(path):  # as matplotlib's imread gave it: floats in [0, 1]
        return read_png(path) / 255.0

    def entries(scale):
        return [Entry(series=s, engine="X", settings={"label": f"{n}"}, seconds=t, reference="ref",
                      rel_rmse=scale * e * 2, median_rel_error=scale * e)
                for s, n, t, e in (("Cycles random walk", 16, 0.7, 0.14), ("Cycles random walk", 64, 2.6, 0.07),
                                   ("EEVEE", 16, 10.0, 0.43), ("Translucent (TEXTURE_SPACE)", 512, 1.5, 0.23))]

    path = tmp_path / "pareto.png"
    pareto_summary_chart({"a": entries(1.0), "b": entries(0.5), "c": entries(2.0)}, path, "test")
    image = imread(path)
    assert image.shape[0] > 400 and image.shape[1] > 1000
    assert image[..., :3].std() > 0.05  # lines and text on the white page
    speed_accuracy_chart(entries(1.0), tmp_path / "chart.png", "one scene")
    assert imread(tmp_path / "chart.png")[..., :3].std() > 0.05
    with pytest.raises(ValueError, match="no scenes"):
        pareto_summary_chart({}, tmp_path / "none.png", "empty")
    # A panel with only the RMSE (the caustic ball's benchmark): drawn from that metric, under its own title.
    from unittest import mock

    import translucent_addon.core.report.report as report_module
    from translucent_addon.core.report.colormaps import series_colours

    rmse_only = [Entry(series=f"S{k}", engine="X", settings={}, seconds=0.1 * (k + 1), reference="ref",
                       rel_rmse=0.5 / (k + 1)) for k in range(12)]  # 12 series: past ten colours
    with mock.patch.object(report_module, "_speed_accuracy_panel", wraps=report_module._speed_accuracy_panel) as panel:
        pareto_summary_chart({"a": entries(1.0), "caustic": rmse_only}, tmp_path / "mixed.png", "t",
                             panel_metrics={"caustic": "rel_rmse"}, panel_titles={"caustic": "caustic ball"})
    assert [(len(c.args[1]), c.args[2]) for c in panel.call_args_list] == [(4, "median_rel_error"), (12, "rel_rmse")]
    assert imread(tmp_path / "mixed.png")[..., :3].std() > 0.05
    colours = series_colours(e.series for e in rmse_only)
    assert len({tuple(c) for c in colours.values()}) == 12


# -- the sky a surface point sees (core/geometry/world_visibility.py) ------------------------------------
def _box_mesh(lo, hi):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
                  [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return v, f


def test_sky_visibility_through_voxels_matches_ray_casting_against_the_triangles():
    """An L of two boxes (a 200 x 200 x 20 floor, a 100 x 200 x 180 wall standing on its far half): the
    voxels hold its volume within 1 %, and the cosine-weighted sky seen from points on the floor (3, 20,
    60 and 80 from the wall) and on the wall's top is what 1024 rays cast against the triangles see,
    within 0.04 (32 rays, a step of 1/32; measured up to 0.033); at the foot of the wall about half the
    sky is gone (the view factor of an infinite wall is 1/2), less the further from it."""
    from translucent_addon.core.geometry import world_visibility as wv
    from translucent_addon.core.geometry.raycast import occluded

    floor_v, floor_f = _box_mesh((0, 0, 0), (200, 200, 20))
    wall_v, wall_f = _box_mesh((100, 0, 20), (200, 200, 200))
    v = np.concatenate([floor_v, wall_v])
    f = np.concatenate([floor_f, wall_f + len(floor_v)])
    occ = wv.occupancy(v, f, 96)
    assert occ.inside.sum() * occ.cell**3 == pytest.approx(200 * 200 * 20 + 100 * 200 * 180, rel=0.01)
    points = np.array([[20.0, 100.0, 20.0], [97.0, 100.0, 20.0], [80.0, 100.0, 20.0], [40.0, 100.0, 20.0],
                       [150.0, 100.0, 200.0]])
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    V = wv.cosine_visibility(points, normals, occ)
    dirs = wv.hemisphere_directions(1024)
    exact = []
    for p in points:
        origins = np.tile(p + 2.0 * occ.cell * np.array([0.0, 0.0, 1.0]), (len(dirs), 1))
        exact.append(1.0 - occluded(origins, dirs, np.full(len(dirs), np.inf), v[f]).mean())
    np.testing.assert_allclose(V, exact, atol=0.04)
    assert V[-1] == pytest.approx(1.0) and 0.4 < V[1] < 0.6 and V[0] > V[3] > V[2] > V[1]


def test_the_noise_of_a_mean_of_renders_follows_their_spread():
    """compare.metrics.mean_noise: for two renders, half the RMSE between them relative to their mean
    (the bench's old rule, which took it relative to the second); for n renders of a known noise sigma
    around a flat image, sigma / sqrt(n) relative to it (within 3 % over 20k pixels), so four seeds keep half
    the noise of one."""
    from translucent_addon.core import metrics

    rng = np.random.default_rng(3)
    mask = np.ones((100, 200), bool)
    a, b = rng.random((2, 100, 200, 4))
    half = 0.5 * metrics.relative_rmse(a, b, mask) * np.sqrt(np.mean(b[..., :3] ** 2)
                                                              / np.mean(((a + b)[..., :3] / 2) ** 2))
    assert metrics.mean_noise(np.stack([a, b]), mask) == pytest.approx(half, rel=1e-12)
    sigma = 0.1
    for n in (2, 4, 8):
        renders = 1.0 + sigma * rng.standard_normal((n, 100, 200, 4))
        assert metrics.mean_noise(renders, mask) == pytest.approx(sigma / np.sqrt(n), rel=0.03)
    with pytest.raises(ValueError):
        metrics.mean_noise(a[None], mask)


def test_block_error_sees_texture_level_differences_and_not_blade_positions():
    """compare.metrics.block_relative_rmse: a stripe pattern against its shifted copy is wrong at every pixel
    (relative RMSE sqrt(2)) but right in every 8 x 8 block (0); a 10 % brighter image is 10 % off in both;
    masked pixels count only where the mask is; an image smaller than a block is refused."""
    from translucent_addon.core import metrics

    h, w = 64, 96
    x = np.arange(w)[None, :, None] * np.ones((h, 1, 4))
    stripes = (x % 2).astype(np.float64)
    shifted = ((x + 1) % 2).astype(np.float64)
    mask = np.ones((h, w), bool)
    assert metrics.relative_rmse(shifted, stripes, mask) == pytest.approx(np.sqrt(2.0))
    assert metrics.block_relative_rmse(shifted, stripes, mask) == pytest.approx(0.0, abs=1e-12)
    rng = np.random.default_rng(5)
    ref = rng.random((h, w, 4)) + 0.5
    assert metrics.block_relative_rmse(1.1 * ref, ref, mask) == pytest.approx(0.1, rel=1e-9)
    half = mask.copy()
    half[:, w // 2:] = False
    wrong_right = ref.copy()
    wrong_right[:, w // 2:] *= 3.0  # outside the mask: no effect
    assert metrics.block_relative_rmse(wrong_right, ref, half) == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError):
        metrics.block_relative_rmse(ref[:4, :4], ref[:4, :4], mask[:4, :4])


def test_the_cache_key_of_a_mesh_ignores_the_order_blender_lists_its_corners_in():
    """compare.cache.corner_digest: the same triangles shuffled, each started at another corner, give the
    same digest (Blender lists a UV sphere's corners in another order from one session to the next); a
    corner moved by 1e-3, a colour changed, or the winding reversed give another."""
    from translucent_addon.core.reference.cache import corner_digest

    rng = np.random.default_rng(2)
    T = 200
    pos = rng.random((3 * T, 3)).astype(np.float32)
    col = rng.random((3 * T, 3)).astype(np.float32)
    d = corner_digest(pos, col)
    perm = rng.permutation(T)
    shift = rng.integers(0, 3, T)
    idx = (3 * perm[:, None] + (shift[:, None] + np.arange(3)[None, :]) % 3).reshape(-1)
    assert corner_digest(pos[idx], col[idx]) == d
    moved = pos.copy()
    moved[7, 1] += 1e-3
    assert corner_digest(moved, col) != d
    recoloured = col.copy()
    recoloured[11, 0] = 0.5
    assert corner_digest(pos, recoloured) != d
    flipped = pos.reshape(T, 3, 3)[:, ::-1].reshape(-1, 3)
    assert corner_digest(flipped, col.reshape(T, 3, 3)[:, ::-1].reshape(-1, 3)) != d


def test_the_cache_key_of_normals_survives_their_float_noise():
    """compare.cache.normals_digest: a unit sphere's smooth normals with 1e-7 of noise (Blender sums them in
    another order between sessions) keep the digest, and so does a moment that comes out -0 instead of 0;
    the sphere's flat (face) normals change it."""
    from translucent_addon.core.reference.cache import normals_digest

    rng = np.random.default_rng(4)
    tri = rng.normal(size=(3000, 3, 3))
    tri = np.concatenate([tri, -tri])  # antipodal pairs: sum n is 0 up to noise of either sign
    tri /= np.linalg.norm(tri, axis=2, keepdims=True)
    pos = tri.reshape(-1, 3)
    smooth = pos.copy()
    d = normals_digest(pos, smooth)
    for _ in range(5):
        assert normals_digest(pos, smooth + 1e-7 * rng.standard_normal(smooth.shape)) == d
    face = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face /= np.linalg.norm(face, axis=1, keepdims=True)
    assert normals_digest(pos, np.repeat(face, 3, axis=0)) != d


# -- the report's PNGs, colours and charts without matplotlib (core/report/png.py, colormaps.py, raster_chart.py) --
def test_the_shipped_extension_never_imports_matplotlib():
    """matplotlib is not in the extension zip: the report (PNGs, error images, charts) must not need it."""
    code = ("import sys, translucent_addon.core.report.report, translucent_addon.core.report.raster_chart; "
            "print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
    import re

    importing = [str(path.relative_to(ROOT)) for path in (ROOT / "translucent_addon").rglob("*.py")
                 if re.search(r"^\s*(import|from)\s+matplotlib\b", path.read_text(encoding="utf-8"), re.M)]
    assert importing == []


@pytest.mark.parametrize("channels", [3, 4])
def test_png_round_trip_is_bit_exact(tmp_path, channels):
    """write_png and read_png: every filter type, odd sizes, one pixel; Pillow (where installed) reads the same."""
    from translucent_addon.core.report.png import read_png, write_png

    rng = np.random.default_rng(channels)
    for h, w in ((1, 1), (7, 13), (31, 5), (64, 3)):
        image = rng.integers(0, 256, (h, w, channels), dtype=np.uint8)
        image[: h // 2, : w // 2] = 255  # flat areas beside the noise
        for filter_type in range(5):
            path = tmp_path / f"{h}x{w}_{filter_type}.png"
            write_png(path, image, filter_type=filter_type)
            assert path.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
            got = read_png(path)
            assert got.dtype == np.uint8 and got.shape == image.shape
            np.testing.assert_array_equal(got, image)
    try:
        from PIL import Image
    except ImportError:
        return
    np.testing.assert_array_equal(np.asarray(Image.open(path)), image)
    Image.fromarray(image).save(tmp_path / "pillow.png", optimize=True)  # Pillow's own choice of filters
    np.testing.assert_array_equal(read_png(tmp_path / "pillow.png"), image)


def test_png_reader_and_writer_refuse_what_they_do_not_handle(tmp_path):
    import struct
    import zlib

    from translucent_addon.core.report.png import read_png, write_png

    with pytest.raises(ValueError):
        write_png(tmp_path / "f.png", np.zeros((4, 4, 3), np.float32))
    with pytest.raises(ValueError):
        write_png(tmp_path / "g.png", np.zeros((4, 4), np.uint8))
    (tmp_path / "text.png").write_text("not a png")
    with pytest.raises(ValueError, match="not a PNG"):
        read_png(tmp_path / "text.png")

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    sixteen_bit = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 1, 1, 16, 2, 0, 0, 0))
                   + chunk(b"IDAT", zlib.compress(bytes(7))) + chunk(b"IEND", b""))
    (tmp_path / "16.png").write_bytes(sixteen_bit)
    with pytest.raises(ValueError, match="8-bit"):
        read_png(tmp_path / "16.png")
    write_png(tmp_path / "ok.png", np.zeros((3, 3, 3), np.uint8))
    (tmp_path / "cut.png").write_bytes((tmp_path / "ok.png").read_bytes()[:-20])
    with pytest.raises(ValueError):
        read_png(tmp_path / "cut.png")


def test_error_png_is_inferno_grey_outside_the_object_and_upright(tmp_path):
    """save_error_png: row 0 of the render is the bottom row of the file; no error is inferno's black end."""
    from translucent_addon.core.report.colormaps import inferno
    from translucent_addon.core.report.png import read_png
    from translucent_addon.core.report.report import save_error_png

    ref = np.ones((6, 5, 3), np.float32)
    mask = np.ones((6, 5), bool)
    mask[0] = False  # the bottom row of the picture
    save_error_png(tmp_path / "err.png", ref.copy(), ref, mask)
    got = read_png(tmp_path / "err.png")
    assert got.shape == (6, 5, 3)
    assert (got[-1] == 63).all()  # 0.25 grey, at the bottom of the file
    np.testing.assert_array_equal(got[:-1], np.broadcast_to((inferno(0.0) * 255).astype(np.uint8), (5, 5, 3)))


def test_inferno_and_the_series_palettes_match_matplotlib():
    """The embedded tables: inferno within 1/255 of matplotlib's at its 256 colours; tab10 and tab20 exact."""
    matplotlib = pytest.importorskip("matplotlib")
    from translucent_addon.core.report.colormaps import inferno, series_colours

    x = np.linspace(0.0, 1.0, 256)
    assert np.abs(inferno(x) - matplotlib.colormaps["inferno"](x)[:, :3]).max() <= 1 / 255
    assert inferno(np.zeros((2, 3))).shape == (2, 3, 3)
    assert np.isfinite(inferno(np.array([np.nan, -1.0, 2.0]))).all()
    few = series_colours(["b", "a", "c", "a"])
    assert list(few) == ["a", "b", "c"]
    for k, name in enumerate(few):
        np.testing.assert_allclose(few[name], matplotlib.colormaps["tab10"](k)[:3], atol=1e-9)
    many = series_colours(f"S{k:02d}" for k in range(12))
    for k, name in enumerate(sorted(many)):
        np.testing.assert_allclose(many[name], matplotlib.colormaps["tab20"](k)[:3], atol=1e-9)


def _near(image, colour, tol=12):
    """Pixels within tol levels of an (r, g, b) colour in [0, 1], in every channel."""
    return (np.abs(image[..., :3].astype(int) - np.round(np.asarray(colour) * 255)) <= tol).all(axis=-1)


def test_raster_chart_draws_series_front_labels_and_text_where_the_log_axes_say(tmp_path):
    """A two-series panel as report.py draws it: each marker where Axes.to_pixel puts it (and to_pixel is
    log10-linear between the frame's edges), the dashed Pareto staircase between its points, the point
    labels, the title's text above the panels and the legend to their right, off the data."""
    from translucent_addon.core.report import raster_chart, report
    from translucent_addon.core.report.colormaps import series_colours
    from translucent_addon.core.report.png import read_png

    font = ROOT / "translucent_addon" / "core" / "report" / "chart_font.npz"
    assert font.stat().st_size < 60_000
    licence = ROOT / "translucent_addon" / "core" / "report" / "chart_font_LICENSE.txt"
    assert licence.read_text().count("Bitstream") > 2
    a = [(0.2, 0.3, "a1"), (0.5, 0.2, "a2"), (5.0, 0.02, "a3")]
    b = [(1.0, 0.1, "16 spp"), (2.0, 0.08, "64 spp")]
    entries = [report.Entry(series=name, engine="X", settings={"label": label}, seconds=t, reference="ref",
                            rel_rmse=e) for name, points in (("A", a), ("B", b)) for t, e, label in points]
    colours = series_colours(["A", "B"])

    def draw(labels):
        fig = raster_chart.Figure(900, 450, title="Speed against accuracy")
        report._speed_accuracy_panel(fig.axes[0], entries, "rel_rmse", "relative RMSE", colours, labels=labels)
        fig.legend("right", report._legend_items(colours))
        return fig, fig.save(tmp_path / f"chart_{labels}.png")

    fig, image = draw(True)
    np.testing.assert_array_equal(read_png(tmp_path / "chart_True.png"), image)
    ax = fig.axes[0]
    x0, y0, x1, y1 = ax.rect
    # to_pixel: the limits at the frame's edges, equal decades equally long.
    (xl, xh), (yl, yh) = ax.xlim, ax.ylim
    np.testing.assert_allclose(ax.to_pixel([10 ** xl, 10 ** xh], [10 ** yl, 10 ** yh]), [[x0, x1], [y1, y0]])
    px, py = ax.to_pixel([0.1, 1.0, 10.0], [0.01, 0.1, 1.0])
    np.testing.assert_allclose(np.diff(px), np.diff(px)[0])
    np.testing.assert_allclose(np.diff(py), np.diff(py)[0])
    assert (image[y0 + 5:y1 - 5, x0] < 90).all()  # the frame's left edge
    yy, xx = np.mgrid[:image.shape[0], :image.shape[1]]
    for name, points in (("A", a), ("B", b)):
        for t, e, _ in points:
            px, py = (float(v) for v in ax.to_pixel(t, e))
            near = _near(image, colours[name]) & (np.hypot(xx + 0.5 - px, yy + 0.5 - py) <= 3.5)
            assert near.sum() >= 12, (name, t, e)  # a marker, not a line's width
            assert math.hypot(xx[near].mean() + 0.5 - px, yy[near].mean() + 0.5 - py) <= 2.0, (name, t, e)
    # The front: 0.2 s at 0.3, 0.5 s at 0.2, 1 s at 0.1, 2 s at 0.08, 5 s at 0.02; dashed along each level.
    front = [(0.2, 0.3), (0.5, 0.2), (1.0, 0.1), (2.0, 0.08), (5.0, 0.02)]
    for (t0, e0), (t1, _) in zip(front[:-1], front[1:]):
        (u0, u1), (v, _) = ax.to_pixel([t0, t1], [e0, e0])
        row = image[int(v) - 1:int(v) + 2, int(u0) + 7:int(u1) - 7]
        grey = (row.max(axis=-1).astype(int) - row.min(axis=-1) < 20) & (row.max(axis=-1) < 160)
        dashed = grey.any(axis=0)
        assert 0.35 < dashed.mean() < 0.95, (t0, dashed.mean())  # drawn, with gaps
    # Text: the title above the panel, the labels beside their points (darker than without them).
    assert (image[:y0 - 4] < 80).all(axis=-1).sum() > 40
    plain = draw(False)[1]

    def ink(im, u, v):  # darkness near a point, where its label goes (at one of its corners)
        return (255 - im[max(int(v) - 20, 0):int(v) + 20, max(int(u) - 45, 0):int(u) + 45].astype(int)).sum() / 255

    for t, e, label in a + b:
        u, v = ax.to_pixel(t, e)
        assert ink(image, u, v) > ink(plain, u, v) + 15 * len(label), label
    # The legend: both series' colours right of the panel, where no data is.
    for name in ("A", "B"):
        assert _near(image[:, x1 + 5:], colours[name]).sum() > 20
    assert image.std() > 20 and len(np.unique(image.reshape(-1, 3), axis=0)) > 50


def test_charts_survive_degenerate_data_and_show_every_series(tmp_path):
    """One point, equal values, zero, infinite and missing errors: no floating-point error on the way,
    nothing non-finite drawn; speed_accuracy_chart shows each series' colour."""
    from translucent_addon.core.report import report
    from translucent_addon.core.report.colormaps import series_colours
    from translucent_addon.core.report.png import read_png

    def entry(series, t, e):
        return report.Entry(series=series, engine="X", settings={"label": "x"}, seconds=t, reference="r",
                            rel_rmse=e, median_rel_error=e)

    cases = {"one": [entry("A", 1.0, 0.1)], "same": [entry("A", 1.0, 0.1), entry("B", 1.0, 0.1)],
             "bad": [entry("A", 0.0, 0.1), entry("A", 1.0, float("inf")), entry("A", 2.0, float("nan")),
                     entry("B", 1.0, None), entry("B", 3.0, 0.2), entry("C", 2.0, 0.0)],
             "none": [entry("A", 1.0, None)]}
    with np.errstate(all="raise"):
        for name, entries in cases.items():
            report.speed_accuracy_chart(entries, tmp_path / f"{name}.png", name)
            image = read_png(tmp_path / f"{name}.png")
            assert image.shape[1] > 1000 and image.std() > 10
        report.pareto_summary_chart(cases, tmp_path / "all.png", "all")
        report.error_against_samples_chart([dict(object_samples=n, rel_rmse_vs_model=0.3 / n ** 0.5, overlap=2.0,
                                                  seconds=0.1) for n in (100, 1000, 10000)], tmp_path / "d.png", "d")
    assert read_png(tmp_path / "d.png").std() > 10
    colours = series_colours(["A", "B"])
    image = read_png(tmp_path / "same.png")
    for name in ("A", "B"):
        assert _near(image, colours[name]).sum() > 30


def test_the_camera_sees_a_box_unless_it_lies_wholly_beyond_one_frustum_plane():
    from translucent_addon.core.frame import CameraView
    from translucent_addon.gpu import blocks

    view = blocks.look_at((0.0, -5.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    camera = CameraView(view, blocks.perspective(np.radians(40.0), 1.0, 0.1, 100.0), 64, 64)
    box = np.array([0.2, 0.2, 0.2])
    assert camera.sees_box(-box, box)  # in front, centred
    assert not camera.sees_box((0.0, -9.0, 0.0) - box, (0.0, -9.0, 0.0) + box)  # behind the camera
    assert not camera.sees_box((6.0, 0.0, 0.0) - box, (6.0, 0.0, 0.0) + box)  # beside the view
    assert not camera.sees_box((0.0, 200.0, 0.0) - box, (0.0, 200.0, 0.0) + box)  # past the far plane
    assert camera.sees_box((1.9, 0.0, 0.0) - box, (1.9, 0.0, 0.0) + box)  # half out at the side: kept
    assert camera.sees_box((-50.0, -9.0, -1.0), (50.0, 50.0, 1.0))  # around the camera: kept

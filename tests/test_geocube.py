"""GEOCUBE (Chan & Wang 2005), pure: the appendix's step functions, the bake, and the exit search
against exact ray casting (brute force on small meshes)."""
from __future__ import annotations

import numpy as np
import pytest
from test_quadgraph import icosphere

from translucent_addon.core.geometry.raycast import BruteForceTracer
from translucent_addon.techniques.geocube import bake as geocube
from translucent_addon.techniques.geocube import model as gd


def voxel_mesh(cells):
    """The closed surface of a union of unit voxels (outward winding), vertices shared."""
    cells = {tuple(c) for c in cells}
    quads = []
    for (x, y, z) in cells:
        for axis in range(3):
            for side in (0, 1):
                n = [0, 0, 0]
                n[axis] = 1 if side else -1
                if (x + n[0], y + n[1], z + n[2]) in cells:
                    continue
                u, w = [a for a in range(3) if a != axis]
                base = np.array([x, y, z], float)
                base[axis] += side
                corners = []
                for du, dw in ((0, 0), (1, 0), (1, 1), (0, 1)):
                    p = base.copy()
                    p[u] += du
                    p[w] += dw
                    corners.append(p)
                e = np.cross(corners[1] - corners[0], corners[3] - corners[0])
                if np.dot(e, n) < 0:
                    corners = corners[::-1]
                quads.append(corners)
    pts = np.array(quads).reshape(-1, 3)
    verts, inverse = np.unique(np.round(pts, 9), axis=0, return_inverse=True)
    q = inverse.reshape(-1, 4)
    tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return verts, tris


def u_shape(scale=10.0):
    """A U: a 3 x 1 x 1 base and two arms 3 high; no single interior point sees both arms' insides."""
    cells = [(x, 0, 0) for x in range(3)] + [(0, 0, z) for z in range(1, 4)] + [(2, 0, z) for z in range(1, 4)]
    v, t = voxel_mesh(cells)
    return v * scale, t


def random_inward_rays(v, t, n, seed):
    pts, nrm, tri = geocube.area_samples(v, t, n, seed=seed)
    rng = np.random.default_rng(seed)
    d = -nrm + 0.6 * rng.normal(size=nrm.shape)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    keep = np.einsum("rd,rd->r", d, nrm) < -0.3
    return pts[keep], d[keep], tri[keep]


def exit_errors(gset, tracer, pts, d, tri, cap):
    at = gd.atlases(gset)
    ex = gd.exit_search(at, pts, d, gset.start_cube[tri], cap, gset.min_step)
    t, _, _, _ = tracer.closest_hit(pts + d * 1e-6, d)
    ok = np.isfinite(t)
    exact = pts + d * (t + 1e-6)[:, None]
    err = np.linalg.norm(ex.point - exact, axis=1)[ok] / gset.size
    return err, ex


# -- the appendix -------------------------------------------------------------------------------------
def _cone_exit_by_marching(f, h, a, n, mu):
    """Distance to leave a unit cone from an axis point, by fine marching (independent of the formula)."""
    apex = -a  # the base centre at the origin, the apex one unit back along the axis
    p0 = apex + (1 - f) * a
    ts = np.linspace(0, 20, 400001)
    p = p0 + ts[:, None] * h
    rel = p - apex
    axial = rel @ a
    inside = (rel @ n * 0 + (p @ n) <= 0) & (axial >= 0) & (axial * 1.0 >= mu * np.linalg.norm(rel, axis=1))
    out = np.flatnonzero(~inside)
    return ts[out[0]]


@pytest.mark.parametrize("seed", range(6))
def test_cone_step_is_the_distance_to_leave_the_cone(seed):
    rng = np.random.default_rng(seed)
    a = np.array([0.0, 0.0, 1.0])
    tilt = rng.normal(size=3) * 0.2
    n = a + tilt
    n /= np.linalg.norm(n)
    h = rng.normal(size=3)
    h /= np.linalg.norm(h)
    if h @ a < -0.5:
        h = -h
    mu = np.cos(rng.uniform(0.2, 1.0))
    f = rng.uniform(0.1, 0.9)
    got = gd.cone_step(f, h, a, n, mu)
    assert got == pytest.approx(_cone_exit_by_marching(f, h, a, n, mu), abs=2e-4)


def test_sphere_step_reaches_the_sphere():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(100, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    h = rng.normal(size=(100, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    f = rng.uniform(0, 1, 100)
    s = gd.s_star(f, np.einsum("rd,rd->r", h, v))
    np.testing.assert_allclose(np.linalg.norm(f[:, None] * v + s[:, None] * h, axis=1), 1.0, atol=1e-12)
    assert (s >= 0).all()


# -- the bake and the search --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sphere_set():
    v, t = icosphere(2, 10.0)
    tracer = BruteForceTracer(v[t])
    return v, t, tracer, geocube.build(v, t, 16, 1.5, tracer, coverage_samples=1500)


def test_one_cube_covers_a_sphere_and_its_cones_follow_the_geometry(sphere_set):
    v, t, tracer, g = sphere_set
    assert g.count == 1 and g.coverage == 1.0
    assert np.isfinite(g.cones).all() and np.isfinite(g.normals).all()
    assert np.linalg.norm(g.centres[0]) < 1.0  # near the centre

    # Every texel's surface point lies on the polyhedron: between its inscribed and its circumscribed sphere.
    from translucent_addon.core.geometry import cubemap

    S = g.centres[0] + cubemap.texel_directions(16) * g.cones[0, ..., :1]
    r = np.linalg.norm(S, axis=-1)
    assert r.min() > 9.4 and r.max() <= 10.0 + 1e-5
    # Cone A from a point of a sphere to its centre fits up to 45 degrees; the samples bound it close.
    theta_A = np.degrees(np.arccos(g.cones[0, ..., 1]))
    assert 35.0 < np.median(theta_A) <= 45.0
    # Cone C: a chord at the critical angle of glass, 2 R cos(theta_c) = 14.9 mm on a sphere of 10.
    assert np.median(g.cones[0, ..., 3]) == pytest.approx(2 * 10 * np.cos(np.arcsin(1 / 1.5)), rel=0.25)


def _planes(v, t):
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return n, v[t[:, 0]]


def test_inscribed_sphere_is_the_distance_to_the_nearest_face(sphere_set):
    v, t, _, g = sphere_set
    n, p0 = _planes(v, t)
    plane_dist = np.abs(np.einsum("td,td->t", n, p0 - g.centres[0]))
    assert g.radius_D[0] == pytest.approx(plane_dist.min(), rel=1e-6)


def test_exit_points_on_a_sphere_match_exact_ray_casting(sphere_set):
    v, t, tracer, g = sphere_set
    pts, d, tri = random_inward_rays(v, t, 400, seed=5)
    err, ex = exit_errors(g, tracer, pts, d, tri, cap=32)
    assert not ex.premature.any()
    assert np.median(err) < 2e-3 and np.percentile(err, 99) < 2e-2, (np.median(err), np.percentile(err, 99))
    assert ex.steps.mean() < 6  # cones A, B, C and D propel the point in a few steps


def test_a_step_cap_too_small_exits_early_at_the_last_surface_point(sphere_set):
    v, t, tracer, g = sphere_set
    pts, d, tri = random_inward_rays(v, t, 200, seed=6)
    _, short = exit_errors(g, tracer, pts, d, tri, cap=1)
    _, full = exit_errors(g, tracer, pts, d, tri, cap=32)
    assert short.premature.mean() > 0.5 and not full.premature.any()


@pytest.fixture(scope="module")
def u_set():
    v, t = u_shape()
    tracer = BruteForceTracer(v[t])
    return v, t, tracer, geocube.build(v, t, 16, 1.5, tracer, coverage_samples=1500)


def test_automatic_placement_covers_a_shape_that_is_not_star_shaped(u_set):
    v, t, tracer, g = u_set
    assert g.count >= 2, "a U needs a cube per arm"
    assert np.isfinite(g.cones).all()
    assert g.coverage == 1.0
    # Independently: every one of a fresh set of samples is seen by some centre.
    pts, nrm, tri = geocube.area_samples(v, t, 800, seed=11)
    seen = geocube.visibility(g.centres, pts, nrm, tracer, geocube.face_normals(v, t)[tri]).any(axis=0)
    assert seen.mean() > 0.99
    assert geocube.inside(g.centres, tracer).all()


def test_exit_search_switches_cubes_in_a_u(u_set):
    v, t, tracer, g = u_set
    pts, d, tri = random_inward_rays(v, t, 600, seed=7)
    err, ex = exit_errors(g, tracer, pts, d, tri, cap=64)
    assert ex.premature.mean() < 0.02
    assert np.median(err) < 5e-3
    assert (err > 0.05).mean() < 0.05, (err > 0.05).mean()


def test_bake_arrays_round_trip(sphere_set):
    _, _, _, g = sphere_set
    back = geocube.from_arrays(geocube.to_arrays(g))
    assert back.res == g.res and back.count == g.count
    np.testing.assert_array_equal(back.cones, g.cones)
    np.testing.assert_array_equal(back.start_cube, g.start_cube)


def test_a_stored_set_whose_atlas_would_pass_the_texture_limit_is_refused(sphere_set):
    """The cubes stack, res + 2 texels each, in one atlas of at most 16,384 rows (64 cubes at 256 texels made
    16,512): a bake places at most MAX_ATLAS_ROWS // (res + 2) and a stored set of more is refused."""
    from translucent_addon.core.bake_store import DamagedBakeError

    _, _, _, g = sphere_set
    arrays = geocube.to_arrays(g)
    res = 256
    over = geocube.MAX_ATLAS_ROWS // (res + 2) + 1
    w = res + 2
    arrays.update(gc_scalars=np.array([res, *arrays["gc_scalars"][1:]]), gc_centres=np.zeros((over, 3)),
                  gc_radius_D=np.ones(over), gc_cones=np.zeros((over, 6, w, w, 4), np.float32),
                  gc_normals=np.zeros((over, 6, w, w, 3), np.float32))
    with pytest.raises(DamagedBakeError, match="cube count"):
        geocube.from_arrays(arrays)
    assert over * w > geocube.MAX_ATLAS_ROWS >= (over - 1) * w


def test_resolution_follows_the_size_on_screen():
    assert geocube.resolution_for(None) == 64
    assert geocube.resolution_for(128) == 64
    assert geocube.resolution_for(40) == 16
    assert geocube.resolution_for(5000) == 256


def test_a_surface_with_no_inside_is_refused():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    t = np.array([[0, 1, 2], [1, 3, 2]])
    with pytest.raises(geocube.GeocubeError, match="no point inside the surface"):
        geocube.build(v, t, 16, 1.5, BruteForceTracer(v[t]), coverage_samples=200)


def test_transfer_lookup_follows_the_table():
    from translucent_addon.core.physics.slab_transfer import transfer_table

    table = transfer_table(0.9, n_photons=4000)
    image, log_max = gd.transfer_image(table)
    taus = np.array([0.0, 0.3, 2.0, 7.0])
    got = gd.transfer_lookup(image, log_max, taus)
    want = np.stack(table.at(taus)[1:], axis=1)
    assert (np.abs(got - want) <= 0.02 * want.max(axis=0) + 1e-6).all(), (got, want)

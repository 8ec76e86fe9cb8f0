"""QUADGRAPH, pure: the volume follows its surface. Poses move the nodes (folds refused); painted maps fill the
volume."""
from __future__ import annotations

import numpy as np
import pytest
from test_quadgraph import _inputs, _run, icosphere

from translucent_addon.core.physics import diffusion as df
from translucent_addon.techniques.quadgraph import deformation as vd
from translucent_addon.techniques.quadgraph import model as qgd

pytest.importorskip("pytetwild")


@pytest.fixture(scope="module")
def baked():
    """A 2-level bake of a 10 mm ball (icosphere of 320 triangles) and its embeddings."""
    v, f = icosphere(2, 1.0)
    (arrays, _), _ = _run(_inputs(vertices=v.astype(np.float32), triangles=f.astype(np.int32)))
    levels = qgd.load(arrays)
    rest_v = arrays["qg_rest_vertices"].astype(np.float64)
    tri = arrays["qg_rest_triangles"]
    embeddings = [qgd.LevelEmbedding(t, arrays[f"qg{h}_points"], arrays[f"qg{h}_tets"], arrays[f"qg{h}_inner_bary"],
                                   rest_v, tri) for h, t in enumerate(levels)]
    return levels, embeddings, rest_v, tri


def _rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def test_closest_point_on_a_triangle_matches_a_dense_search():
    rng = np.random.default_rng(3)
    a, b, c = rng.normal(size=(3, 200, 3))
    p = rng.normal(size=(200, 3)) * 2.0
    bary = vd.closest_on_triangles(p, a, b, c)
    q = np.einsum("nc,ncd->nd", bary, np.stack([a, b, c], axis=1))
    assert np.allclose(bary.sum(axis=1), 1.0) and (bary >= -1e-12).all()
    u, w = np.meshgrid(np.linspace(0, 1, 201), np.linspace(0, 1, 201))
    keep = u + w <= 1.0
    u, w = u[keep], w[keep]
    dense = (1 - u - w)[None, :, None] * a[:, None] + u[None, :, None] * b[:, None] + w[None, :, None] * c[:, None]
    best = np.linalg.norm(dense - p[:, None], axis=2).min(axis=1)
    got = np.linalg.norm(q - p, axis=1)
    assert (got <= best + 1e-12).all()  # never farther than any point of the triangle
    assert np.allclose(got, best, atol=0.02 * np.ptp(dense, axis=1).max())  # and as near as the grid finds


def test_harmonic_interpolation_reproduces_an_affine_map_inside(baked):
    _, embeddings, _, _ = baked
    d = embeddings[-1]
    M = np.array([[1.1, 0.2, 0.0], [0.0, 0.9, 0.3], [0.1, 0.0, 1.2]])
    t = np.array([1.0, -2.0, 0.5])
    u = d.harmonic(d.points[d.fixed] @ (M - np.eye(3)).T + t)
    assert (~d.fixed).sum() > 10, "the ball has inner points"
    assert np.abs(u - (d.points @ (M - np.eye(3)).T + t)).max() < 1e-9


def test_a_rigid_motion_moves_the_nodes_rigidly_and_keeps_the_graph(baked):
    levels, embeddings, rest_v, _ = baked
    R = _rotation((1, 2, 3), 0.7)
    t = np.array([30.0, -5.0, 12.0])
    for rest, embedding in zip(levels, embeddings):
        # The rest pose through the same path: equal to the bake but for float32 storage.
        still = embedding.deform(rest_v)
        assert np.allclose(still.weights, rest.weights, rtol=2e-3, atol=1e-6)
        moved = embedding.deform(rest_v @ R.T + t)
        assert np.abs(moved.positions_mm - (rest.positions_mm @ R.T + t)).max() < 1e-4  # mm
        assert np.allclose(moved.normals, rest.normals @ R.T, atol=1e-5)
        assert np.allclose(moved.weights, still.weights, rtol=1e-6, atol=1e-9)
        assert np.allclose(moved.d_surface, still.d_surface, rtol=1e-6)
        assert (moved.neighbours == rest.neighbours).all()


def test_a_uniform_scale_scales_lengths_and_the_laplacian(baked):
    levels, embeddings, rest_v, _ = baked
    rest, still, moved = levels[-1], embeddings[-1].deform(rest_v), embeddings[-1].deform(2.0 * rest_v)
    assert np.allclose(moved.positions_mm, 2.0 * rest.positions_mm, atol=1e-4)
    assert np.allclose(moved.d_surface, 2.0 * still.d_surface, rtol=1e-6)
    assert np.allclose(moved.weights, still.weights / 4.0, rtol=1e-6, atol=1e-9)  # a_ij ~ 1 / length^2


def test_a_twist_keeps_surface_nodes_on_the_surface_and_changes_the_solution(baked):
    """Twisting the ball 60 degrees top to bottom: surface nodes stay on the moved surface, no
    tetrahedron folds, and the diffusion solution (a light from +x) changes."""
    levels, embeddings, rest_v, tri = baked
    z = rest_v[:, 2] / np.abs(rest_v[:, 2]).max()
    angle = np.radians(30.0) * z
    c, s = np.cos(angle), np.sin(angle)
    twisted = np.stack([c * rest_v[:, 0] - s * rest_v[:, 1], s * rest_v[:, 0] + c * rest_v[:, 1], rest_v[:, 2]], 1)
    rest, moved = levels[-1], embeddings[-1].deform(twisted)
    S = rest.n_surface
    # Each surface node lies on its embedding triangle of the twisted surface (it lay on the rest one).
    emb = embeddings[-1].node_embedding
    on_rest = np.abs(emb.offset).max(axis=1)
    assert np.percentile(on_rest, 95) < 1e-6, "the finest level's surface nodes lie on the mesh itself"
    tri_now = twisted[tri[emb.triangle]]
    q = np.einsum("nc,ncd->nd", emb.bary, tri_now)
    assert np.abs(moved.positions_mm[:S] - q)[on_rest < 1e-6].max() < 1e-6
    assert np.abs(moved.positions_mm - rest.positions_mm).max() > 1.0  # mm: it did move
    kappa = np.full((rest.count, 1), df.kappa(0.01, 1.0))
    mu = np.full((rest.count, 1), 0.01)
    q_s = np.clip(rest.normals[:, :1], 0.0, None)  # lit from +x in the rest pose's node order

    def solve(t):
        return df.solve_direct(t.neighbours, t.weights, t.d_surface, kappa, mu, q_s, 1.3)

    phi_rest, phi_moved = solve(rest), solve(moved)
    assert np.isfinite(phi_moved).all() and (phi_moved[:S] > 0).any()
    change = np.abs(phi_moved - phi_rest).max() / np.abs(phi_rest).max()
    assert 1e-3 < change < 0.5, change  # the graph changed, but it is the same ball lit the same way


def test_a_pose_that_turns_the_volume_inside_out_is_refused(baked):
    _, embeddings, rest_v, _ = baked
    mirrored = rest_v * np.array([1.0, 1.0, -1.0])
    with pytest.raises(vd.DeformationError,
                       match=r"'Ball': the deformation turns .* tetrahedra \(100% of the volume\) inside out; "
                             r"press Bake"):
        embeddings[-1].deform(mirrored, "'Ball': ")
    squashed = rest_v * np.array([1.0, 1.0, 1e-5])
    with pytest.raises(vd.DeformationError):
        embeddings[-1].deform(squashed)


def test_the_bake_hash_follows_topology_not_pose():
    base = _inputs()
    moved = _inputs(vertices=base.vertices * np.float32(1.3))
    assert moved.hash() == base.hash()  # a pose: the nodes follow at run time
    loose = _inputs(vertices=np.concatenate([base.vertices, base.vertices[:1]]))  # one more vertex, same triangles
    assert loose.hash() != base.hash()
    rewired = _inputs(triangles=base.triangles[:, ::-1].copy())
    assert rewired.hash() != base.hash()


def test_slivers_that_turn_over_are_not_a_fold_but_a_turned_over_part_of_the_volume_is():
    rest = np.ones(1000)
    rest[:50] = 1e-6  # slivers
    now = rest.copy()
    now[:50] = -1e-6
    assert vd.check_folds(rest, now).sum() == 50  # 5e-8 of the volume: kept
    now[50:70] = -0.5  # 2 % of the volume turned over
    with pytest.raises(vd.DeformationError, match=r"70 of 1,000 tetrahedra \(2% of the volume\)"):
        vd.check_folds(rest, now)


def test_paint_is_carried_into_the_volume_smoothly_and_exactly_for_a_linear_map(baked):
    """Corner values that are a linear function of position reach every node as that function (to the
    tetrahedraliser's envelope, 1e-3 of the diagonal, by which boundary points sit off the surface)."""
    levels, embeddings, rest_v, tri = baked
    corners = rest_v[tri.reshape(-1)]
    linear = np.stack([corners[:, 0], 2.0 * corners[:, 1] - corners[:, 2] + 3.0], axis=1)
    diag = float(np.linalg.norm(np.ptp(rest_v, axis=0)))
    for rest, embedding in zip(levels, embeddings):
        got = embedding.carry(linear)
        p = rest.positions_mm
        want = np.stack([p[:, 0], 2.0 * p[:, 1] - p[:, 2] + 3.0], axis=1)
        assert np.abs(got - want).max() < 4e-3 * diag


def test_painted_maps_set_blur_and_the_light_entering(baked):
    """Mask 0, glow and tint scale q at the surface nodes where painted; blur scales both coefficients."""
    levels, embeddings, rest_v, tri = baked
    corners = rest_v[tri.reshape(-1)]
    top = corners[:, 2] > 0
    paint = np.tile(np.array([1.0, 1.0, 1.0, 0.0], np.float32), (len(corners), 1))
    tint = np.ones((len(corners), 3), np.float32)
    paint[top, 2] = 4.0  # glow weight 1
    tint[top] = (1.0, 0.5, 0.25)
    paint[~top, 1] = 0.25  # blur weight 1 below
    rest, embedding = levels[-1], embeddings[-1]
    M_d, q_factor = qgd.node_paint(embedding, paint, tint)
    S = rest.n_surface
    z = rest.positions_mm[:, 2]
    far_top, far_bottom = z > 3.0, z < -3.0  # mm, away from the painted boundary at z = 0 (radius 10)
    assert np.allclose(q_factor[:S][far_top[:S]], [4.0, 2.0, 1.0], atol=1e-6)
    assert np.allclose(q_factor[:S][far_bottom[:S]], 1.0, atol=1e-6)
    assert np.allclose(M_d[far_bottom & (np.arange(rest.count) < S)], 0.25, atol=1e-6)
    assert (M_d >= 0.25).all() and (M_d <= 1.0).all()
    # Near the centre, between the two painted halves, the blur is between theirs (the mean is 0.625).
    centre = (np.arange(rest.count) >= S) & (np.abs(z) < 1.0) & (np.linalg.norm(rest.positions_mm, axis=1) < 5.0)
    assert centre.sum() > 3 and ((M_d[centre] > 0.45) & (M_d[centre] < 0.8)).all(), M_d[centre]
    kappa, mu = qgd.node_material(rest.positions_mm, (0.01,) * 3, (1.0,) * 3, M_d=M_d)
    k1, mu1 = qgd.node_material(rest.positions_mm, (0.01,) * 3, (1.0,) * 3)
    assert np.allclose(kappa / k1, 1.0 / M_d[:, None]) and np.allclose(mu / mu1, M_d[:, None])


def test_a_point_over_a_needle_triangle_stays_put_when_the_needle_barely_moves():
    """The embedding's frame and length come from vertex normals and the mean edge, not from the triangle's
    own normal and area: a needle does not blow its offset up."""
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1e-4, 0.0], [0.5, -1.0, 0.0]])
    f = np.array([[0, 1, 2], [0, 3, 1]])  # a needle beside a fat triangle, one plane
    p = np.array([[0.5, 0.00005, 0.3]])
    e = vd.embed(p, v, f)
    assert np.allclose(vd.place(e, v, f), p, atol=1e-12)
    moved = v.copy()
    moved[2, 1] += 1e-3  # the needle's apex moves by 1e-3
    assert np.abs(vd.place(e, moved, f) - p).max() < 1e-2

"""TEXTURE_SPACE's far field (``techniques/texture_space/far_field.py``), pure: the hierarchy and its partition."""
from __future__ import annotations

import numpy as np
import pytest

from translucent_addon.core.data import DATA
from translucent_addon.core.geometry.mesh_io import load_npz
from translucent_addon.core.geometry.mesh_measures import vertex_areas, vertex_normals
from translucent_addon.techniques.texture_space import far_field
from translucent_addon.techniques.texture_space.throughput import ACROSS_REACH


@pytest.fixture(scope="module")
def cow():
    v, t = load_npz(DATA / "meshes" / "cow.npz")
    v = (v - v.min(axis=0)) * (100.0 / np.ptp(v, axis=0).max())  # 10 cm, in mm
    A_v = vertex_areas(v, t)
    return v, t, A_v, far_field.build(v, vertex_normals(v, t), A_v, near_mm=ACROSS_REACH * np.sqrt(A_v))


def test_levels_nest_and_their_weights_add_up(cow):
    v, t, A_v, h = cow
    assert h.levels >= 3 and len(h.W[-1]) <= far_field.TOP_CLUSTERS
    for level in range(h.levels):
        np.testing.assert_allclose(h.W[level].sum(), A_v.sum() / 3.0, rtol=1e-12)
        members = np.linalg.norm(v - h.x[level][h.of[level]], axis=1)
        assert np.all(members <= h.rho[level][h.of[level]] + 1e-9)
        if level:  # every cluster lies inside one cluster of the next level
            parents = np.full(len(h.W[level - 1]), -1)
            parents[h.of[level - 1]] = h.of[level]
            assert np.array_equal(parents[h.of[level - 1]], h.of[level])
    slots = h.slots()
    assert slots.shape == (len(v), h.levels) and slots.max() + 1 == h.count
    assert len(np.unique(slots)) == h.count  # no slot shared between levels


def test_every_source_reaches_every_receiver_exactly_once(cow):
    """The receiver's near vertices and the members of its far clusters are all the other vertices, once each;
    no far cluster comes nearer than its members' near reach or its opening radius."""
    v, t, A_v, h = cow
    V = len(v)
    (near_dst, near_src), (far_dst, far_level, far_cluster) = far_field.interactions(h, v)
    count = np.bincount(near_dst * V + near_src, minlength=V * V).astype(np.int64)
    for level in range(h.levels):
        at = far_level == level
        size = np.bincount(h.of[level], minlength=len(h.W[level]))
        order = np.argsort(h.of[level], kind="stable")
        start = np.concatenate([[0], np.cumsum(size)])
        for j, P in zip(far_dst[at], far_cluster[at]):
            count[j * V + order[start[P]:start[P + 1]]] += 1
        d = np.linalg.norm(v[far_dst[at]] - h.x[level][far_cluster[at]], axis=1)
        assert np.all(d > h.rho[level][far_cluster[at]] * (1.0 + 1.0 / far_field.THETA))
        assert np.all(d > h.near[level][far_cluster[at]])
    expected = np.ones((V, V), np.int64)
    np.fill_diagonal(expected, 0)
    np.testing.assert_array_equal(count.reshape(V, V), expected)
    assert len(near_dst) < 0.2 * V * V  # most sources come through clusters


def test_a_far_entry_is_the_mean_of_its_childrens_profile(cow):
    """Level 0's entries are exact (its children are its vertices): G_jP W_P = sum_(i in P) A_i / 3 R_d C."""
    from translucent_addon.core.physics import slab_through
    from translucent_addon.core.physics.presets import load_presets
    from translucent_addon.techniques.texture_space.throughput import Material

    v, t, A_v, h = cow
    m = load_presets()["marble"]
    material = Material(tuple(m.sigma_a), tuple(m.sigma_s_prime), 1.0)
    n = vertex_normals(v, t)
    _, (far_dst, far_level, far_cluster) = far_field.interactions(h, v)
    pick = np.flatnonzero(far_level == 0)[::997][:40]
    G, _ = far_field.far_weights(h, v, n, A_v, material, far_dst[pick], far_level[pick], far_cluster[pick])
    slab = slab_through.constants(material.sigma_a, material.sigma_s_prime, material.eta)
    for k, (j, P) in enumerate(zip(far_dst[pick], far_cluster[pick])):
        i = np.flatnonzero(h.of[0] == P)
        r = np.linalg.norm(v[i] - v[j], axis=1)
        f = A_v[i, None] / 3.0 * material.R_d(r) * slab_through.factor((v[j] - v[i]) @ n[j], *slab)
        np.testing.assert_allclose(G[k] * h.W[0][P], f.sum(axis=0), rtol=1e-6)


def test_a_loose_vertex_without_area_leaves_every_entry_finite():
    """A vertex no triangle uses (A_v = 0) makes clusters of no power: their entries are zero, not 0 / 0."""
    from translucent_addon.core.physics.presets import load_presets
    from translucent_addon.techniques.texture_space import throughput

    x = np.linspace(0.0, 40.0, 21)
    X, Y = np.meshgrid(x, x)
    v = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)
    idx = np.arange(len(v)).reshape(21, 21)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    t = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    v = np.concatenate([v, [[200.0, 200.0, 50.0]]])  # far from everything, in a cluster of its own
    A_v = vertex_areas(v, t)
    assert A_v[-1] == 0.0
    m = load_presets()["marble"]
    material = throughput.Material(tuple(m.sigma_a), tuple(m.sigma_s_prime), 1.0)
    (indptr, indices, data), _, far = throughput.throughput(v, A_v, material, triangles=t)
    assert np.isfinite(data).all() and np.isfinite(far.data).all() and len(far.indices) > 0

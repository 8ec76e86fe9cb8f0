"""TEXTURE_SPACE precomputation (Lensch 2002), pure: atlas, proxy, kernels, throughput, blending."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from translucent_addon.core import bake_store as store
from translucent_addon.core.geometry.mesh_measures import vertex_areas
from translucent_addon.core.physics.lut import profile_model
from translucent_addon.core.physics.presets import load_presets
from translucent_addon.techniques import registry
from translucent_addon.techniques.texture_space import model as tsd
from translucent_addon.techniques.texture_space import proxy
from translucent_addon.techniques.texture_space import throughput as lensch
from translucent_addon.techniques.texture_space.atlas import build_atlas, rasterize, texel_mm
from translucent_addon.techniques.texture_space.bake import BakeParameters

SKIN = load_presets()["skin1"]
MATERIAL = lensch.Material(tuple(SKIN.sigma_a), tuple(SKIN.sigma_s_prime), SKIN.eta)  # the exact profile
total_diffuse_reflectance = profile_model(MATERIAL.profile).total_diffuse_reflectance


def plate(n: int, size_mm: float = 100.0):
    x = np.linspace(-size_mm / 2, size_mm / 2, n + 1)
    X, Y = np.meshgrid(x, x)
    v = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return v, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def sphere(radius_mm: float = 40.0, rings: int = 16, segments: int = 32):
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    T, P = np.meshgrid(theta, phi, indexing="ij")
    v = np.concatenate([[[0, 0, radius_mm]], np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)],
                                                        -1).reshape(-1, 3) * radius_mm, [[0, 0, -radius_mm]]])
    f = []
    ring = lambda i, j: 1 + i * segments + j % segments  # noqa: E731
    for j in range(segments):
        f.append((0, ring(0, j), ring(0, j + 1)))
        f.append((len(v) - 1, ring(rings - 2, j + 1), ring(rings - 2, j)))
        for i in range(rings - 2):
            f += [(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)), (ring(i, j), ring(i + 1, j + 1), ring(i, j + 1))]
    return v, np.array(f)


def baked(v, f, resolution, blend=True, material=MATERIAL):
    atlas = build_atlas(v, f, resolution)
    job = lensch.precompute(atlas, v, f, material, blend=blend)
    try:
        while True:
            next(job)
    except StopIteration as done:
        return atlas, done.value


@pytest.fixture(scope="module")
def plate_bake():
    v, f = plate(50)  # 2 mm edges, texels of about 0.55 mm: Lensch's ratio
    return (v, f) + baked(v, f, 256)


def test_rasterize_covers_each_texel_centre_once_and_inside_its_triangle():
    uv = np.array([[[0.2, 0.3], [9.7, 0.4], [0.3, 9.6]], [[9.7, 0.4], [9.8, 9.9], [0.3, 9.6]]], np.float32)
    xy, tri, bary = rasterize(uv, 10, 10)
    assert len(np.unique(xy[:, 1] * 10 + xy[:, 0])) == len(xy)
    centre = xy + 0.5
    back = np.einsum("nk,nkd->nd", bary, uv[tri].astype(np.float64))
    np.testing.assert_allclose(back, centre, atol=1e-5)
    assert 80 <= len(xy) <= 100  # the square [0.3, 9.7]^2 holds the centres 0.5 .. 9.5 (minus a rim)


def test_atlas_texels_lie_on_the_surface_and_their_areas_add_up():
    v, f = sphere()
    atlas = build_atlas(v, f, 256)
    n = atlas.surface_count
    radius = np.linalg.norm(atlas.position_mm[:n], axis=1)
    assert radius.max() <= 40.0 + 1e-3 and radius.min() > 40.0 * np.cos(np.pi / 16) - 1e-3  # on the facets
    area = proxy.surface_area(v, f)
    assert abs(atlas.area_mm2[:n].sum() / area - 1.0) < 0.02
    # Border texels: a closed sphere has surface across every seam, so most find a source nearby.
    border = atlas.count - n
    assert border > 0.5 * 4 * np.sqrt(n)
    assert np.all(atlas.source[n:] < n)


def test_texels_carry_the_normal_field_s_curvature_into_object_space():
    """Light entering at an angle is read where it entered (``oblique_entry``), from each texel's shape operator:
    on a 40 mm sphere with smooth normals it is I / R in the tangent plane (trace 2 / R, the normal its null
    direction) within 5 % in the median texel; in object space, for an object stretched by 2 along x with 1000 mm
    to its unit, what the normal does along p is what it does along x = S p mm (finite differences on the
    mapped field)."""
    from translucent_addon.core.geometry.mesh_measures import vertex_normals
    from translucent_addon.techniques.texture_space.bake import proxy_corner_curvature, texel_curvature

    R = 40.0
    v, f = sphere(R, rings=24, segments=48)
    normals = vertex_normals(v, f)[f]
    atlas = build_atlas(v, f, 256, normals)
    packed = texel_curvature(atlas, proxy_corner_curvature(v, f, normals, v, f, normals, None))
    # Normals as the bake has them for a scaled object (turned by S^-T, not of unit length): the same field.
    scaled = texel_curvature(atlas, proxy_corner_curvature(v, f, 8.0 * normals, v, f, 8.0 * normals, None))
    np.testing.assert_allclose(scaled, packed, rtol=1e-5, atol=1e-7)
    n = atlas.surface_count
    assert packed.shape == (atlas.count, 6) and packed.dtype == np.float32
    trace = packed[:n, :3].sum(axis=1)
    assert abs(np.median(trace) * R / 2.0 - 1.0) < 0.05
    S = np.zeros((n, 3, 3))
    S[:, [0, 1, 2], [0, 1, 2]] = packed[:n, :3]
    S[:, [0, 0, 1], [1, 2, 2]] = packed[:n, 3:]
    S[:, [1, 2, 2], [0, 0, 1]] = packed[:n, 3:]
    along_normal = np.linalg.norm(np.einsum("nij,nj->ni", S, atlas.normal[:n]), axis=1)
    assert np.median(along_normal) * R < 0.02
    assert tsd.object_curvature(None, atlas.normal, np.eye(3), 1.0).shape == (atlas.count, 6)
    assert not tsd.object_curvature(None, atlas.normal, np.eye(3), 1.0).any()  # an old bake: no shift
    # Object space: x = S p mm, n_p ~ S^T n. The field n(x) = x / R on the sphere, mapped, differentiated.
    stretch, mm = np.diag([2.0, 1.0, 1.0]), 1000.0
    k = int(np.argmin(np.abs(atlas.normal[:n] @ np.array([0.6, 0.0, 0.8]) - 1.0)))  # a texel off every axis
    S_p = tsd.object_curvature(packed[k:k + 1], atlas.normal[k:k + 1], stretch, mm)[0]
    S_p = np.array([[S_p[0], S_p[3], S_p[4]], [S_p[3], S_p[1], S_p[5]], [S_p[4], S_p[5], S_p[2]]])
    x0 = atlas.position_mm[k].astype(np.float64)
    p0 = np.linalg.solve(stretch, x0) / mm

    def n_p(p):
        x = stretch @ p * mm
        n = stretch.T @ (x / np.linalg.norm(x))
        return n / np.linalg.norm(n)

    t = np.cross(n_p(p0), [0.0, 1.0, 0.0])
    t /= np.linalg.norm(t)  # a direction in the object's tangent plane
    t = t - n_p(p0) * (n_p(p0) @ t)
    h = 1e-7
    numeric = (n_p(p0 + h * t) - n_p(p0 - h * t)) / (2 * h)
    np.testing.assert_allclose(S_p @ t, numeric, rtol=0.08, atol=0.02 * np.linalg.norm(numeric))


def test_gather_conserves_the_irradiance_integral(plate_bake):
    """sum_v E^g_v A_v / 3 = sum_texels A E exactly: sum_v (4 beta_v - 1) = 1 (Lensch Eq. 10)."""
    v, f, atlas, bake = plate_bake
    n = atlas.surface_count
    E = np.random.default_rng(3).uniform(0.0, 2.0, n)
    E_g = np.bincount(bake.dual_vertices.ravel(), weights=(bake.dual_weights * E[:, None]).ravel(),
                      minlength=len(bake.A_v))
    np.testing.assert_allclose((E_g * bake.A_v / 3.0).sum(), (atlas.area_mm2[:n] * E).sum(), rtol=1e-5)


def _product(v, A_v, near, far, E):
    """F^0 E + G E_P (V, 3) from ``throughput``'s two parts."""
    indptr, indices, data = near
    bake = lensch.LenschBake(A_v=A_v, dual_vertices=None, dual_weights=None, blend_weights=None, kernel_taps=None,
                             kernels=None, F_indptr=indptr, F_indices=indices, F_data=data, G_indptr=far.indptr,
                             G_indices=far.indices, G_data=far.data, clusters=far.clusters)
    B = lensch.global_product(lensch.throughput_matrices(indptr, indices, data), E, np.zeros((len(v), 3)))
    return B + lensch.far_product(bake.far_matrices(), bake.cluster_power(E))


def _dense(v, A_v, normals=None):
    """Every pair's A_i / 3 R_d C [i, j], no threshold, no diagonal."""
    from translucent_addon.core.physics import slab_through

    r = np.linalg.norm(v[:, None] - v[None], axis=2)
    dense = (A_v[:, None, None] / 3.0) * MATERIAL.R_d_exact(r.ravel()).reshape(len(v), len(v), 3)
    if normals is not None:
        h = np.einsum("ijd,jd->ij", v[None, :] - v[:, None], normals)  # depth of i below j's tangent plane
        dense *= slab_through.through_factor(h.ravel(), SKIN.sigma_a, SKIN.sigma_s_prime, SKIN.eta).reshape(
            len(v), len(v), 3)
    for c in range(3):
        np.fill_diagonal(dense[..., c], 0)
    return dense


def test_near_pairs_and_far_clusters_carry_every_pair_of_the_dense_matrix():
    """Near pairs one by one and far sources by cluster (``far_field``): under uniform light and a smooth one
    the product is the dense matrix's, every pair included, within 0.5 %; the near part alone is a small
    share of the pairs."""
    v, f = plate(24, 60.0)
    A_v = vertex_areas(v, f)
    near, _, far = lensch.throughput(v, A_v, MATERIAL)
    dense = _dense(v, A_v)
    assert len(near[1]) < 0.3 * len(v) ** 2 and len(far.indices) > 0
    for E in (np.ones((len(v), 3)), np.exp(v[:, :1] / 30.0) * np.array([1.0, 0.5, 0.25])):
        np.testing.assert_allclose(_product(v, A_v, near, far, E),
                                   np.einsum("ijc,ic->jc", dense, E), rtol=5e-3)


def test_light_straight_through_a_part_reaches_the_far_face():
    """Two 30 mm plates 22 mm apart facing away from each other (a thick part, skin1), the bottom one lit: what
    reaches the top plate is the dense matrix's (C of ``slab_through`` included) within 2 %, where the pairs above
    Lensch's threshold carried 64 % of the red (86 %, 95 % of green and blue, which ride on red's entries)."""
    from translucent_addon.core.geometry.mesh_measures import vertex_normals

    gap = 22.0
    top, f = plate(12, 30.0)
    bottom = top - [0.0, 0.0, gap]
    v = np.concatenate([top, bottom])
    tris = np.concatenate([f, f[:, ::-1] + len(top)])  # the bottom faces down
    A_v = vertex_areas(v, tris)
    near, _, far = lensch.throughput(v, A_v, MATERIAL, triangles=tris)
    dense = _dense(v, A_v, vertex_normals(v, tris))
    E = np.zeros((len(v), 3))
    E[len(top):] = 1.0
    B = _product(v, A_v, near, far, E)[:len(top)]
    exact = np.einsum("ijc,ic->jc", dense, E)[:len(top)]
    assert exact.min() > 0.0
    np.testing.assert_allclose(B, exact, rtol=0.02)
    thresholded = np.where(dense.max(axis=2, keepdims=True) >= lensch.THRESHOLD, dense, 0.0)
    kept = np.einsum("ijc,ic->jc", thresholded, E)[:len(top)].sum(axis=0) / exact.sum(axis=0)
    assert kept[0] < 0.7  # 0.64 / 0.86 / 0.95


def test_inside_the_kernel_local_plus_global_is_the_kernel(plate_bake):
    """After the correction of Sec. 5.4, an impulse's response in its 7x7 window is exactly A R_d."""
    v, f, atlas, bake = plate_bake
    n = atlas.surface_count
    centre = np.argmin(np.linalg.norm(atlas.position_mm[:n], axis=1))
    E = np.zeros((atlas.count, 3))
    E[centre] = 1.0
    E[n:] = E[atlas.source[n:]]
    B = lensch.radiosity(atlas, bake, E)
    window = lensch._taps(atlas, np.array([centre]), lensch.LOCAL_OFFSETS)[0]
    assert (window >= 0).all() and (window < n).all()
    J = lensch.texel_jacobians(atlas, v, f)
    for k, o in enumerate(window):
        if o == centre:
            continue
        ring = int(np.max(np.abs(lensch.LOCAL_OFFSETS[k])))
        exact = atlas.area_mm2[centre] * lensch._profile_texel(atlas, MATERIAL, J, np.array([o]), np.array([centre]),
                                                               lensch.SUBTEXELS.get(ring, 1))[0]
        np.testing.assert_allclose(B[o], exact, rtol=2e-3, atol=1e-6 * exact.max())


def test_a_source_across_a_seam_enters_a_kernel_once():
    """Across a sharp crease several gutter taps of a kernel can find the same source on the other
    side. That source's light enters the kernel once: an impulse there gives A_s R_d at the texel,
    as inside a chart, not that times the number of taps holding it."""
    v, f = plate(30)
    v[:, 2] = -3.0 * np.abs(v[:, 0])  # a ridge of 37 degrees along x = 0: the atlas cuts it
    atlas, bake = baked(v, f, 128)
    n = atlas.surface_count
    repeated = lensch.repeated_sources(atlas, bake.kernel_taps)
    rows = np.flatnonzero(repeated.any(axis=1))
    assert len(rows) > 5, "the crease gives kernels with a source in several gutter taps"
    assert np.all(bake.kernels[repeated] == 0.0)
    J = lensch.texel_jacobians(atlas, v, f)
    for o in rows[:6]:
        k_rep = np.flatnonzero(repeated[o])[0]
        s_src = atlas.source[bake.kernel_taps[o, k_rep]]
        taps = bake.kernel_taps[o]
        kept = [k for k in range(len(taps)) if taps[k] >= 0 and atlas.source[taps[k]] == s_src and not repeated[o, k]]
        assert len(kept) == 1
        E = np.zeros((atlas.count, 3))
        E[s_src] = 1.0
        E[n:] = E[atlas.source[n:]]
        B = lensch.radiosity(atlas, bake, E)
        ring = int(np.max(np.abs(lensch.LOCAL_OFFSETS[kept[0]])))
        exact = atlas.area_mm2[s_src] * lensch._profile_texel(atlas, MATERIAL, J, np.array([o]), taps[kept],
                                                             lensch.SUBTEXELS.get(ring, 1))[0]
        np.testing.assert_allclose(B[o], exact, rtol=2e-3, atol=1e-6 * exact.max())


def test_the_uniform_light_gain_leaves_the_far_response_alone(plate_bake):
    """The calibration scales only a vertex's one-ring entries of F^0 (and B^d): light from farther
    away keeps Lensch's point rule A_i / 3 R_d(|v_i - v_j|) exactly."""
    v, f, atlas, bake = plate_bake
    V = len(v)
    rows = np.repeat(np.arange(V), np.diff(bake.F_indptr))
    near = lensch.edge_entries(f, bake.F_indptr, bake.F_indices)
    assert near.any() and (~near).any()
    r = np.linalg.norm(v[bake.F_indices] - v[rows], axis=1)
    point_rule = bake.A_v[bake.F_indices, None].astype(np.float64) / 3.0 * MATERIAL.R_d(r)
    np.testing.assert_allclose(bake.F_data[~near], point_rule[~near], rtol=1e-5)
    gain = bake.F_data[near] / point_rule[near]
    assert np.abs(gain - 1.0).max() > 0.01, "the one-ring carries the calibration"


def test_uniform_light_on_a_plate_gives_the_total_diffuse_reflectance(plate_bake):
    """B = R_dt (the profile's total; Jensen Eq. 6 for the dipole) far from the edges: +1..2 % after the
    uniform-light calibration (+2..5 % before it: the hats overshoot the convex R_d)."""
    v, f, atlas, bake = plate_bake
    B = lensch.radiosity(atlas, bake, np.ones((atlas.count, 3)))
    centre = np.linalg.norm(atlas.position_mm[:atlas.surface_count, :2], axis=1) < 25.0
    ratio = np.median(B[centre], axis=0) / total_diffuse_reflectance(
        np.array(SKIN.sigma_a), np.array(SKIN.sigma_s_prime), SKIN.eta)
    assert np.all(np.abs(ratio - 1.0) < 0.04), ratio


def test_without_blending_light_is_counted_twice():
    """Lensch Fig. 6 (middle): local kernels plus the full F add up to far more than R_dt."""
    v, f = plate(30, 60.0)
    atlas, bake = baked(v, f, 160, blend=False)
    B = lensch.radiosity(atlas, bake, np.ones((atlas.count, 3)))
    centre = np.linalg.norm(atlas.position_mm[:atlas.surface_count, :2], axis=1) < 15.0
    ratio = np.median(B[centre], axis=0) / total_diffuse_reflectance(
        np.array(SKIN.sigma_a), np.array(SKIN.sigma_s_prime), SKIN.eta)
    assert np.all(ratio > 1.4), ratio


def _edges(v, f):
    return np.concatenate([np.linalg.norm(v[f[:, (k + 1) % 3]] - v[f[:, k]], axis=1) for k in range(3)])


def _min_angles(p):
    out = []
    for k in range(3):
        a, b = p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]
        cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        out.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return np.min(out, axis=0)


def test_refinement_splits_long_edges_evenly_and_keeps_the_surface():
    """A coarse, uneven mesh (a UV sphere stretched 3x: long edges at the equator, short at the poles)
    is refined until no edge passes the spacing's bound in atlas texels, conforming, on the same surface,
    with bounded angles; its corners carry the display's attributes by barycentrics."""
    v, f = sphere()
    v = v * np.array([3.0, 1.0, 1.0])
    area = proxy.surface_area(v, f)
    r = proxy.refine_for_atlas(v, f, 256)
    texel = texel_mm(area, 256)
    lengths = _edges(r.vertices, r.triangles)
    assert lengths.max() <= proxy.SPACING_TEXELS * proxy.MAX_EDGE_RATIO * texel * (1 + 1e-9)
    assert lengths.max() < 2.5 * np.median(lengths)  # even: subdivision 1-to-4 keeps the input's 3x spread
    assert len(f) < len(r.triangles) < proxy.MAX_TRIANGLES  # not capped: the bound above is the edge's
    assert abs(proxy.surface_area(r.vertices, r.triangles) - area) < 1e-9 * area  # midpoints stay on the facets
    edges = np.sort(np.concatenate([r.triangles[:, [0, 1]], r.triangles[:, [1, 2]], r.triangles[:, [2, 0]]]), axis=1)
    _, count = np.unique(edges, axis=0, return_counts=True)
    assert np.all(count == 2), "conforming: every edge of the closed sphere is shared by two triangles"
    np.testing.assert_allclose(r.corners(v[f].reshape(-1, 3)).reshape(-1, 3, 3), r.vertices[r.triangles], atol=1e-9)
    n0 = np.cross(v[f][:, 1] - v[f][:, 0], v[f][:, 2] - v[f][:, 0])[r.parent]
    p = r.vertices[r.triangles]
    assert np.all(np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), n0) > 0), "winding kept"
    assert _min_angles(p).min() >= 0.5 * _min_angles(v[f]).min()  # longest-edge bisection bounds the angles
    assert proxy.target_triangles(area, 4096) == proxy.MAX_TRIANGLES


def test_a_finer_proxy_spacing_refines_and_decimates_to_shorter_edges():
    """Proxy spacing 2.5 instead of 3.5 texels: refined edges bounded 2.5/3.5 as long, Blender's decimation
    target (3.5/2.5)^2 = 1.96 times the triangles; and the bake goes stale."""
    v, f = sphere()
    area = proxy.surface_area(v, f)
    texel = texel_mm(area, 256)
    coarse, fine = proxy.refine_for_atlas(v, f, 256), proxy.refine_for_atlas(v, f, 256, spacing=2.5)
    assert _edges(fine.vertices, fine.triangles).max() <= 2.5 * proxy.MAX_EDGE_RATIO * texel * (1 + 1e-9)
    assert _edges(coarse.vertices, coarse.triangles).max() > 2.5 * proxy.MAX_EDGE_RATIO * texel
    assert len(fine.triangles) > len(coarse.triangles)  # by bisection steps: here 12.9k against 11.0k
    ratio = proxy.target_triangles(area, 512, 2.5) / proxy.target_triangles(area, 512)
    assert ratio == pytest.approx((3.5 / 2.5) ** 2, rel=0.01)
    inputs = registry.BakeInputs(name="s", method="TEXTURE_SPACE", vertices=v.astype(np.float32),
                                 triangles=f.astype(np.int32), mm_per_unit=1.0, sigma_a=(0.1,) * 3,
                                 sigma_s_prime=(1.0,) * 3, eta=1.3, g=0.0)
    assert inputs.hash() != dataclasses.replace(inputs, params=BakeParameters(proxy_spacing=2.5)).hash()


def test_an_atlas_whose_kernels_would_not_fit_the_gpu_table_is_refused(monkeypatch):
    """The kernel table holds KERNEL_TEXELS_MAX texels (5.4M surface texels of 49 taps); here made small so that
    a 64-texel atlas of a sphere passes it: one line naming the setting to lower, nothing baked."""
    v, f = sphere()
    inputs = registry.BakeInputs(name="Ball", method="TEXTURE_SPACE", vertices=v.astype(np.float32),
                                 triangles=f.astype(np.int32), mm_per_unit=1.0, sigma_a=(0.1,) * 3,
                                 sigma_s_prime=(1.0,) * 3, eta=1.3, g=0.0,
                                 params=BakeParameters(atlas_resolution=64))
    monkeypatch.setattr(tsd, "KERNEL_TEXELS_MAX", 49 * 100)
    with pytest.raises(registry.BakeInputError, match=r"'Ball': the atlas at 64 texels has [\d,]+ surface texels; "
                                                      r"the GPU's kernel table holds 100: lower Atlas resolution"):
        for _ in registry.run(inputs):
            pass


def test_refinement_caps_the_triangle_count():
    v, f = sphere()
    r = proxy.refine_for_atlas(v, f, 4096)
    assert 0.5 * proxy.MAX_TRIANGLES < len(r.triangles) <= proxy.MAX_TRIANGLES


def test_texels_take_the_corner_normals_they_are_given():
    """The atlas interpolates the shading normals it is given per corner: flat-shaded corners give
    every texel its facet's normal; none gives the smooth vertex normals."""
    v, f = sphere(rings=8, segments=12)
    p = v[f]
    facet = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    facet /= np.linalg.norm(facet, axis=1, keepdims=True)
    flat = build_atlas(v, f, 128, np.repeat(facet[:, None, :], 3, axis=1))
    np.testing.assert_allclose(flat.normal, facet[flat.triangle], atol=1e-6)
    smooth = build_atlas(v, f, 128)
    assert np.median(np.einsum("ij,ij->i", smooth.normal, facet[smooth.triangle])) < 0.9999


def test_a_decimated_proxy_takes_the_display_normal_on_its_own_side():
    """A proxy vertex of a thin part can lie nearer the far side's display vertices; it takes the
    nearest display normal that faces its own way."""
    top = np.array([[-1, -1, 0.3], [1, -1, 0.3], [0, 1, 0.3]], float)
    bottom = top * [1, 1, 0] + [0, 0, -0.1]
    display_v = np.concatenate([top, bottom])
    display_t = np.array([[0, 1, 2], [3, 5, 4]])
    up, down = np.array([0, 0, 1.0]), np.array([0, 0, -1.0])
    display_n = np.stack([np.tile(up, (3, 1)), np.tile(down, (3, 1))])
    proxy_v = top * [1, 1, 0]  # the mid plane, nearer the bottom
    n = proxy.transfer_normals(display_v, display_t, display_n, proxy_v, np.array([[0, 1, 2]]))
    np.testing.assert_allclose(n, np.tile(up, (3, 1)))


def test_display_mapping_of_the_proxy_itself_is_the_identity():
    v, f = sphere()
    tri, bary = proxy.display_mapping(v, f, v, f)
    np.testing.assert_array_equal(tri, np.repeat(np.arange(len(f)), 3))
    np.testing.assert_allclose(bary, np.tile(np.eye(3), (len(f), 1)), atol=1e-6)


def test_float16_tables_survive_the_store():
    a = np.random.default_rng(0).normal(size=(7, 49, 3)).astype(np.float16)
    idblock = {}
    store.write(idblock, "TEXTURE_SPACE", "h", {"k": a, "odd": a[:1, :1, :1]})
    rec = store.read(idblock, "TEXTURE_SPACE")
    np.testing.assert_array_equal(rec.arrays["k"], a)
    assert rec.arrays["odd"].shape == (1, 1, 1) and rec.arrays["odd"].dtype == np.float16
    assert store.read_meta(idblock, "TEXTURE_SPACE") == {} and store.read_meta(idblock, "QUADGRAPH") is None


def test_gpu_tables_wrap_every_entry_where_the_shaders_look(plate_bake):
    v, f, atlas, bake = plate_bake
    arrays = {**atlas.to_arrays(), **bake.to_arrays(), "proxy_triangles": f.astype(np.int32),
              "proxy_vertices_mm": v.astype(np.float32),
              "display_uv": np.zeros((3 * len(f), 2), np.float32), "vertex_corner": np.zeros(len(v), np.int32)}
    arrays["lensch_kernels"] = bake.kernels.astype(np.float16)
    t = tsd.gpu_tables(arrays, 1000.0)
    assert t.local_half == lensch.LOCAL
    # Each texel's facet: its proxy triangle's normal, on the side of its shading normal.
    p = v[f[atlas.triangle]]
    facet = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    facet /= np.linalg.norm(facet, axis=1, keepdims=True)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", t.facet, facet)), 1.0, atol=1e-5)
    assert np.all(np.einsum("ij,ij->i", t.facet, t.normal) > 0)
    e = 123 * 49 + 17
    assert t.kernels.shape[1] == tsd.KERNEL_WIDTH
    np.testing.assert_array_equal(t.kernels[e // tsd.KERNEL_WIDTH, e % tsd.KERNEL_WIDTH, :3],
                                  bake.kernels[123, 17].astype(np.float16))
    j = 77
    hi, lo = t.F_indptr[j // tsd.TABLE_WIDTH, j % tsd.TABLE_WIDTH]
    assert hi * tsd.ROW_SPLIT + lo == bake.F_indptr[j] + bake.G_indptr[j]
    # Row j walks its F^0 entries, then its far clusters as sources past the vertices (``ts_product``).
    indptr, indices, data = tsd.merged_rows(bake)
    F_row, G_row = slice(*bake.F_indptr[j:j + 2]), slice(*bake.G_indptr[j:j + 2])
    assert bake.G_indptr[j + 1] > bake.G_indptr[j]
    np.testing.assert_array_equal(indices[indptr[j]:indptr[j + 1]],
                                  np.concatenate([bake.F_indices[F_row], bake.G_indices[G_row] + len(v)]))
    np.testing.assert_array_equal(data[indptr[j]:indptr[j + 1], :3], np.concatenate([bake.F_data[F_row],
                                                                                      bake.G_data[G_row]]))
    np.testing.assert_array_equal(data[indptr[j]:indptr[j + 1], 3], np.concatenate([bake.F_depth[F_row],
                                                                                     bake.G_depth[G_row]]))
    assert t.cluster_count == bake.cluster_count > 0 and len(t.cluster_points[1]) == bake.clusters.size
    # Row starts past 2^24 (a float's exact integers) still come back exactly from two float32 halves.
    starts = np.array([0, 4095, 4096, (1 << 24) + 1, tsd.GPU_PRODUCT_LIMIT - 1], np.int64)
    halves = tsd.split_rows(starts).astype(np.float32)
    np.testing.assert_array_equal(halves[:, 0].astype(np.int64) * tsd.ROW_SPLIT + halves[:, 1].astype(np.int64),
                                  starts)
    assert t.vertex_size[0] * t.vertex_size[1] >= len(v)


@pytest.fixture(scope="module")
def stored_sphere():
    """A TEXTURE_SPACE bake of a small sphere as the registry makes and stores it (xatlas in a child)."""
    v, f = sphere(radius_mm=20.0, rings=8, segments=12)
    inputs = registry.BakeInputs(name="s", method="TEXTURE_SPACE", vertices=v.astype(np.float32),
                                 triangles=f.astype(np.int32), mm_per_unit=1.0, sigma_a=(0.01,) * 3,
                                 sigma_s_prime=(1.0,) * 3, eta=1.3, g=0.0,
                                 params=BakeParameters(atlas_resolution=64))
    job = registry.run(inputs)
    try:
        while True:
            next(job)
    except StopIteration as done:
        return done.value[0]


def _damaged(arrays, name, at, value):
    a = dict(arrays)
    a[name] = np.array(a[name])
    a[name][at] = value
    return a


@pytest.mark.parametrize("name, at, value, why", [
    ("lensch_F_indices", 3, 2_000_000_000, r"'lensch_F_indices' holds indices outside \[0, "),
    ("lensch_F_indices", -1, -2_000_000_000, r"'lensch_F_indices' holds indices outside \[0, "),
    ("lensch_F_indptr", 5, 2**31 - 2, r"'lensch_F_indptr' holds indices outside"),
    ("lensch_F_indptr", 5, 0, r"'lensch_F_indptr' does not point at rows of .* entries in order"),
    ("lensch_G_indices", 3, 2_000_000_000, r"'lensch_G_indices' holds indices outside \[0, "),
    ("lensch_G_indptr", 5, 2**31 - 2, r"'lensch_G_indptr' holds indices outside"),
    ("lensch_clusters", (0, 0), -5, r"'lensch_clusters' holds indices outside \[0, "),
    ("proxy_triangles", (0, 1), 10**6, r"'proxy_triangles' holds indices outside"),
    ("atlas_source", 0, -1, r"'atlas_source' holds indices outside"),
    ("atlas_shape", 0, 10**6, r"its atlas width is 1000000, outside \[1, 16384\]"),
])
def test_a_stored_bake_whose_indices_do_not_fit_is_refused_before_scipy_or_the_gpu(stored_sphere, name, at, value,
                                                                                     why):
    """Issue 37: ``lensch_F_indices`` of 2e9 or a row pointer near 2^31 crashed Blender inside SciPy's compiled
    product (a bake with a rewritten data hash, or one from before it, reaches it). ``load`` checks every index
    first; both the GPU tables and the CPU product go through it."""
    tsd.check(stored_sphere)  # as baked
    damaged = _damaged(stored_sphere, name, at, value)
    with pytest.raises(store.DamagedBakeError, match=why):
        tsd.load(damaged)
    with pytest.raises(store.DamagedBakeError, match=why):
        tsd.gpu_tables(damaged, 1.0)


def test_the_light_that_crossed_a_part_is_told_apart_from_the_light_that_came_back():
    """``through_share``: on the two plates 22 mm apart, lit below, what reaches the top plate crossed the part
    (B^t = B there), and what the lit plate sends back to itself did not (B^t = 0 there). The display sends B^t out
    by the diffusion mode's law M and the rest by the angular law a."""
    from translucent_addon.core.physics import slab_through
    from translucent_addon.core.physics.angular_law import nodes, through_constants, through_exit, through_exit_table

    top, f = plate(12, 30.0)
    v = np.concatenate([top, top - [0.0, 0.0, 22.0]])
    tris = np.concatenate([f, f[:, ::-1] + len(top)])
    A_v = vertex_areas(v, tris)
    (indptr, indices, data), depth, far = lensch.throughput(v, A_v, MATERIAL, triangles=tris)
    z_r = slab_through.constants(SKIN.sigma_a, SKIN.sigma_s_prime, SKIN.eta)[1]
    bake = lensch.LenschBake(A_v=A_v, dual_vertices=None, dual_weights=None, blend_weights=None, kernel_taps=None,
                             kernels=None, F_indptr=indptr, F_indices=indices, F_data=data, G_indptr=far.indptr,
                             G_indices=far.indices, G_data=far.data, clusters=far.clusters, F_depth=depth,
                             G_depth=far.depth, z_r=z_r)
    E = np.zeros((len(v), 3))
    E[len(top):] = 1.0
    B = _product(v, A_v, (indptr, indices, data), far, E)
    B_t = lensch.vertex_through(bake, E)
    np.testing.assert_allclose(B_t[:len(top)], B[:len(top)], rtol=1e-6)
    assert np.abs(B_t[len(top):]).max() < 1e-6 * B[len(top):].max()
    M = through_exit_table(SKIN.sigma_a, SKIN.sigma_s_prime, SKIN.eta)
    np.testing.assert_allclose(M, through_exit(through_constants(SKIN.sigma_a, SKIN.sigma_s_prime, SKIN.eta),
                                               SKIN.eta, nodes()))
    assert np.all(np.diff(M[:, 0]) > 0)  # the diffusion mode leaves more towards the normal than at grazing
    np.testing.assert_array_equal(profile_model("DIPOLE").through_exit_table(SKIN.sigma_a, SKIN.sigma_s_prime,
                                                                             SKIN.eta), 1.0)


def test_a_stored_bake_with_the_near_depths_but_not_the_far_ones_is_refused(stored_sphere):
    """The through share reads both depths: without the far ones the CPU product drew NaN, the GPU zeros."""
    assert "lensch_G_depth" in stored_sphere and "lensch_F_depth" in stored_sphere
    damaged = {k: v for k, v in stored_sphere.items() if k != "lensch_G_depth"}
    with pytest.raises(store.DamagedBakeError, match="its array 'lensch_G_depth' is missing"):
        tsd.load(damaged)

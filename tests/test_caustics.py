"""Caustics mapping (Shah ch. 5), pure parts: optics, the intersection estimate, the light-space
grids and the exact sphere reference."""
from __future__ import annotations

import math

import numpy as np
import pytest

from translucent_addon.core.lights import DIRECTIONAL, POINT, Emitter
from translucent_addon.core.reference import caustic_sphere as cs
from translucent_addon.gpu import blocks
from translucent_addon.techniques.caustics import model as cm


def test_refract_obeys_snell_and_flags_total_internal_reflection():
    rng = np.random.default_rng(1)
    n = np.tile([0.0, 0.0, 1.0], (500, 1))
    theta = rng.uniform(0, math.pi / 2 * 0.999, 500)
    d = np.stack([np.sin(theta), np.zeros(500), -np.cos(theta)], 1)
    t, ok = cm.refract(d, n, 1 / 1.5)
    assert ok.all()
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.hypot(t[:, 0], t[:, 1]) * 1.5, np.sin(theta), atol=1e-12)  # n1 sin = n2 sin
    t, ok = cm.refract(d, n, 1.5)  # leaving glass: TIR beyond asin(1/1.5)
    np.testing.assert_array_equal(ok, np.sin(theta) <= 1 / 1.5)
    assert np.all(t[~ok] == 0)
    np.testing.assert_allclose(cm.reflect(d, n), d * [1, 1, -1], atol=1e-15)


def height(x, y):
    """A rugged receiver: ridges and bumps of 2 cm over a 40 cm square."""
    return 0.02 * (np.sin(23 * x) * np.cos(17 * y) + 0.5 * np.sin(51 * x + 31 * y))


def heightfield_lookup(texels=None):
    """The positions texture of a directional light straight down on the height field: exact (None)
    or nearest-texel over texels x texels on [-0.2, 0.2]^2."""

    def lookup(points):
        x, y = points[:, 0], points[:, 1]
        if texels is not None:
            x = (np.floor((x + 0.2) / 0.4 * texels) + 0.5) / texels * 0.4 - 0.2
            y = (np.floor((y + 0.2) / 0.4 * texels) + 0.5) / texels * 0.4 - 0.2
        ok = (np.abs(points[:, 0]) <= 0.2) & (np.abs(points[:, 1]) <= 0.2)
        return np.stack([x, y, height(x, y)], 1), ok

    return lookup


def exact_heightfield_hits(v, r):
    """Ray / height-field intersections by fine marching and bisection."""
    t = np.zeros(len(v))
    step = 1e-3
    above = lambda t: (v + t[:, None] * r)[:, 2] - height(*(v + t[:, None] * r)[:, :2].T)  # noqa: E731
    while True:
        nxt = t + step
        done = above(nxt) <= 0
        if done.all():
            break
        t = np.where(done, t, nxt)
    lo, hi = t, t + step
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        a = above(mid) > 0
        lo, hi = np.where(a, mid, lo), np.where(a, hi, mid)
    return v + lo[:, None] * r


def _rays(n=2000, seed=3):
    rng = np.random.default_rng(seed)
    v = np.c_[rng.uniform(-0.1, 0.1, (n, 2)), np.full(n, 0.15)]
    r = np.c_[rng.uniform(-0.35, 0.35, (n, 2)), -np.ones(n)]
    return v, r / np.linalg.norm(r, axis=1, keepdims=True)


@pytest.mark.parametrize("secant", [False, True])
def test_intersection_estimate_converges_on_a_rugged_height_field(secant):
    """Shah 5.3.4: the error falls with iterations (exact positions texture); Secant falls faster."""
    v, r = _rays()
    exact = exact_heightfield_hits(v, r)
    errors = []
    for it in (1, 2, 5, 12):
        y, valid, _, _ = cm.estimate_intersection(v, r, heightfield_lookup(), it, guard=True, secant=secant)
        assert valid.all()
        errors.append(np.median(np.linalg.norm(y - exact, axis=1)))
    assert errors[0] > 1e-3  # one look-up is visibly off on this receiver
    assert errors[-1] < 0.05 * errors[0], errors
    assert all(b <= a * 1.05 for a, b in zip(errors, errors[1:])), errors
    if secant:
        y, *_ = cm.estimate_intersection(v, r, heightfield_lookup(), 5, guard=True, secant=True)
        y_shah, *_ = cm.estimate_intersection(v, r, heightfield_lookup(), 5, guard=True, secant=False)
        assert np.median(np.linalg.norm(y - exact, axis=1)) < np.median(np.linalg.norm(y_shah - exact, axis=1))


def test_oscillation_guard_bisects_where_the_fixed_point_step_diverges():
    """A receiver for which d -> |y(v + d r) - v| has slope -1.5 at the root: Shah's step oscillates
    with growing amplitude; the guard brackets the root and bisects to it."""
    v = np.zeros((1, 3))
    r = np.array([[0.0, 0.0, -1.0]])

    def lookup(points):
        d = np.linalg.norm(points - v, axis=1)
        seen = np.clip(1.0 - 1.5 * (d - 1.0), 0.0, None)  # root at d = 1
        return v + seen[:, None] * r, np.ones(len(points), bool)

    # d_0 = |y(v) - v| = 2.5, then 0.25, 2.125, ... without the guard.
    _, _, d_plain, _ = cm.estimate_intersection(v, r, lookup, 8, guard=False)
    _, _, d_guard, _ = cm.estimate_intersection(v, r, lookup, 8, guard=True)
    assert abs(d_plain[0] - 1.0) > 0.5
    assert abs(d_guard[0] - 1.0) < 0.02


def test_a_null_lookup_loses_the_ray():
    v = np.array([[0.0, 0.0, 0.15], [0.19, 0.0, 0.15]])
    r = np.array([[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]])
    _, valid, _, _ = cm.estimate_intersection(v, r, heightfield_lookup(256), 3)
    np.testing.assert_array_equal(valid, [True, False])


def test_caster_grid_flux_factors_add_up_to_the_grid_solid_angle_and_area():
    e = Emitter(POINT, (0, 0, 0.5), (0, 0, -1), (1, 1, 1))
    grid = cm.caster_grid(e, (0, 0, 0.1), 0.05, 64)
    t = grid.half_extent
    pyramid = 4 * math.asin(t * t / (1 + t * t))  # solid angle of a square pyramid of half-tangent t
    assert grid.texel_flux_factor().sum() == pytest.approx(pyramid, rel=1e-4)
    # The sphere's silhouette fits: its rim projects inside the grid, touching within the margin.
    ang = np.linspace(0, 2 * np.pi, 64)
    rim_dir = np.stack([np.cos(ang), np.sin(ang), np.zeros(64)], 1)
    sin_a = 0.05 / 0.4
    rim = np.array([0, 0, 0.5]) + 0.4 * math.sqrt(1 - sin_a**2) * (
        math.sqrt(1 - sin_a**2) * np.array([0, 0, -1]) + sin_a * rim_dir)
    ndc = cm.project(grid.view_proj, rim)
    assert np.abs(ndc).max() < 1.0 and np.linalg.norm(ndc, axis=1).min() > 0.95
    sun = Emitter(DIRECTIONAL, (0, 0, 0), (0, 0, -1), (1, 1, 1))
    g2 = cm.caster_grid(sun, (0, 0, 0.1), 0.05, 32)
    assert g2.texel_flux_factor().sum() == pytest.approx((2 * 0.05 * 1.02) ** 2, rel=1e-9)
    with pytest.raises(cm.CausticError):
        cm.caster_grid(Emitter(POINT, (0, 0, 0.12), (0, 0, -1), (1, 1, 1), source="inside"), (0, 0, 0.1), 0.05, 8)


def test_atlas_texels_follow_the_shadow_cube_faces():
    e = Emitter(POINT, (0, 0, 1.0), (0, 0, -1), (1, 1, 1))
    faces, _ = blocks.shadow_projection(e, np.zeros(3), 1.0)
    pts = np.array([[0, 0, 0.0], [2, 0, 1.0], [0, -2, 1.0], [0, 0, 3.0]])
    col, row, inside = cm.atlas_texels(e, faces, pts, 64)
    assert inside.all()
    expected_faces = [5, 0, 3, 4]
    np.testing.assert_array_equal((col // 64) + 3 * (row // 64), expected_faces)
    # Straight below the light lands in the middle of the -Z face.
    assert abs(col[0] % 64 - 31.5) <= 0.5 and abs(row[0] % 64 - 31.5) <= 0.5


def test_receiver_patch_areas_tile_a_plane():
    """Texel patch areas of the -Z face over a floor add up to the floor area the face sees."""
    e = Emitter(POINT, (0, 0, 1.0), (0, 0, -1), (1, 1, 1))
    N = 256
    c = (np.arange(N) + 0.5) / N * 2 - 1
    x, y = np.meshgrid(c, c)  # the -Z face at unit height sees the floor square [-1, 1]^2
    pts = np.stack([x.ravel(), y.ravel(), np.zeros(N * N)], 1)
    nor = np.tile([0.0, 0.0, 1.0], (N * N, 1))
    area = cm.receiver_patch_area(e, pts, nor, N, 1.0)
    # Sum over texel centres of (area per texel) ~ the 2 x 2 floor square (midpoint rule).
    assert area.sum() == pytest.approx(4.0, rel=2e-3)


def test_exact_sphere_trace_conserves_flux():
    """eta -> 1: everything passes straight, onto the sphere's shadow disk; eta 1.5: the landed flux is
    the mean of T_in T_out over the silhouette, and the irradiance histogram integrates to it."""
    e = Emitter(POINT, (0, 0, 0.5), (0, 0, -1), (0.8, 0.8, 0.8))
    pts, flux, total = cs.trace(e, cs.GlassSphere((0, 0, 0.1), 0.05, 1.0 + 1e-9), 0.0, n=40_000)
    assert flux.sum(0)[0] == pytest.approx(total[0], rel=1e-6)
    shadow_r = 0.5 * math.tan(math.asin(0.05 / 0.4))
    assert np.hypot(pts[:, 0], pts[:, 1]).max() == pytest.approx(shadow_r, rel=1e-3)
    assert total[0] == pytest.approx(0.8 * 2 * math.pi * (1 - math.sqrt(1 - (0.05 / 0.4) ** 2)), rel=1e-12)
    pts, flux, total = cs.trace(e, cs.GlassSphere((0, 0, 0.1), 0.05, 1.5, (2.0, 0.0, 0.0)), 0.0, n=160_000)
    ratio = flux.sum(0) / total
    assert 0.80 < ratio[1] < 0.87  # Fresnel in and out at eta 1.5
    assert ratio[0] < ratio[1] * math.exp(-2.0 * 0.05)  # Beer over chords of at most 2 R
    E, centres = cs.irradiance_grid(pts, flux, -0.2, 0.2, 64)
    on = (np.abs(pts[:, :2]) < 0.2).all(1)
    assert E.sum(axis=(0, 1))[1] * (0.4 / 64) ** 2 == pytest.approx(flux[on, 1].sum(), rel=1e-9)

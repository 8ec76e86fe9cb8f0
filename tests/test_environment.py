"""Environment key filtered chain (Chan & Wang 2005 Sec. 3.1-3.2): pure tests, plus one Cycles check."""
from __future__ import annotations

import math
import os
import tempfile
import time

import numpy as np
import pytest

from translucent_addon.core import environment as env
from translucent_addon.core.geometry import cubemap

pytestmark = pytest.mark.gpu  # also run on Blender 5.3 under Vulkan and OpenGL (make test-gpu53)

TABLE1 = {2: 4.6, 4: 10.5, 8: 21.6, 16: 43.4, 32: 86.9, 64: 173.7}  # Chan & Wang Table 1 (omega 0.02)


def _level_faces(chain, lv):
    """Unbordered faces (6, r, r, 3) of a level, read back from the atlas."""
    r = chain.res >> lv
    w = r + 2
    blk = chain.atlas[chain.rows[lv]: chain.rows[lv] + w, : 6 * w, :3]
    return blk.reshape(w, 6, w, 3).transpose(1, 0, 2, 3)[:, 1:-1, 1:-1].astype(np.float64)


@pytest.fixture(scope="module")
def busy_chain():
    """A 64-texel chain of a random equirect with a bright patch (sharp features everywhere)."""
    rng = np.random.default_rng(0)
    img = rng.uniform(0.0, 1.0, (64, 128, 3))
    img[20:30, 40:60] = 8.0
    return env.build_chain(img, 64)


# -- key widths ------------------------------------------------------------------------------

def test_key_width_linear_closed_form_and_table1():
    widths = {k: env.key_width(k) for k in TABLE1}
    unit = widths[2] / 2
    for k, w in widths.items():
        assert w == pytest.approx(k * unit, rel=1e-9)  # scale-free problem: exactly linear
    # Numerical root == closed form of the worst case (peak midway between four samples).
    assert unit == pytest.approx(1.0 / (2.0 * math.sqrt(-math.log(1.0 - 0.02))), rel=1e-6)
    assert env._reconstruction_error(unit) == pytest.approx(0.02, abs=1e-6)
    assert env._reconstruction_error(0.9 * unit) > 0.02
    assert env.key_width(4, omega=0.01) > env.key_width(4) > env.key_width(4, omega=0.05)
    # Table 1: our bivariate sigma is ~1.30x Table 1's width from /8 on (Table 1 tends to 2.71 per
    # unit ratio; a univariate analysis gives 2.49-2.86), more at /2 and /4 where Table 1's discrete
    # 512-texel computation dips below its own asymptote. Tolerance: the ratio's spread over /8../64
    # (Table 1 is rounded to 0.1 texel) plus 1 %.
    ratios = {k: widths[k] / TABLE1[k] for k in TABLE1}
    for k in (8, 16, 32, 64):
        assert ratios[k] == pytest.approx(1.30, rel=0.015)
    assert 1.30 < ratios[4] < 1.36 and 1.45 < ratios[2] < 1.56
    # The blurring angle 2 r alpha of Table 1 uses alpha = 90 deg / 512 (checks our alpha).
    assert math.degrees(2 * TABLE1[2] * 0.5 * math.pi / 512) == pytest.approx(1.62, abs=0.01)


# -- chain layout and filtering --------------------------------------------------------------

def test_chain_layout(busy_chain):
    ch = busy_chain
    assert ch.res == 64 and ch.levels == 7
    assert ch.atlas.dtype == np.float32 and ch.atlas.shape == (sum((64 >> k) + 2 for k in range(7)), 6 * 66, 4)
    assert np.all(ch.atlas[..., 3] == 1.0)
    assert ch.sigma[0] == 0.0 and np.all(np.diff(ch.sigma) > 0)
    assert ch.sigma[1] == pytest.approx(env.key_width(2) * math.pi / 128)
    assert list(ch.rows) == [0, 66, 100, 118, 128, 134, 138]


def test_constant_environment_stays_constant():
    c = np.array([0.3, 0.5, 0.7])
    for source in (np.broadcast_to(c, (32, 64, 3)), np.broadcast_to(c, (6, 32, 32, 3)),
                   lambda d: np.broadcast_to(c, d.shape)):
        ch = env.build_chain(np.asarray(source) if not callable(source) else source, 32)
        for lv in range(ch.levels):
            w = (32 >> lv) + 2
            blk = ch.atlas[ch.rows[lv]: ch.rows[lv] + w, : 6 * w, :3]
            np.testing.assert_allclose(blk, np.broadcast_to(c, blk.shape), atol=1e-6)
        np.testing.assert_allclose(ch.mean, c, atol=1e-9)
    d = np.random.default_rng(1).normal(size=(100, 3))
    theta = np.linspace(0.0, 10.0, 100)
    np.testing.assert_allclose(env.sample(ch, d, theta), np.broadcast_to(c, (100, 3)), atol=1e-6)
    uni = env.EnvironmentChain.uniform(c)
    assert uni.levels == 1 and uni.res == 1
    np.testing.assert_allclose(env.sample(uni, d, theta), np.broadcast_to(c, (100, 3)), atol=1e-6)
    np.testing.assert_allclose(uni.mean, c)


def test_filtering_preserves_mean(busy_chain):
    ch = busy_chain
    for lv in range(ch.levels):
        om = cubemap.texel_solid_angles(ch.res >> lv)
        m = (_level_faces(ch, lv) * om[..., None]).sum(axis=(0, 1, 2)) / om.sum()
        np.testing.assert_allclose(m, ch.mean, rtol=0.01)


def _edge_points(rng, n):
    """Directions on cube edges (two equal largest |components|), and those two axes."""
    d = rng.normal(size=(n, 3))
    a = np.abs(d)
    order = np.argsort(-a, axis=1)
    i0, i1 = order[:, 0], order[:, 1]
    r = np.arange(n)
    d[r, i1] = np.sign(d[r, i1]) * a[r, i0]
    return d / np.linalg.norm(d, axis=1, keepdims=True), i0, i1


def test_filtered_levels_are_seam_free(busy_chain):
    """Across a face edge the value jumps by a few % of its change over one texel inside a face."""
    ch = busy_chain
    rng = np.random.default_rng(2)
    d, i0, i1 = _edge_points(rng, 2000)
    r = np.arange(len(d))
    for lv in (1, 2, 3):
        res = ch.res >> lv

        def look(x):
            return cubemap.sample_atlas(ch.atlas, res, x, int(ch.rows[lv]))[..., :3]

        on0 = d.copy()
        on0[r, i0] *= 1.0 + 1e-7  # just inside face i0
        on1 = d.copy()
        on1[r, i1] *= 1.0 + 1e-7  # just inside face i1
        one_texel = on0.copy()
        one_texel[r, i1] *= 1.0 - 2.0 / res  # one texel further into face i0
        jump = np.abs(look(on0) - look(on1)).max(axis=-1)
        within = np.abs(look(one_texel) - look(on0)).max(axis=-1)
        assert jump.mean() < 0.1 * within.mean(), (lv, jump.mean(), within.mean())
        assert jump.max() < 0.1 * within.max()


def _spherical_std(sigma, theta_max):
    """Per-axis angular std sqrt(E[theta^2] / 2) of exp(-theta^2 / 2 sigma^2) on the sphere."""
    th = (np.arange(20000) + 0.5) * (theta_max / 20000)  # midpoint rule
    g = np.exp(-0.5 * (th / sigma) ** 2) * np.sin(th)
    return math.sqrt((g * th * th).sum() / (2.0 * g.sum()))


def test_blur_width_matches_sigma():
    """A one-texel delta near a cube corner spreads with the level's sigma (per-axis angular std)."""
    res = 64
    faces = np.zeros((6, res, res, 3))
    faces[0, 3, 60] = 1.0  # face +X, close to a corner: the kernel straddles three faces
    d0 = cubemap.texel_directions(res, 0)[0, 3, 60]
    ch = env.build_chain(faces, res)
    for lv in (1, 2, 3):
        r = res >> lv
        f = _level_faces(ch, lv)[..., 0]
        om = cubemap.texel_solid_angles(r)
        th = np.arccos(np.clip(cubemap.texel_directions(r, 0) @ d0, -1.0, 1.0))
        w = f * om
        measured = math.sqrt((w * th * th).sum() / (2.0 * w.sum()))
        ideal = _spherical_std(ch.sigma[lv], min(env.KERNEL_CUTOFF * ch.sigma[lv], math.pi))
        assert measured == pytest.approx(ideal, rel=0.02), (lv, measured, ideal)
        if lv < 3:  # small angles: the sphere is flat enough for sigma itself
            assert measured == pytest.approx(ch.sigma[lv], rel=0.10)


def test_finer_faces_are_box_downsampled():
    faces = np.random.default_rng(6).uniform(0.0, 1.0, (6, 64, 64, 3))
    om = cubemap.texel_solid_angles(64)
    mean = (faces * om[..., None]).sum(axis=(0, 1, 2)) / om.sum()
    ch = env.build_chain(faces, 16)
    assert ch.res == 16 and ch.levels == 5
    np.testing.assert_allclose(ch.mean, mean, rtol=1e-9)
    with pytest.raises(ValueError):
        env.build_chain(faces, 24)


def test_sample_interpolates_levels(busy_chain):
    ch = busy_chain
    rng = np.random.default_rng(3)
    d = rng.normal(size=(200, 3))

    def level(lv):
        return cubemap.sample_atlas(ch.atlas, ch.res >> lv, d, int(ch.rows[lv]))[..., :3]

    np.testing.assert_allclose(env.sample(ch, d, 0.0), level(0))
    np.testing.assert_allclose(env.sample(ch, d, ch.sigma[2]), level(2), atol=1e-12)
    mid = 0.25 * ch.sigma[2] + 0.75 * ch.sigma[3]
    assert env.fractional_level(ch.sigma, mid) == pytest.approx(2.75)
    np.testing.assert_allclose(env.sample(ch, d, mid), 0.25 * level(2) + 0.75 * level(3), atol=1e-12)
    np.testing.assert_allclose(env.sample(ch, d, 100.0), level(ch.levels - 1), atol=1e-12)
    theta = rng.uniform(0.0, 2.0, 200)
    per = np.stack([env.sample(ch, d[i], theta[i]) for i in range(0, 200, 37)])
    np.testing.assert_allclose(env.sample(ch, d, theta)[::37], per, atol=1e-12)


def test_build_time_budget():
    """Budget: a 128-texel base from a 512 x 256 equirect in < 5 s (about 1 s measured, 2 cores)."""
    img = np.random.default_rng(4).uniform(0.0, 1.0, (256, 512, 4)).astype(np.float32)
    env.key_width(2)  # cached root
    t0 = time.perf_counter()
    ch = env.build_chain(img, 128)
    assert time.perf_counter() - t0 < 5.0
    assert ch.levels == 8 and ch.atlas.shape == (271, 780, 4)


# -- equirect convention ---------------------------------------------------------------------

def test_equirect_axis_round_trip():
    h, w = 16, 32
    img = np.zeros((h, w, 3))
    colors = np.eye(3).tolist() + [[1, 1, 0], [0, 1, 1], [1, 0, 1]]
    # (direction, painted (rows, cols)): row 0 is the bottom (-Z), u = 0.5 looks along +X,
    # u = 0.25 along +Y, u = 0.75 along -Y, u = 0 / 1 along -X (wraps).
    cases = [
        ((1, 0, 0), ([7, 8], [15, 16])),
        ((0, 1, 0), ([7, 8], [7, 8])),
        ((0, -1, 0), ([7, 8], [23, 24])),
        ((-1, 0, 0), ([7, 8], [31, 0])),
        ((0, 0, 1), ([15], list(range(w)))),
        ((0, 0, -1), ([0], list(range(w)))),
    ]
    for (d, (rows, cols)), c in zip(cases, colors):
        img[np.ix_(rows, cols)] = c
    for (d, _), c in zip(cases, colors):
        np.testing.assert_allclose(env.sample_equirect(img, np.array(d, float)), c, atol=1e-12)
    u, v = env.equirect_direction_to_uv(np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]))
    np.testing.assert_allclose(u, [0.5, 0.25, 0.5])
    np.testing.assert_allclose(v, [0.5, 0.5, 1.0])


def test_equirect_matches_cycles():
    """Cycles renders of an Environment Texture world agree with ``sample_equirect`` per pixel.

    Three 24 x 24 perspective views (90 deg), 1 sample, 0.01 px filter: pixel centres' rays.
    Tolerance 1e-4 (float texture, linear EXR). Cycles extends the image periodically in v too,
    so within half a pixel row of a pole it blends in the opposite pole's row, where we clamp:
    those pixels are excluded.
    """
    bpy = pytest.importorskip("bpy")
    from mathutils import Vector

    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = 1
    sc.cycles.use_denoising = False
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.filter_width = 0.01
    n = 24
    sc.render.resolution_x = sc.render.resolution_y = n
    sc.render.resolution_percentage = 100
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    h, w = 32, 64
    img = np.random.default_rng(5).uniform(0.1, 1.0, (h, w, 4)).astype(np.float32)
    img[..., 3] = 1.0
    image = bpy.data.images.new("translucent_env_test", w, h, float_buffer=True)
    image.pixels.foreach_set(img.ravel())
    world = bpy.data.worlds.new("translucent_env_test")
    sc.world = world
    nodes = world.node_tree.nodes
    tex = nodes.new("ShaderNodeTexEnvironment")
    tex.image = image
    tex.interpolation = "Linear"
    world.node_tree.links.new(tex.outputs["Color"], nodes["Background"].inputs["Color"])
    cam = bpy.data.cameras.new("translucent_env_test")
    cam.lens_unit = "FOV"
    cam.sensor_fit = "HORIZONTAL"
    cam.angle = math.radians(90.0)
    ob = bpy.data.objects.new("translucent_env_test", cam)
    sc.collection.objects.link(ob)
    sc.camera = ob
    ob.rotation_mode = "QUATERNION"
    c = (np.arange(n) + 0.5) / n * 2.0 - 1.0  # tan(45 deg) = 1
    y, x = np.meshgrid(c, c, indexing="ij")  # EXR pixels: row 0 at the bottom, like the view
    cam_dirs = np.stack([x, y, -np.ones_like(x)], axis=-1)
    checked = 0
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "env.exr")
        sc.render.filepath = path
        for view in [(-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-0.3, 0.5, -0.6)]:  # u seam, +Z, near -Z
            ob.rotation_quaternion = Vector(view).normalized().to_track_quat("-Z", "Y")
            bpy.context.view_layer.update()
            bpy.ops.render.render(write_still=True)
            out = bpy.data.images.load(path)
            rendered = np.array(out.pixels[:], np.float64).reshape(n, n, 4)[..., :3]
            bpy.data.images.remove(out)
            dirs = cam_dirs @ np.array(ob.matrix_world.to_3x3()).T
            _, v = env.equirect_direction_to_uv(dirs)
            keep = (v * h > 0.5) & (v * h < h - 0.5)  # not within half a row of a pole
            err = np.abs(env.sample_equirect(img[..., :3], dirs) - rendered).max(axis=-1)
            assert err[keep].max() < 1e-4, (view, err[keep].max())
            checked += int(keep.sum())
    assert checked > 3 * n * n - 20

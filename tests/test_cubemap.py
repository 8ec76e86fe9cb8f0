"""Cube-map directions and the bordered atlas (core/geometry/cubemap.py)."""
import numpy as np
import pytest

from translucent_addon.core.geometry import cubemap


def test_direction_and_face_coordinates_round_trip():
    rng = np.random.default_rng(1)
    d = rng.normal(size=(5000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    face, s, t = cubemap.direction_to_face_st(d)
    assert (np.abs(s) <= 1).all() and (np.abs(t) <= 1).all()
    assert np.allclose(cubemap.face_st_to_direction(face, s, t), d, atol=1e-12)
    # The face's major axis is the direction's largest component, with its sign.
    major = np.argmax(np.abs(d), axis=1)
    assert (face // 2 == major).all()
    assert ((face % 2 == 1) == (d[np.arange(len(d)), major] < 0)).all()


def test_texel_solid_angles_cover_the_sphere():
    for res in (1, 4, 32):
        assert cubemap.texel_solid_angles(res).sum() == pytest.approx(4 * np.pi, rel=1e-12)


def test_border_texels_hold_the_neighbouring_face_and_sampling_is_seam_free():
    res = 16
    dirs = cubemap.texel_directions(res)
    # A smooth function of direction stored in the bordered atlas.
    f = lambda d: (np.sin(3 * d[..., 0]) + d[..., 1] * d[..., 2] + 2.0)[..., None]  # noqa: E731
    atlas = cubemap.atlas_from_faces(f(dirs))
    assert atlas.shape == (res + 2, 6 * (res + 2), 1)
    # Border texel of face 0 at s < -1 points into another face: its face lookup is not 0.
    face, _, _ = cubemap.direction_to_face_st(dirs[0, 5, 0])
    assert face != 0
    rng = np.random.default_rng(2)
    d = rng.normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    err = np.abs(cubemap.sample_atlas(atlas, res, d)[:, 0] - f(d)[:, 0])
    # Bilinear error of a smooth function, with no larger error along the face edges (no seam).
    _, s, t = cubemap.direction_to_face_st(d)
    edge = np.maximum(np.abs(s), np.abs(t)) > 1 - 1.0 / res
    assert err.max() < 0.02
    assert err[edge].max() < 2.0 * err[~edge].max()

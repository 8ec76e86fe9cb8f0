"""Cube-map directions and the bordered face atlas the GPU samples (GEOCUBE cubes, environment maps).

Faces follow OpenGL's cube-map convention (+X, -X, +Y, -Y, +Z, -Z; s, t in [-1, 1]), but the
maps are stored as 2-D atlases, not GPU cube textures: Blender's ``gpu`` module cannot upload
cube faces or mip levels from Python, and a 2-D atlas lets the shader and its NumPy twin sample
exactly the same texels. Each face of ``res`` x ``res`` texels is stored with a one-texel border
on every side holding the value in the border texel's own (extrapolated) direction, which lies
on the neighbouring face: bilinear filtering inside a face then blends across the edge with no
seam. ``glsl`` twin: ``gpu_shaders/common/cube_atlas.glsl``.

Pure (NumPy).
"""
from __future__ import annotations

import numpy as np

# (major axis, sign, s axis and sign, t axis and sign) per face: OpenGL Table 3.21.
_FACES = (
    (0, +1.0, (2, -1.0), (1, -1.0)),
    (0, -1.0, (2, +1.0), (1, -1.0)),
    (1, +1.0, (0, +1.0), (2, +1.0)),
    (1, -1.0, (0, +1.0), (2, -1.0)),
    (2, +1.0, (0, +1.0), (1, -1.0)),
    (2, -1.0, (0, -1.0), (1, -1.0)),
)


def face_st_to_direction(face: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Unit directions of face coordinates s, t (any real values: beyond +-1 they extrapolate)."""
    face = np.asarray(face)
    s, t = np.broadcast_arrays(np.asarray(s, np.float64), np.asarray(t, np.float64))
    face = np.broadcast_to(face, s.shape)
    d = np.zeros(s.shape + (3,))
    for f, (major, sign, (sa, ss), (ta, ts)) in enumerate(_FACES):
        m = face == f
        if not m.any():
            continue
        d[m, major] = sign
        d[m, sa] = ss * s[m]
        d[m, ta] = ts * t[m]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def direction_to_face_st(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Face index and s, t in [-1, 1] of directions (need not be unit)."""
    d = np.asarray(d, np.float64)
    a = np.abs(d)
    major = np.argmax(a, axis=-1)
    # Ties go to the lowest axis, as in the GLSL twin (x >= y, x >= z).
    m = np.take_along_axis(d, major[..., None], axis=-1)[..., 0]
    face = 2 * major + (m < 0)
    s = np.empty(d.shape[:-1])
    t = np.empty(d.shape[:-1])
    for f, (mj, sign, (sa, ss), (ta, ts)) in enumerate(_FACES):
        k = face == f
        if not k.any():
            continue
        den = np.abs(d[k, mj])
        s[k] = ss * d[k, sa] / den
        t[k] = ts * d[k, ta] / den
    return face, s, t


def texel_directions(res: int, border: int = 1) -> np.ndarray:
    """Directions of every texel centre of the bordered faces: (6, res + 2b, res + 2b, 3).

    Row index follows t, column index follows s (row 0 at t = -1), matching the atlas layout.
    """
    i = np.arange(-border, res + border) + 0.5
    c = 2.0 * i / res - 1.0
    t, s = np.meshgrid(c, c, indexing="ij")
    return np.stack([face_st_to_direction(f, s, t) for f in range(6)])


def texel_solid_angles(res: int) -> np.ndarray:
    """Solid angle of every (unbordered) texel, (6, res, res); they sum to 4 pi."""
    edges = 2.0 * np.arange(res + 1) / res - 1.0

    def corner(x: np.ndarray, y: np.ndarray) -> np.ndarray:  # integral of the solid-angle density from the face centre
        return np.arctan2(x * y, np.sqrt(x * x + y * y + 1.0))

    t, s = np.meshgrid(edges, edges, indexing="ij")
    a = corner(s, t)
    face = a[1:, 1:] - a[:-1, 1:] - a[1:, :-1] + a[:-1, :-1]
    return np.broadcast_to(face, (6, res, res)).copy()


def atlas_from_faces(faces: np.ndarray) -> np.ndarray:
    """(6, R, R, C) bordered faces -> (R, 6 R, C) atlas, faces side by side."""
    faces = np.asarray(faces)
    return np.concatenate(list(faces), axis=1)


def _corners(res: int, d: np.ndarray, row0: int):
    face, s, t = direction_to_face_st(d)
    w = res + 2
    # Texel-space coordinates inside the bordered face (texel centres at k + 0.5).
    x = np.clip((s + 1.0) * 0.5 * res + 0.5, 0.0, w - 1.0)
    y = np.clip((t + 1.0) * 0.5 * res + 0.5, 0.0, w - 1.0)
    x0 = np.minimum(np.floor(x).astype(np.int64), w - 2)
    y0 = np.minimum(np.floor(y).astype(np.int64), w - 2)
    return face * w + x0, row0 + y0, x - x0, y - y0


def gather_min(atlas: np.ndarray, res: int, d: np.ndarray, row0: int = 0) -> np.ndarray:
    """The smallest of the four texels bilinear filtering would blend (GLSL ``textureGather`` twin);
    ``atlas`` is one channel (H, W)."""
    col, row, _, _ = _corners(res, d, row0)
    return np.minimum(np.minimum(atlas[row, col], atlas[row, col + 1]),
                      np.minimum(atlas[row + 1, col], atlas[row + 1, col + 1]))


def sample_atlas(atlas: np.ndarray, res: int, d: np.ndarray, row0: int = 0) -> np.ndarray:
    """Bilinear lookup of directions ``d`` in a bordered atlas (the GLSL ``cube_atlas_sample`` twin).

    ``atlas``: (H, 6 (res + 2), C); the cube's rows start at ``row0``. Returns (..., C).
    """
    col, row, fx, fy = _corners(res, d, row0)
    fx, fy = fx[..., None], fy[..., None]
    a = atlas[row, col]
    b = atlas[row, col + 1]
    c = atlas[row + 1, col]
    e = atlas[row + 1, col + 1]
    return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + e * fx) * fy

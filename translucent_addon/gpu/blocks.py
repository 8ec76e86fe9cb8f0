"""Uniform-block packing (std140) and shadow-map projections. Pure NumPy.

Mirrors the structs of ``gpu_shaders/common/structs.glsl``. Matrices are
NumPy row-major maths (``clip = M @ p``); GLSL ``mat4`` is column-major, so a
matrix is written as ``M.T`` flattened.
"""
from __future__ import annotations

import math

import numpy as np

from ..core.lights import DIRECTIONAL, Emitter, fitted_tan_half

FRAME_FLOATS = 3 * 16 + 3 * 4 + 9 * 4
OBJECT_FLOATS = 16 + 16 + 4
LIGHT_FLOATS = 6 * 16 + 5 * 4

# Cube faces +X -X +Y -Y +Z -Z: (forward, up). The lookup picks the face by the
# major axis of p - light, so only the forward direction must match that order.
CUBE_FACES = (
    ((1, 0, 0), (0, -1, 0)),
    ((-1, 0, 0), (0, -1, 0)),
    ((0, 1, 0), (0, 0, 1)),
    ((0, -1, 0), (0, 0, -1)),
    ((0, 0, 1), (0, -1, 0)),
    ((0, 0, -1), (0, -1, 0)),
)


def _mat(m) -> np.ndarray:
    return np.asarray(m, dtype=np.float32).T.ravel()


def look_at(eye, forward, up) -> np.ndarray:
    """World -> view matrix looking along ``forward`` (OpenGL: view looks down -Z). Scalar maths: a frame makes
    dozens (six per point light and area-light sample), where NumPy's per-call cost on 3-vectors was 25 us."""
    fx, fy, fz = (float(c) for c in forward)
    n = math.sqrt(fx * fx + fy * fy + fz * fz)
    fx, fy, fz = fx / n, fy / n, fz / n
    ux, uy, uz = (float(c) for c in up)
    nu = math.sqrt(ux * ux + uy * uy + uz * uz)
    if abs(fx * ux + fy * uy + fz * uz) / nu > 0.999:
        ux, uy, uz = (1.0, 0.0, 0.0) if abs(fx) < 0.9 else (0.0, 1.0, 0.0)
    sx, sy, sz = fy * uz - fz * uy, fz * ux - fx * uz, fx * uy - fy * ux
    ns = math.sqrt(sx * sx + sy * sy + sz * sz)
    sx, sy, sz = sx / ns, sy / ns, sz / ns
    ux, uy, uz = sy * fz - sz * fy, sz * fx - sx * fz, sx * fy - sy * fx
    ex, ey, ez = (float(c) for c in eye)
    return np.array([[sx, sy, sz, -(sx * ex + sy * ey + sz * ez)],
                     [ux, uy, uz, -(ux * ex + uy * ey + uz * ez)],
                     [-fx, -fy, -fz, fx * ex + fy * ey + fz * ez],
                     [0.0, 0.0, 0.0, 1.0]])


def perspective(fov_y: float, aspect: float, near: float, far: float) -> np.ndarray:
    t = 1.0 / math.tan(fov_y / 2)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = t / aspect, t
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def orthographic(half_w: float, half_h: float, near: float, far: float) -> np.ndarray:
    m = np.eye(4)
    m[0, 0], m[1, 1] = 1 / half_w, 1 / half_h
    m[2, 2] = -2 / (far - near)
    m[2, 3] = -(far + near) / (far - near)
    return m


def _point_projection(pos, centre, radius: float, fov: float) -> np.ndarray:
    """A point emitter's square perspective face of angle ``fov``, deep enough for the scene sphere."""
    far = float(np.linalg.norm(pos - centre)) + 2.0 * radius
    return perspective(fov, 1.0, max(far * 1e-4, 1e-5), far)


def shadow_projection(e: Emitter, centre: np.ndarray, radius: float):
    """Face view-projection matrices (6, 4, 4) and the shadow origin of an emitter."""
    faces = np.tile(np.eye(4), (6, 1, 1))
    if e.kind == DIRECTIONAL:
        axis = np.asarray(e.direction)
        origin = centre - axis * 2.0 * radius
        faces[0] = orthographic(radius, radius, 0.0, 4.0 * radius) @ look_at(origin, axis, (0, 0, 1))
        return faces, origin
    pos = np.asarray(e.position, float)
    proj = _point_projection(pos, centre, radius, math.pi / 2)
    for i, (fwd, up) in enumerate(CUBE_FACES):
        faces[i] = proj @ look_at(pos, fwd, up)
    return faces, pos


def shadow_faces(e: Emitter, centre: np.ndarray, radius: float, fit_spot: bool = True):
    """The shadow map's faces of an emitter: (faces (6, 4, 4), origin, face count, tan_half). A spot whose
    cone fits in 45 degrees (``lights.fitted_tan_half``) gets one perspective face along its axis, as wide
    as the cone (tan_half > 0): finer than a cube face at the same texels, and one face to draw instead of
    six; other emitters those of ``shadow_projection`` (tan_half 0). ``fit_spot`` False keeps the cube
    (the caustics passes address their atlases by cube faces)."""
    t = fitted_tan_half(e) if fit_spot else 0.0
    if t == 0.0:
        return (*shadow_projection(e, centre, radius), 1 if e.kind == DIRECTIONAL else 6, 0.0)
    pos = np.asarray(e.position, float)
    axis = np.asarray(e.direction, float)
    up = (1.0, 0.0, 0.0) if abs(axis[2]) > 0.9 else (0.0, 0.0, 1.0)
    faces = np.tile(np.eye(4), (6, 1, 1))
    faces[0] = _point_projection(pos, centre, radius, 2.0 * math.atan(t)) @ look_at(pos, axis, up)
    return faces, pos, 1, t


def face_texels(texels: int, n_faces: int) -> int:
    """Texels per side of an emitter's shadow-map faces in the 3 x 2 atlas of ``texels``-wide tiles: a
    single face (a fitted spot, a sun) takes a 2 x 2 block of tiles, twice the texels at no extra memory.
    Light that grazes a rim enters within a texel or two of the map's silhouette, and QUADGRAPH's single
    scattering reads its path there (back-lit cow 0.197 -> 0.184 and bunny 0.109 -> 0.104 against exact
    transport, with the key spot's map at 2048 instead of 1024)."""
    return 2 * int(texels) if n_faces == 1 else int(texels)


def cube_face(d) -> int:
    """The face index for a direction, as ``cube_face`` in pipeline/base_lighting.glsl."""
    a = np.abs(d)
    if a[0] >= a[1] and a[0] >= a[2]:
        return 0 if d[0] > 0 else 1
    if a[1] >= a[2]:
        return 2 if d[1] > 0 else 3
    return 4 if d[2] > 0 else 5


def frame_block(view, projection, world_color, world_sh) -> bytes:
    """FrameData: view_proj, view, proj, world colour, camera position (w: orthographic), forward, and
    the world's radiance in SH bands 0-2 (9 x rgb, ``FrameInputs.world_sh``)."""
    view = np.asarray(view, np.float64)
    projection = np.asarray(projection, np.float64)
    data = np.zeros(FRAME_FLOATS, np.float32)
    data[0:16] = _mat(projection @ view)
    data[16:32] = _mat(view)
    data[32:48] = _mat(projection)
    data[48:51] = world_color
    inv = np.linalg.inv(view)
    data[52:55] = inv[:3, 3]
    data[55] = 1.0 if projection[3, 3] == 1.0 else 0.0
    data[56:59] = -inv[:3, 2]
    data[60:96] = np.pad(np.asarray(world_sh, np.float64)[:, :3], ((0, 0), (0, 1))).ravel()
    return data.tobytes()


def object_block(model, normal_matrix, tag: int = 0) -> bytes:
    """ObjectData: model, normal matrix, shading (x: the subsurface tag, IMAGE_SPACE's object number times 64 plus
    its material slot, ``image_space.model.object_tag``, 0 for Lambert; y: 1 when the model mirrors, its
    determinant negative: the fragment shaders' ``facing_out`` turns gl_FrontFacing then)."""
    mirrored = float(np.linalg.det(np.asarray(model, np.float64)[:3, :3]) < 0.0)
    shading = np.array([tag, mirrored, 0, 0], np.float32)
    return np.concatenate([_mat(model), _mat(normal_matrix), shading]).astype(np.float32).tobytes()


def light_block(e: Emitter, faces: np.ndarray, origin, texels: int, radius: float, shadows: bool = True,
                normal_offset_texels: float = 1.5, tan_half: float = 0.0) -> bytes:
    """LightData (common/structs.glsl); ``tan_half`` > 0: the shadow map is one fitted face
    (``shadow_faces``)."""
    data = np.zeros(LIGHT_FLOATS, np.float32)
    data[:96] = np.concatenate([_mat(f) for f in faces])
    data[96:99] = origin
    data[99] = float(e.kind)
    data[100:103] = e.direction
    data[104:107] = e.radiance
    data[108:112] = (e.cos_half_angle, e.spot_smooth, 1.0 if e.cosine_lobe else 0.0, tan_half)
    data[112:116] = (texels, radius, normal_offset_texels, 1.0 if shadows else 0.0)
    return data.tobytes()


CAUSTIC_FLOATS = 16 + 5 * 4


def caustic_block(grid_view_proj, grid_size: int, half_extent: float, caster, settings) -> bytes:
    """CausticData (std140): the caster's grid projection and optics, the estimate and splat settings.
    ``caster``: a scene_data.Caster; ``settings``: a scene_data.CausticSettings."""
    data = np.zeros(CAUSTIC_FLOATS, np.float32)
    data[0:16] = _mat(grid_view_proj)
    surfaces = 0 if caster.mode == "REFLECTIVE" else int(caster.surfaces)
    data[16:20] = (grid_size, half_extent, surfaces, caster.eta)
    data[20:23] = caster.sigma_a
    data[23] = caster.dispersion
    data[24:27] = caster.tint
    channels = 3 if (caster.dispersion > 0 and surfaces > 0) else 1
    estimator = 2.0 if settings.secant else (1.0 if settings.guard else 0.0)  # secant steps keep the guard
    data[28:32] = (settings.iterations, estimator, settings.texels, channels)
    data[32:35] = (settings.splat_sigma, 1.0 if settings.adaptive else 0.0, settings.splat_sigma_max)
    return data.tobytes()

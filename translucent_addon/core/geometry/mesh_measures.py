"""Per-vertex measures of a triangle mesh, the scale of its transform, and a quadrature rule on triangles
(pure)."""
from __future__ import annotations

import numpy as np

from .mesh_checks import triangle_areas


def stretch_of(linear: np.ndarray) -> np.ndarray:
    """The symmetric factor S of the polar decomposition L = R S: the object's scale, rotation removed."""
    _, sing, vt = np.linalg.svd(np.asarray(linear, np.float64))
    return vt.T @ np.diag(sing) @ vt


def vertex_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """A_v: the area of the triangles sharing each vertex (Lensch 5.2; a third of it is the vertex's own)."""
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    area = triangle_areas(v, t)
    A_v = np.zeros(len(v))
    for k in range(3):
        np.add.at(A_v, t[:, k], area)
    return A_v


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray, by_angle: bool = False) -> np.ndarray:
    """Unit vertex normals (zero for vertices no triangle uses), the facet normals weighted by area, or
    with ``by_angle`` by each corner's angle, as Blender computes a smooth mesh's."""
    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    p = v[t]
    face_n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # length = 2 * area
    if by_angle:
        face_n /= np.maximum(np.linalg.norm(face_n, axis=1, keepdims=True), 1e-30)
    n = np.zeros_like(v)
    for k in range(3):
        weight = 1.0
        if by_angle:
            a, b = p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]
            cos = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-30)
            weight = np.arccos(np.clip(cos, -1.0, 1.0))[:, None]
        np.add.at(n, t[:, k], face_n * weight)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def facing_side(facet_normals: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Facet normals turned to the side of the interpolated normals (whatever the winding)."""
    return facet_normals * np.where(np.einsum("ij,ij->i", facet_normals, normals) < 0, -1.0, 1.0)[:, None]


def subtriangle_centroids(n: int) -> np.ndarray:
    """Barycentric (u, v) of the centroids of the n^2 equal sub-triangles of a triangle: (n^2, 2)."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    up = i + j <= n - 1
    down = i + j <= n - 2
    cu = np.concatenate([(i[up] + 1 / 3) / n, (i[down] + 2 / 3) / n])
    cv = np.concatenate([(j[up] + 1 / 3) / n, (j[down] + 2 / 3) / n])
    return np.stack([cu, cv], axis=1)


def uv_tangents(positions: np.ndarray, uvs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per corner (3T, 3) the derivatives dP/du and dP/dv of each triangle's affine map from its UVs to
    its positions (the tangent frame of a height field, with lengths in scene units per UV unit).
    A triangle with degenerate UVs gets zero tangents."""
    p = np.asarray(positions, np.float64).reshape(-1, 3, 3)
    t = np.asarray(uvs, np.float64).reshape(-1, 3, 2)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    ok = np.abs(det) > 1e-14
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    dpdu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * inv
    dpdv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * inv
    return (np.repeat(dpdu, 3, axis=0).astype(np.float32), np.repeat(dpdv, 3, axis=0).astype(np.float32))

"""Triangle meshes from OBJ files and the compact NPZ files the extension ships."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def load_obj(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) float32 and triangles (T, 3) int32 of an OBJ (polygons fanned, 1-based, v/vt/vn ok)."""
    verts, tris = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append(line.split()[1:4])
            elif line.startswith("f "):
                idx = [int(tok.split("/")[0]) for tok in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                tris.extend((idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1))
    v = np.asarray(verts, dtype=np.float32).reshape(-1, 3)
    t = np.asarray(tris, dtype=np.int32).reshape(-1, 3)
    if len(t) and (t.min() < 0 or t.max() >= len(v)):
        raise ValueError(f"{path}: face index out of range")
    return v, t


def load_obj_uv(path: str | Path) -> np.ndarray | None:
    """(T, 3, 2) float32 texture coordinates at each triangle corner of an OBJ (polygons fanned as ``load_obj``
    fans them), or None when a face has none."""
    uvs, corners = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("vt "):
                uvs.append(line.split()[1:3])
            elif line.startswith("f "):
                toks = [tok.split("/") for tok in line.split()[1:]]
                if any(len(t) < 2 or not t[1] for t in toks):
                    return None
                idx = [int(t[1]) for t in toks]
                idx = [i - 1 if i > 0 else len(uvs) + i for i in idx]
                corners.extend((idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1))
    if not corners:
        return None
    return np.asarray(uvs, np.float32).reshape(-1, 2)[np.asarray(corners, np.int64)]


def save_npz(path: str | Path, vertices: np.ndarray, triangles: np.ndarray, uv: np.ndarray | None = None) -> None:
    """Vertices, triangles and, when given, (T, 3, 2) corner UVs (float16: a texture's 1/2048 is plenty)."""
    extra = {} if uv is None else {"uv": uv.astype(np.float16)}
    np.savez_compressed(path, vertices=vertices.astype(np.float32), triangles=triangles.astype(np.int32), **extra)


def load_npz(path: Path) -> tuple[np.ndarray, np.ndarray]:
    with np.load(path) as data:
        return data["vertices"], data["triangles"]


def load_npz_uv(path: Path) -> np.ndarray | None:
    """The (T, 3, 2) float32 corner UVs a bundled mesh carries, or None."""
    with np.load(path) as data:
        return data["uv"].astype(np.float32) if "uv" in data else None

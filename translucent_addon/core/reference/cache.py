"""Reference renders cached by a hash of everything that made them. Pure.

A cached entry is <dir>/<key>.npy (linear RGBA float32) and <key>.json (the description that was
hashed, and the seconds the render took), so a report can say how the reference was made.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np


def corner_digest(*corner_arrays: np.ndarray) -> str:
    """A digest of triangle corners (each array (3T, k), row i the i-th corner) that does not depend on the
    order of the triangles nor on which corner a triangle starts at: Blender does not always list the
    corners of the same primitive in the same order from one session to the next (a UV sphere's), and a
    cache key must not change with it. Mirror images hash differently; a moved corner changes the digest."""
    rows = np.concatenate([np.asarray(a, np.float32).reshape(-1, 3, np.shape(a)[-1]) for a in corner_arrays], axis=2)
    rows = np.round(rows.astype(np.float64), 6) + 0.0  # float noise of the same geometry read twice; no -0
    # Rotate each triangle to start at its lexicographically smallest corner (keeps the winding).
    first = np.lexsort(rows.transpose(2, 0, 1)[::-1].reshape(rows.shape[2], -1)).reshape(-1)
    order = np.empty(rows.shape[0] * 3, np.int64)
    order[first] = np.arange(len(first))
    rank = order.reshape(-1, 3)
    start = rank.argmin(axis=1)
    rolled = rows[np.arange(len(rows))[:, None], (start[:, None] + np.arange(3)[None, :]) % 3]
    flat = rolled.reshape(len(rolled), -1)
    flat = flat[np.lexsort(flat.T[::-1])]
    return hashlib.blake2b(np.ascontiguousarray(flat).tobytes(), digest_size=12).hexdigest()


def normals_digest(positions: np.ndarray, normals: np.ndarray) -> str:
    """A digest of corner normals that survives their float noise: Blender sums smooth normals in an order
    that changes between sessions, so their last bits do, and any rounding of 80,000 values lands some on
    the other side. Their moments (sum n, sum n p^T, over the corners) to 4 significant digits still tell
    smooth from flat shading and an edited normal from none."""
    p = np.asarray(positions, np.float64).reshape(-1, 3)
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    moments = np.concatenate([n.sum(axis=0), (n[:, :, None] * p[:, None, :]).sum(axis=0).ravel()])
    scale = max(float(np.abs(moments).max()), 1e-30)
    return hashlib.blake2b((np.round(moments / scale, 4) + 0.0).tobytes(), digest_size=12).hexdigest()


def key(description: dict) -> str:
    return hashlib.blake2b(json.dumps(description, sort_keys=True, default=str).encode(), digest_size=12).hexdigest()


def load(cache_dir: Path, description: dict) -> tuple[np.ndarray, float] | None:
    """(image, seconds) of a cached render, or None."""
    k = key(description)
    npy, meta = Path(cache_dir) / f"{k}.npy", Path(cache_dir) / f"{k}.json"
    if not (npy.exists() and meta.exists()):
        return None
    return np.load(npy), json.loads(meta.read_text())["seconds"]


def store(cache_dir: Path, description: dict, image: np.ndarray, seconds: float) -> None:
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    k = key(description)
    np.save(cache_dir / f"{k}.npy", np.asarray(image, np.float32))
    (cache_dir / f"{k}.json").write_text(json.dumps({"description": description, "seconds": seconds},
                                                     sort_keys=True, default=str, indent=1))

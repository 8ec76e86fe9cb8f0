"""Reference renders cached by a hash of everything that made them. Pure.

A cached entry is <dir>/<key>.npy (linear RGBA float32) and <key>.json (the description that was
hashed, and the seconds the render took), so a report can say how the reference was made.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np


def key(description: dict) -> str:
    return hashlib.blake2b(json.dumps(description, sort_keys=True, default=str).encode(), digest_size=12).hexdigest()


def load(cache_dir: Path, description: dict):
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

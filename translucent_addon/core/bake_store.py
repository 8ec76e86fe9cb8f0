"""Bake storage on a Blender ID as ID-property arrays, and the inputs hash.

Pure: works on anything with ``__getitem__``/``__setitem__``/``get``/``__contains__``
(a ``bpy.types.Object`` or a dict in tests). ID-property arrays take NumPy
buffers directly and survive save and reload.

Layout: ``id["translucent_bake"][method] = {"inputs_hash", "format", "meta" (JSON),
"arrays": {name: flat array}, "shapes": {name: [dims]}, "dtypes": {name: str}}``.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import Any

import numpy as np

BAKE_KEY = "translucent_bake"
FORMAT_VERSION = 1
# ID-property arrays hold float32 ('f'), float64 ('d') and int32 ('i'); float16 arrays (large kernel
# tables) are stored two to an int32.
_STORABLE = {np.dtype(np.float32), np.dtype(np.float64), np.dtype(np.int32)}
_HALF = np.dtype(np.float16)


def inputs_hash(arrays: dict[str, np.ndarray], params: dict) -> str:
    """Hash of everything a bake depends on: arrays by name, dtype, shape and bytes, and params."""
    h = hashlib.blake2b(digest_size=16)
    h.update(f"format={FORMAT_VERSION}".encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    h.update(json.dumps(params, sort_keys=True, default=float).encode())
    return h.hexdigest()


@dataclasses.dataclass
class BakeRecord:
    method: str
    inputs_hash: str
    meta: dict
    arrays: dict[str, np.ndarray]


def write(idblock: Any, method: str, digest: str, arrays: dict[str, np.ndarray], meta: dict | None = None) -> None:
    """Store (replace) one method's bake on the ID."""
    group = {"arrays": {}, "shapes": {}, "dtypes": {}}
    for name, a in arrays.items():
        a = np.ascontiguousarray(a)
        if a.dtype == _HALF:
            flat = np.concatenate([a.reshape(-1), np.zeros(a.size % 2, np.float16)])
            group["arrays"][name] = flat.view(np.int32) if flat.size else np.zeros(0, np.int32)
        elif a.dtype not in _STORABLE:
            raise TypeError(f"bake array '{name}' has dtype {a.dtype}; store float16, float32, float64 or int32")
        else:
            group["arrays"][name] = a.reshape(-1) if a.size else np.zeros(0, a.dtype)
        group["shapes"][name] = list(a.shape)
        group["dtypes"][name] = a.dtype.str
    group["inputs_hash"] = digest
    group["format"] = FORMAT_VERSION
    group["meta"] = json.dumps(meta or {}, sort_keys=True)
    if BAKE_KEY in idblock:
        idblock[BAKE_KEY][method] = group
    else:
        idblock[BAKE_KEY] = {method: group}


def _as_array(value, dtype: str, shape) -> np.ndarray:
    stored = np.dtype(np.int32) if np.dtype(dtype) == _HALF else np.dtype(dtype)
    try:
        a = np.frombuffer(value, dtype=stored).copy()
    except TypeError:  # a plain list (dict-backed tests, empty arrays)
        a = np.asarray(value, dtype=stored)
    if np.dtype(dtype) == _HALF:
        a = a.view(np.float16)[:int(np.prod(shape))]
    return a.reshape(tuple(shape))


def read(idblock: Any, method: str) -> BakeRecord | None:
    if BAKE_KEY not in idblock or method not in idblock[BAKE_KEY]:
        return None
    g = idblock[BAKE_KEY][method]
    if int(g.get("format", 0)) != FORMAT_VERSION:
        return None
    arrays = {
        name: _as_array(g["arrays"][name], g["dtypes"][name], g["shapes"][name])
        for name in g["arrays"].keys()
    }
    return BakeRecord(method, str(g["inputs_hash"]), json.loads(g["meta"]), arrays)


def read_meta(idblock: Any, method: str) -> dict | None:
    """A bake's metadata without reading its arrays (None when there is no bake of this format)."""
    if BAKE_KEY not in idblock or method not in idblock[BAKE_KEY]:
        return None
    g = idblock[BAKE_KEY][method]
    return json.loads(g["meta"]) if int(g.get("format", 0)) == FORMAT_VERSION else None


def stored_hash(idblock: Any, method: str) -> str | None:
    if BAKE_KEY not in idblock or method not in idblock[BAKE_KEY]:
        return None
    g = idblock[BAKE_KEY][method]
    return str(g["inputs_hash"]) if int(g.get("format", 0)) == FORMAT_VERSION else None


def status(idblock: Any, method: str, current_hash: str) -> str:
    """'MISSING', 'STALE' (inputs changed since the bake) or 'OK'."""
    h = stored_hash(idblock, method)
    if h is None:
        return "MISSING"
    return "OK" if h == current_hash else "STALE"


def clear(idblock: Any, method: str | None = None) -> bool:
    """Remove one method's bake (or all); True if something was removed."""
    if BAKE_KEY not in idblock:
        return False
    if method is None:
        del idblock[BAKE_KEY]
        return True
    bakes = idblock[BAKE_KEY]
    if method not in bakes:
        return False
    del bakes[method]
    if len(bakes) == 0:
        del idblock[BAKE_KEY]
    return True

"""Bake storage on a Blender ID as ID-property arrays, and the inputs hash.

Pure: works on anything with ``__getitem__``/``__setitem__``/``get``/``__contains__``
(a ``bpy.types.Object`` or a dict in tests). ID-property arrays take NumPy
buffers directly and survive save and reload.

Layout: ``id["translucent_bake"][method] = {"inputs_hash", "format", "meta" (JSON), "data_hash",
"arrays": {name: flat array}, "shapes": {name: [dims]}, "dtypes": {name: str}}``. A bake of at least
``SIDECAR_MIN_BYTES`` written with a ``Sidecar`` keeps its arrays in an OpenEXR file instead (``bake_exr``;
``"image"``: what the sidecar makes of the file, on the Blender side an image data block, which Pack Resources and
a farm's packer follow; ``"arrays"`` empty): a TEXTURE_SPACE bake of the demo bunny is 125 MB, which the .blend,
every linked duplicate and the undo memory carried. The file is named by the data hash (which covers the meta, bake
time included): a file never holds other data than its name says, and copies of one bake share it. Earlier bakes
kept theirs in ``.npz`` files named by a path string (``"file"``), which Blender's tools did not see: they are still
read (``Sidecar.load_npz``) and converted once (``convert``).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from . import bake_exr

BAKE_KEY = "translucent_bake"
FORMAT_VERSION = 1
# ID-property arrays hold float32 ('f'), float64 ('d') and int32 ('i'); float16 arrays (large kernel
# tables) are stored two to an int32.
_STORABLE = {np.dtype(np.float32), np.dtype(np.float64), np.dtype(np.int32)}
_HALF = np.dtype(np.float16)
# No stored value is this large (positions in mm, weights, form factors, kernels); a product of two such stays
# finite in float32, so a value past it is damage that would draw inf (issue 37's fuzz found 1e30 doing so).
MAX_MAGNITUDE = 1e18


def inputs_hash(arrays: dict[str, np.ndarray], params: dict) -> str:
    """Hash of everything a bake depends on: arrays by name, dtype, shape and bytes, and params."""
    h = hashlib.blake2b(digest_size=16)
    h.update(f"format={FORMAT_VERSION}".encode())
    _hash_arrays(h, arrays, lambda name, a: f"{name}:{a.dtype.str}:{a.shape}")
    h.update(json.dumps(params, sort_keys=True, default=float).encode())
    return h.hexdigest()


def _hash_arrays(h: Any, arrays: dict, label: Callable[[str, np.ndarray], str]) -> None:
    """Feed arrays to a hash in name order: each one's ``label(name, array)``, then its bytes."""
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(label(name, a).encode())
        h.update(a.tobytes())


class DamagedBakeError(ValueError):
    """A stored bake that cannot be what was baked: its data changed since (a different data hash), or its
    arrays do not fit their own shapes and types, or hold NaN. It is never drawn."""


def data_hash(group_arrays: dict, shapes: dict, dtypes: dict, meta: str, digest: str) -> str:
    """Hash of a bake's data as stored (each array's name, dtype, shape and bytes, the meta, the inputs hash):
    written with the bake, compared when it is read, so that data changed in the file is refused."""
    h = hashlib.blake2b(digest_size=16)
    h.update(f"{digest}|{meta}".encode())
    _hash_arrays(h, group_arrays, lambda name, a: f"{name}:{dtypes[name]}:{list(shapes[name])}:{a.dtype.str}")
    return h.hexdigest()


# Bakes from this size on go to the sidecar file when there is one; smaller ones stay in the ID.
SIDECAR_MIN_BYTES = 256 * 1024


@dataclasses.dataclass
class Sidecar:
    """Bake files in one folder, ``<data hash>.exr`` each (``bake_exr``). ``ref_of`` turns a written file into what
    the ID stores (the Blender side: an image data block), ``source_of`` gives a stored reference's file or bytes
    (a packed image's), raising ``DamagedBakeError`` when it has neither; ``path_of`` finds an older ``.npz`` file
    from its stored string (relative to the .blend, ``//...``, on the Blender side)."""

    folder: Path
    ref_of: Callable[[Path], Any] = str
    source_of: Callable[[Any], Path | bytes] = Path
    path_of: Callable[[str], Path] = Path

    def save(self, name: str, arrays: dict[str, np.ndarray]) -> Any:
        """Write the stored (flat) arrays unless a file of this data hash is there already; its reference."""
        path = Path(self.folder) / f"{name}.exr"
        if not path.exists():
            bake_exr.write(path, arrays)  # whole or absent, also when Blender is killed while writing
        return self.ref_of(path)

    def load(self, ref: Any) -> dict[str, np.ndarray]:
        """The stored arrays of a reference ``save`` returned."""
        source = self.source_of(ref)
        if isinstance(source, (bytes, bytearray, memoryview)):
            what = "its packed image"
        else:
            what = f"its file {source}"
            if not Path(source).is_file():
                raise DamagedBakeError(f"{what} is missing (was the .blend moved without its bake folder?)")
        try:
            return bake_exr.decode(source) if what == "its packed image" else bake_exr.read(Path(source))
        except (OSError, bake_exr.ExrError) as err:
            raise DamagedBakeError(f"{what} cannot be read ({err})") from None

    def load_npz(self, ref: str) -> dict[str, np.ndarray]:
        """The stored arrays of an older bake's ``.npz`` file."""
        path = self.path_of(ref)
        if not Path(path).is_file():
            raise DamagedBakeError(f"its file {ref} is missing (was the .blend moved without its bake folder?)")
        try:
            with np.load(path, allow_pickle=False) as data:
                return {name: data[name] for name in data.files}
        except (OSError, ValueError, EOFError) as err:
            raise DamagedBakeError(f"its file {ref} cannot be read ({err})") from None


@dataclasses.dataclass
class BakeRecord:
    method: str
    inputs_hash: str
    meta: dict
    arrays: dict[str, np.ndarray]


def write(idblock: Any, method: str, digest: str, arrays: dict[str, np.ndarray], meta: dict | None = None,
          sidecar: Sidecar | None = None) -> None:
    """Store (replace) one method's bake on the ID; its arrays in a ``sidecar`` file when given and the bake is
    at least ``SIDECAR_MIN_BYTES``."""
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
    group["data_hash"] = data_hash(group["arrays"], group["shapes"], group["dtypes"], group["meta"], digest)
    if sidecar is not None and sum(a.nbytes for a in group["arrays"].values()) >= SIDECAR_MIN_BYTES:
        group["image"] = sidecar.save(group["data_hash"], group["arrays"])
        group["arrays"] = {}
    if BAKE_KEY in idblock:
        idblock[BAKE_KEY][method] = group
    else:
        idblock[BAKE_KEY] = {method: group}


def _as_array(a: np.ndarray, dtype: str, shape) -> np.ndarray:
    if np.dtype(dtype) == _HALF:
        a = a.view(np.float16)[:int(np.prod(shape))]
    return a.reshape(tuple(shape))


def read(idblock: Any, method: str, sidecar: Sidecar | None = None) -> BakeRecord | None:
    """The stored bake of ``method`` (None when there is none of this format). Raises ``DamagedBakeError`` when its
    data is not what was baked: checked against the data hash written with it (bakes from before it was
    written: their arrays' shapes, types and finiteness only), or when its file is missing."""
    if BAKE_KEY not in idblock or method not in idblock[BAKE_KEY]:
        return None
    g = idblock[BAKE_KEY][method]
    if int(g.get("format", 0)) != FORMAT_VERSION:
        return None
    try:
        if "image" in g or "file" in g:
            if sidecar is None:
                raise DamagedBakeError("its file cannot be read here")
            source = sidecar.load(g["image"]) if "image" in g else sidecar.load_npz(str(g["file"]))
        else:
            source = g["arrays"]
        stored = {name: _stored(source[name], g["dtypes"][name]) for name in source.keys()}
        shapes = {name: [int(d) for d in g["shapes"][name]] for name in stored}
        dtypes = {name: str(g["dtypes"][name]) for name in stored}
        meta_text = str(g["meta"])
        digest = str(g["inputs_hash"])
        expected = g.get("data_hash")
        if expected is not None and str(expected) != data_hash(stored, shapes, dtypes, meta_text, digest):
            raise DamagedBakeError("its data changed since it was baked")
        arrays = {name: _as_array(stored[name], dtypes[name], shapes[name]) for name in stored}
        meta = json.loads(meta_text)
    except DamagedBakeError:
        raise
    except (KeyError, TypeError, ValueError) as err:
        raise DamagedBakeError(f"its arrays cannot be read ({err})") from None
    for name, a in arrays.items():
        if a.dtype.kind == "f" and not np.isfinite(a).all():
            raise DamagedBakeError(f"its array '{name}' holds values that are not numbers")
        if a.dtype.kind == "f" and a.size and float(np.abs(a).max()) > MAX_MAGNITUDE:
            raise DamagedBakeError(f"its array '{name}' holds values beyond {MAX_MAGNITUDE:g}")
    return BakeRecord(method, digest, meta, arrays)


def _stored(value, dtype: str) -> np.ndarray:
    """An ID-property array as the NumPy array it holds (its stored dtype: float16 is kept two to an int32)."""
    stored = np.dtype(np.int32) if np.dtype(dtype) == _HALF else np.dtype(dtype)
    try:
        return np.frombuffer(value, dtype=stored).copy()
    except TypeError:  # a plain list (dict-backed tests, empty arrays)
        return np.asarray(value, dtype=stored)


def files(idblock: Any) -> dict[str, str]:
    """The ``.npz`` file of each older bake on the ID that has one: {method: reference}."""
    if BAKE_KEY not in idblock:
        return {}
    return {m: str(g["file"]) for m, g in idblock[BAKE_KEY].items() if "file" in g}


def images(idblock: Any) -> dict[str, Any]:
    """The file reference of each bake on the ID that keeps its arrays in one: {method: reference}."""
    if BAKE_KEY not in idblock:
        return {}
    return {m: g["image"] for m, g in idblock[BAKE_KEY].items() if "image" in g}


def refer(idblock: Any, method: str, ref: str) -> None:
    """Point an older bake at its ``.npz`` file's new reference (the file was copied beside a .blend saved
    elsewhere)."""
    idblock[BAKE_KEY][method]["file"] = ref


def convert(idblock: Any, method: str, sidecar: Sidecar) -> None:
    """Move an older bake's arrays from its ``.npz`` file into the sidecar's image file, unchanged (its data hash
    still holds). Raises ``DamagedBakeError`` when the old file cannot be read, ``OSError`` when the new one cannot
    be written; the bake is left as it was then."""
    g = idblock[BAKE_KEY][method]
    arrays = sidecar.load_npz(str(g["file"]))
    ref = sidecar.save(str(g.get("data_hash") or g["inputs_hash"]), arrays)
    g["image"] = ref
    del g["file"]


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


def source_key(idblock: Any, method: str, holder: str) -> str | None:
    """What a bake's GPU data is cached under: its method, data hash and where its arrays are read from (its file,
    or ``holder`` naming the ID for packed arrays). Equal keys are equal arrays from one source, so linked
    duplicates and instances share one copy, and a damaged source is refused for every object reading it."""
    if BAKE_KEY not in idblock or method not in idblock[BAKE_KEY]:
        return None
    g = idblock[BAKE_KEY][method]
    if "image" in g:
        source = f"image:{getattr(g['image'], 'name', g['image'])}"
    else:
        source = str(g["file"]) if "file" in g else f"packed:{holder}"
    return f"{method}#{g.get('data_hash', g.get('inputs_hash', ''))}@{source}"


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

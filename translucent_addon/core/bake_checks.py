"""What a stored bake's arrays must satisfy before anything is made of them: shapes, index ranges, row pointers.

Pure. The data hash (``bake_store``) refuses a bake changed since it was baked; these checks refuse one whose
arrays do not fit together however it came to be (a bake from before the data hash, a file written by a script
that wrote the hash too), before an index reaches SciPy's compiled sparse product, a GPU fetch or a GPU loop,
where it would read out of bounds (issue 37: out-of-range ``lensch_F_indices`` crashed Blender). Each check
raises ``DamagedBakeError`` naming the array; the caller (``gpu/bake_cache``) draws the object with its base
colour and says why.
"""
from __future__ import annotations

import numpy as np

from .bake_store import DamagedBakeError


def shaped(arrays: dict, name: str, shape: tuple) -> np.ndarray:
    """``arrays[name]``, which must exist and have ``shape`` (None: any length on that axis)."""
    if name not in arrays:
        raise DamagedBakeError(f"its array '{name}' is missing")
    a = np.asarray(arrays[name])
    if a.ndim != len(shape) or any(want is not None and got != want for got, want in zip(a.shape, shape)):
        raise DamagedBakeError(f"its array '{name}' has shape {a.shape}, not {_shape_text(shape)}")
    return a


def indices(arrays: dict, name: str, shape: tuple, upper: int, *, none: bool = False) -> np.ndarray:
    """``shaped`` integers in [0, upper) (``none``: -1 also allowed, meaning no entry)."""
    a = shaped(arrays, name, shape)
    if a.dtype.kind not in "iu":
        raise DamagedBakeError(f"its array '{name}' holds {a.dtype} values, not indices")
    lowest = -1 if none else 0
    if a.size and (int(a.min()) < lowest or int(a.max()) >= upper):
        raise DamagedBakeError(f"its array '{name}' holds indices outside [{lowest}, {upper})")
    return a


def row_pointers(arrays: dict, name: str, rows: int, entries: int) -> np.ndarray:
    """A CSR row-pointer array: ``rows + 1`` integers from 0 to ``entries``, never decreasing."""
    p = indices(arrays, name, (rows + 1,), entries + 1)
    if int(p[0]) != 0 or int(p[-1]) != entries or (np.diff(p.astype(np.int64)) < 0).any():
        raise DamagedBakeError(f"its array '{name}' does not point at rows of {entries:,} entries in order")
    return p


def count(value: object, name: str, lowest: int, highest: int) -> int:
    """A stored count within [lowest, highest] (a table's size, a texture's side)."""
    try:
        n = int(value)
    except (TypeError, ValueError, OverflowError):
        raise DamagedBakeError(f"its {name} is not a count") from None
    if not lowest <= n <= highest:
        raise DamagedBakeError(f"its {name} is {n}, outside [{lowest}, {highest}]")
    return n


def _shape_text(shape: tuple) -> str:
    return "(" + ", ".join("any" if d is None else str(d) for d in shape) + ")"

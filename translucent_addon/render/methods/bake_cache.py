"""GPU data of baked methods, one entry per bake key (object name '#' inputs hash), built on first use.

A new bake of an object replaces its previous entry, so a re-baked object does not keep two copies.
"""
from __future__ import annotations

_entries: dict = {}


def get(handle, build):
    """The GPU data of ``handle`` (a scene_data.BakeHandle): cached, or ``build(arrays)`` of its bake."""
    res = _entries.get(handle.key)
    if res is None:
        arrays = handle.load()
        owner = handle.key.split("#")[0]
        for key in [k for k in _entries if k.split("#")[0] == owner]:
            del _entries[key]  # the object's previous bake
        res = _entries[handle.key] = build(arrays)
    return res


def clear() -> None:
    _entries.clear()

"""GPU data of baked methods, one entry per bake key (object name '#' inputs hash), built on first use.

A new bake of an object replaces its previous entry, so a re-baked object does not keep two copies.
"""
from __future__ import annotations

import dataclasses

from ..core.bake_store import DamagedBakeError
from ..core.frame import Lost
from . import resources


@dataclasses.dataclass
class Active:
    """A mesh of the frame drawn by a baked method, with the GPU data of its bake."""

    index: int  # mesh index in the frame
    mesh: object
    resources: object


def prepare(frame, method: str, build, matches) -> list[Active]:
    """The meshes of ``method`` in a frame whose bake is current, with its GPU data (``build(arrays, mesh)``
    on first use). A bake that does not ``matches(resources, mesh)`` is not drawn: the mesh keeps its base
    colour and the frame says why."""
    active = []
    for k, mesh in enumerate(frame.meshes):
        handle = getattr(mesh, "bake", None)
        if mesh.method != method or handle is None or mesh.medium is None:
            continue
        res = checked(frame, mesh.name, method, handle, lambda arrays, m=mesh: build(arrays, m))
        if res is None:
            continue
        if not matches(res, mesh):
            frame.warnings.append(f"'{mesh.name}': {method} bake does not match the mesh; press Bake")
            continue
        active.append(Active(k, mesh, res))
    return active


def checked(frame, name: str, label: str, handle, build):
    """``get``, or None when the bake is damaged: its arrays fail their checks (``core/bake_checks``), its
    data hash, or fit no table. The frame then says why once (``Lost``); the refusal is kept until a new bake."""
    damaged = resources.current().damaged  # bake key -> why (not read again every frame; a new bake forgets it)
    why = damaged.get(handle.key)
    if why is None:
        try:
            return get(handle, build)
        except DamagedBakeError as err:
            why = damaged[handle.key] = str(err)
        except (ValueError, IndexError, KeyError, TypeError) as err:  # arrays that fit no table: damaged too
            why = damaged[handle.key] = f"its arrays do not fit together ({type(err).__name__}: {err})"
    frame.warnings.append(Lost(f"'{name}': {label} bake is damaged: {why}; drawn with its base colour. Press Bake"))
    return None


def get(handle, build):
    """The GPU data of ``handle`` (a scene_data.BakeHandle): cached, or ``build(arrays)`` of its bake."""
    entries = resources.current().bakes
    res = entries.get(handle.key)
    if res is None:
        arrays = handle.load()
        forget(_owner(handle.key))  # the object's previous bake
        res = entries[handle.key] = build(arrays)
    return res


def _owner(key: str) -> str:
    """The object name of a bake key, name '#' hash (a name may hold '#' itself; the hash does not)."""
    return key.rsplit("#", 1)[0]


def forget(owner: str) -> None:
    """Drop an object's GPU data: its bake was just rewritten or cleared. (A QUADGRAPH bake's key does not
    change with a new bake in another pose, since its hash follows the topology only.)"""
    held = resources.current()
    for table in (held.bakes, held.damaged):
        for key in [k for k in table if _owner(k) == owner]:
            del table[key]


def clear() -> None:
    held = resources.current()
    held.bakes.clear()
    held.damaged.clear()

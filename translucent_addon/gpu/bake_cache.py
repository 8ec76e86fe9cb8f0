"""GPU data of baked methods, one entry per bake *content* (``BakeHandle.key``: method, data hash, source), built on
first use and shared by every object drawing that bake: linked duplicates, collection and geometry-nodes
instances of one baked object hold one copy, not one each (issue 57: 20 duplicates of a baked sphere held 11 GB).

Each entry knows the objects drawing it (``users``); an object drawing a new bake leaves its old one, and a bake no
object draws any more is dropped, so a re-baked object does not keep two copies. What differs per drawn instance
(the maps its light is gathered into) is not here: a technique keeps it on its entry per instance slot
(``Active.slot``), made on first use and reused every frame.
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
    slot: int = 0  # this instance's number among the frame's instances drawing the same ``resources``


def prepare(frame, method: str, build, matches, variant=None, in_view: bool = False) -> list[Active]:
    """The meshes of ``method`` in a frame whose bake is current, with its GPU data (``build(arrays, mesh)``
    on first use). A bake that does not ``matches(resources, mesh)`` is not drawn: the mesh keeps its base
    colour and the frame says why. ``variant(mesh)``: for a technique whose GPU data follow the drawn mesh as well
    as the bake (QUADGRAPH's nodes follow its pose), what tells two meshes of one bake apart; instances of one
    variant share an entry, and the frame's n-th distinct variant of a bake takes its n-th entry. ``in_view``: for
    a technique whose light reaches no pixel outside the object's own, the meshes the camera cannot see are left
    out (not lit, not solved: a crowd running out of the frame costs what the camera sees)."""
    active, slots, variants = [], {}, {}
    for k, mesh in enumerate(frame.meshes):
        handle = getattr(mesh, "bake", None)
        if mesh.method != method or handle is None or mesh.medium is None:
            continue
        if in_view and not frame.camera.sees_box(*mesh.world_box()):
            continue
        if variant is not None:
            seen = variants.setdefault(handle.key, {})
            number = seen.setdefault(variant(mesh), len(seen))
            if number:
                handle = _Variant(handle, number)
        res = checked(frame, mesh.name, method, handle, lambda arrays, m=mesh: build(arrays, m))
        if res is None:
            continue
        if not matches(res, mesh):
            frame.warnings.append(f"'{mesh.name}': {method} bake does not match the mesh; press Bake")
            continue
        slot = slots[id(res)] = slots.get(id(res), -1) + 1
        active.append(Active(k, mesh, res, slot))
    return active


def keep_drawn(actives: list[Active], *tables: str) -> None:
    """Drop from each entry's per-mesh tables (dicts by mesh key, named ``tables``: display batches) the meshes this
    frame does not draw with it; the instances of one bake drawn from different meshes each keep theirs."""
    drawn: dict = {}
    for a in actives:
        drawn.setdefault(id(a.resources), (a.resources, set()))[1].add(a.mesh.key)
    for res, keys in drawn.values():
        for name in tables:
            table = getattr(res, name)
            for key in [k for k in table if k not in keys]:
                del table[key]


class _Variant:
    """A bake's handle for the n-th distinct variant of its meshes in a frame: its own entry."""

    def __init__(self, handle, number: int):
        self.key, self.load, self.owner = f"{handle.key}|{number}", handle.load, handle.owner


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
    _use(handle.owner, handle.key)
    frame.warnings.append(Lost(f"'{name}': {label} bake is damaged: {why}; drawn with its base colour. Press Bake"))
    return None


def get(handle, build):
    """The GPU data of ``handle`` (a core.frame.BakeHandle): cached, or ``build(arrays)`` of its bake."""
    entries = resources.current().bakes
    _use(handle.owner, handle.key)
    res = entries.get(handle.key)
    if res is None:
        res = entries[handle.key] = build(handle.load())
    return res


def _use(owner: str, key: str) -> None:
    """``owner`` draws the bake ``key`` (one bake per owner): the one it drew before is left, dropped when no other
    object draws it."""
    held = resources.current()
    before = held.bake_users.get(owner)
    if before == key:
        return
    held.bake_users[owner] = key
    if before is not None:
        _drop_unused(before)


def _drop_unused(key: str) -> None:
    held = resources.current()
    if key not in held.bake_users.values():
        held.bakes.pop(key, None)
        held.damaged.pop(key, None)


def forget(owner: str) -> None:
    """An object's bake was just rewritten or cleared: it draws none now, and what only it drew is dropped (with the
    refusal of a damaged one), so that the next frame reads its new bake."""
    held = resources.current()
    for name in [o for o in held.bake_users if o == owner or o.startswith(f"{owner}/")]:
        key = held.bake_users.pop(name)
        _drop_unused(key)
        held.damaged.pop(key, None)


def clear() -> None:
    held = resources.current()
    held.bakes.clear()
    held.damaged.clear()
    held.bake_users.clear()

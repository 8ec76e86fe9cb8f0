"""Where an object's bakes live: on its mesh (linked duplicates share them), with their arrays in a folder beside
the .blend (``<name>_translucent/``, as Blender keeps its own simulation caches) unless the scene packs them into
the file. A bake of the demo bunny took the .blend from 2 MB to 98 MB, every Alt+D duplicate again as much, and
rode the undo memory; now the file holds its hashes and metadata only.

A bake's hash covers the object's scale, material and evaluated modifiers: duplicates sharing a mesh share its bake
while those agree. A duplicate that differs (another scale, another material) and is baked while the mesh's bake
serves the others keeps its own bake on itself (``write(own=True)``), so neither makes the other's stale; an object's
own bake is the one it reads. A mesh linked from a library cannot be written: its objects keep their bakes on
themselves.

An unsaved file bakes into Blender's temporary folder; saving (``relocate``, a ``save_pre`` handler) copies the
files a bake refers to beside the .blend it is saved as and points the bakes there, also on Save As to another
folder; saving a copy points them back afterwards (``restore``, ``save_post``). Files of 0.1.x kept their bakes on
the object: they are read from there, per method, until baked again.
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import bpy

from ..core import bake_store as store
from ..gpu import bake_cache
from .session import current as current_session


def _writable(ob):
    """The ID a new bake of the object goes to: its mesh, unless that comes from a library."""
    data = ob.data
    return ob if data is None or getattr(data, "library", None) is not None else data


def owner(ob, method: str | None = None):
    """The ID holding an object's bake of ``method`` (any method when None): the object when it holds its own (a
    duplicate that differs from those sharing its mesh, a mesh linked from a library, a 0.1.x file), else its
    mesh."""
    if _holds(ob, method):
        return ob
    return _writable(ob)


def _holds(idblock, method: str | None) -> bool:
    if store.BAKE_KEY not in idblock:
        return False
    return method is None or method in idblock[store.BAKE_KEY]


def folder_for(filepath: str) -> Path:
    """The bake folder of a .blend (Blender's temporary folder while the file is unsaved)."""
    if not filepath:
        return Path(bpy.app.tempdir) / "translucent_bakes"
    path = Path(filepath)
    return path.parent / f"{path.stem}_translucent"


def _ref(path: Path, filepath: str) -> str:
    """A file as a bake refers to it: relative to the .blend ("//..."), absolute while the file is unsaved."""
    if not filepath:
        return str(path)
    return "//" + Path(os.path.relpath(path, Path(filepath).parent)).as_posix()


def _path(ref: str, filepath: str) -> Path:
    if ref.startswith("//"):
        return Path(filepath).parent / ref[2:] if filepath else Path(ref[2:])
    return Path(ref)


def sidecar(scene=None) -> store.Sidecar | None:
    """Where a bake made now writes its arrays: None when the scene packs bakes into the .blend."""
    if scene is not None and scene.translucent.bake_storage == "PACKED":
        return None
    return reader()


def reader() -> store.Sidecar:
    """How stored bakes find their files (whatever the scene's storage setting)."""
    filepath = bpy.data.filepath
    return store.Sidecar(folder_for(filepath), ref_of=lambda p: _ref(p, filepath),
                         path_of=lambda r: _path(r, filepath))


def write(ob, method: str, digest: str, arrays: dict, meta: dict, scene=None, own: bool = False) -> str | None:
    """Store a bake with the object's mesh (``own``: on the object, the mesh's serving other objects), its arrays
    beside the .blend (or packed, as the scene says). Where the folder cannot be written (a read-only folder, a
    full disk) the bake is packed instead: returns why, else None."""
    holder, why = (ob if own else _writable(ob)), None
    try:
        store.write(holder, method, digest, arrays, meta, sidecar=sidecar(scene))
    except OSError as err:
        store.write(holder, method, digest, arrays, meta)
        why = f"'{ob.name}': the bake folder could not be written ({err}); the bake is kept inside the .blend"
    if holder is not ob and _holds(ob, method):  # the object's own bake (or a 0.1.x one): the mesh's is it now
        store.clear(ob, method)
    return why


def read(ob, method: str):
    return store.read(owner(ob, method), method, reader())


def read_meta(ob, method: str) -> dict | None:
    return store.read_meta(owner(ob, method), method)


def stored_hash(ob, method: str) -> str | None:
    return store.stored_hash(owner(ob, method), method)


def source_key(ob, method: str) -> str | None:
    """``store.source_key`` of the object's bake of ``method``: what its GPU data is shared under."""
    holder = owner(ob, method)
    kind = "object" if holder == ob else "mesh"
    return store.source_key(holder, method, f"{kind}:{holder.name}")


def status(ob, method: str, digest: str) -> str:
    """``store.status`` of the object's bake of ``method`` (where it is held) for inputs ``digest``."""
    return store.status(owner(ob, method), method, digest)


def _methods(idblock) -> set:
    return set(idblock[store.BAKE_KEY].keys()) if store.BAKE_KEY in idblock else set()


def clear(ob, method: str | None = None) -> bool:
    """Remove an object's bake of ``method`` (every method when None): its own where it holds one, else its
    mesh's (which linked duplicates share). The files stay: another bake (a duplicate, an undo step) may refer
    to them."""
    methods = {method} if method else _methods(ob) | _methods(_writable(ob))
    removed = False
    for m in sorted(methods):
        removed = store.clear(owner(ob, m), m) or removed
    return removed


def _holders():
    """The IDs of this file (not linked from a library) that hold bakes."""
    for collection in (bpy.data.meshes, bpy.data.objects):
        for idblock in collection:
            if idblock.library is None and store.BAKE_KEY in idblock:
                yield idblock


def _copy(source: Path, target: Path) -> None:
    """Copy a bake file whole or not at all (an interrupted copy leaves no truncated target)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f"{target.stem}.{os.getpid()}.partial{target.suffix}")
    shutil.copyfile(source, partial)
    partial.replace(target)


@bpy.app.handlers.persistent
def relocate(filepath, *_args) -> None:
    """save_pre: copy every bake file beside the .blend being saved (``filepath``) and refer to it there; what
    each referred to before is kept on the session (``restore``)."""
    before = current_session().before_copy
    before.clear()
    if not filepath:
        return
    old, new_folder = bpy.data.filepath, folder_for(filepath)
    for idblock in _holders():
        kind = "meshes" if isinstance(idblock, bpy.types.Mesh) else "objects"
        for method, ref in store.files(idblock).items():
            before.append((idblock.name, kind, method, ref))
            source = _path(ref, old)
            target = new_folder / source.name
            fresh = source.is_file() and (not target.is_file() or target.stat().st_size != source.stat().st_size)
            if fresh and source.resolve() != target.resolve():
                _copy(source, target)
            if target.is_file():
                store.refer(idblock, method, _ref(target, filepath))


@bpy.app.handlers.persistent
def restore(filepath, *_args) -> None:
    """save_post: after saving a copy (the session's file is still the old one), point the bakes back."""
    before = current_session().before_copy
    if filepath and bpy.data.filepath != filepath:
        for name, kind, method, ref in before:
            idblock = getattr(bpy.data, kind).get(name)
            if idblock is not None and method in store.files(idblock):
                store.refer(idblock, method, ref)
    before.clear()


@bpy.app.handlers.persistent
def forget_loaded(*_args) -> None:
    """load_post: another file's bakes are not this one's, even under the same names and hashes."""
    bake_cache.clear()


_HANDLERS = (("save_pre", relocate), ("save_post", restore), ("load_post", forget_loaded))


def register() -> None:
    for kind, handler in _HANDLERS:
        handlers = getattr(bpy.app.handlers, kind)
        if handler not in handlers:
            handlers.append(handler)


def unregister() -> None:
    for kind, handler in _HANDLERS:
        handlers = getattr(bpy.app.handlers, kind)
        if handler in handlers:
            handlers.remove(handler)

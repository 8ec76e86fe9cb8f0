"""Where an object's bakes live: on its mesh (linked duplicates share them), with their arrays in a folder beside
the .blend (``<name>_translucent/``, as Blender keeps its own simulation caches) unless the scene packs them into
the file. A bake of the demo bunny took the .blend from 2 MB to 98 MB, every Alt+D duplicate again as much, and
rode the undo memory; now the file holds its hashes and metadata only.

An unsaved file bakes into Blender's temporary folder; saving (``relocate``, a ``save_pre`` handler) copies the
files a bake refers to beside the .blend it is saved as and points the bakes there, also on Save As to another
folder. Files of 0.1.x kept their bakes on the object: they are read from there until baked again.
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import bpy

from ..core import bake_store as store


def owner(ob):
    """The ID holding an object's bakes: its mesh, or the object itself where a file of 0.1.x put them."""
    data = ob.data
    if data is not None and store.BAKE_KEY not in data and store.BAKE_KEY in ob:
        return ob
    return data if data is not None else ob


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


def write(ob, method: str, digest: str, arrays: dict, meta: dict, scene=None) -> None:
    """Store a bake on the object's mesh, its arrays beside the .blend (or packed, as the scene says)."""
    store.write(ob.data, method, digest, arrays, meta, sidecar=sidecar(scene))
    if store.BAKE_KEY in ob:  # a 0.1.x bake on the object: the mesh's is the one now
        store.clear(ob, method)


def read(ob, method: str):
    return store.read(owner(ob), method, reader())


def read_meta(ob, method: str) -> dict | None:
    return store.read_meta(owner(ob), method)


def stored_hash(ob, method: str) -> str | None:
    return store.stored_hash(owner(ob), method)


def clear(ob, method: str | None = None) -> bool:
    """Remove an object's bake(s), from its mesh and from the object (0.1.x). The files stay: another bake (a
    duplicate, an undo step) may refer to them."""
    removed = store.clear(ob.data, method) if ob.data is not None else False
    return store.clear(ob, method) or removed


def _holders():
    for collection in (bpy.data.meshes, bpy.data.objects):
        for idblock in collection:
            if store.BAKE_KEY in idblock:
                yield idblock


@bpy.app.handlers.persistent
def relocate(filepath, *_args) -> None:
    """save_pre: copy every bake file beside the .blend being saved (``filepath``) and refer to it there."""
    if not filepath:
        return
    old, new_folder = bpy.data.filepath, folder_for(filepath)
    for idblock in _holders():
        for method, ref in store.files(idblock).items():
            source = _path(ref, old)
            target = new_folder / source.name
            if source.resolve() != target.resolve() and source.is_file() and not target.is_file():
                new_folder.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(source, target)
            if target.is_file():
                store.refer(idblock, method, _ref(target, filepath))


def register() -> None:
    if relocate not in bpy.app.handlers.save_pre:
        bpy.app.handlers.save_pre.append(relocate)


def unregister() -> None:
    if relocate in bpy.app.handlers.save_pre:
        bpy.app.handlers.save_pre.remove(relocate)

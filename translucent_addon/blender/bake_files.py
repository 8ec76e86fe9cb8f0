"""Where an object's bakes live: on its mesh (linked duplicates share them), with their arrays in an OpenEXR file
beside the .blend (``<name>_translucent/<data hash>.exr``, as Blender keeps its own simulation caches) unless the
scene keeps new bakes inside the file. The bake refers to its file through an image data block (named
``.translucent <hash>``, hidden from the image lists): the file reference Blender's own tools follow, so *File >
External Data > Pack Resources* packs bakes (Unpack writes them back), *Report / Find Missing Files* and *Make Paths
Relative* handle them, and a farm's packer (the Blender Asset Tracer, which asks Blender for the file paths an ID
uses) carries them. A path kept in a custom property, as bakes were before, none of them saw.

A bake's hash covers the object's scale, material and evaluated modifiers: duplicates sharing a mesh share its bake
while those agree. A duplicate that differs (another scale, another material) and is baked while the mesh's bake
serves the others keeps its own bake on itself (``write(own=True)``), so neither makes the other's stale; an object's
own bake is the one it reads. A mesh linked from a library cannot be written: its objects keep their bakes on
themselves.

An unsaved file bakes into Blender's temporary folder; saving (``relocate``, a ``save_pre`` handler) copies the
files a bake refers to beside the .blend it is saved as and points the bakes there, also on Save As to another
folder; saving a copy points them back afterwards (``restore``, ``save_post``). Bakes whose arrays were kept in
``.npz`` files are converted when their file is opened (``convert_loaded``). ``purge`` removes the files of a bake
folder that nothing refers to; after each save it removes those nothing referred to in this session, which no
Undo step can bring back (the *Purge bake files on save* preference).
"""
from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import bpy

from ..core import bake_store as store
from ..core.bake_store import DamagedBakeError
from ..gpu import bake_cache
from . import preferences
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


IMAGE_PREFIX = ".translucent "  # a leading dot hides an ID from Blender's browse lists


def image_for(path: Path):
    """The image data block of a bake file: one per file (bakes of equal data share it), relative to the .blend
    once it is saved, never colour-managed."""
    image = bpy.data.images.load(str(path), check_existing=True)
    if not image.name.startswith(IMAGE_PREFIX):
        image.name = f"{IMAGE_PREFIX}{Path(path).stem[:12]}"
        image.colorspace_settings.is_data = True
    if bpy.data.filepath and not image.filepath.startswith("//"):
        image.filepath = bpy.path.relpath(str(path))
    return image


def image_path(image) -> Path:
    """Where a bake image's file is (beside the .blend holding the image: a library's bakes beside the library)."""
    return Path(bpy.path.abspath(image.filepath, library=image.library))


def _source(image):
    """A bake image's bytes when it is packed into the .blend, else its file."""
    if image is None:
        raise DamagedBakeError("its image data block was removed")
    if image.packed_file is not None:
        return image.packed_file.data
    path = image_path(image)
    if not path.is_file():
        raise DamagedBakeError(f"its file {image.filepath} is missing (was the .blend moved without its bake folder? "
                               f"File > External Data > Find Missing Files can look for it)")
    return path


def reader() -> store.Sidecar:
    """How stored bakes find their files (whatever the scene's storage setting)."""
    filepath = bpy.data.filepath
    return store.Sidecar(folder_for(filepath), ref_of=image_for, source_of=_source,
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
    seen = current_session().bake_files_seen
    if seen is not None:
        seen.update(referenced([holder]))
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


def images() -> list:
    """The image data blocks this file's bakes keep their arrays in (each once)."""
    found = {}
    for idblock in _holders():
        for image in store.images(idblock).values():
            if image is not None:
                found[image.name] = image
    return list(found.values())


def referenced(holders=None) -> set[Path]:
    """The bake files (resolved) that the bakes on ``holders`` (every holder of this file when None) read: files of
    images not packed, and older bakes' ``.npz`` files."""
    refs = set()
    for idblock in _holders() if holders is None else holders:
        for image in store.images(idblock).values():
            if image is not None and image.packed_file is None and image.library is None:
                refs.add(image_path(image).resolve())
        for ref in store.files(idblock).values():
            refs.add(_path(ref, bpy.data.filepath).resolve())
    return refs


def _copy(source: Path, target: Path) -> None:
    """Copy a bake file whole or not at all (an interrupted copy leaves no truncated target)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f"{target.stem}.{os.getpid()}.partial{target.suffix}")
    shutil.copyfile(source, partial)
    partial.replace(target)


def _copied(source: Path, new_folder: Path) -> Path | None:
    """``source`` copied into ``new_folder`` unless an equal-sized file of its name is there (the file itself
    when it is there already); None when there is nothing to copy."""
    target = new_folder / source.name
    fresh = source.is_file() and (not target.is_file() or target.stat().st_size != source.stat().st_size)
    if fresh and source.resolve() != target.resolve():
        _copy(source, target)
    return target if target.is_file() else None


@bpy.app.handlers.persistent
def relocate(filepath, *_args) -> None:
    """save_pre: copy every bake file beside the .blend being saved (``filepath``) and refer to it there; what
    each referred to before is kept on the session (``restore``). A bake image's new path is written as Blender's
    Save As expects a path of the file being saved: relative to the file's old folder (Save As rebases those onto
    the new one) or, for a first save, absolute (made relative as every path then is)."""
    before = current_session().before_copy
    before.clear()
    if not filepath:
        return
    old, new_folder = bpy.data.filepath, folder_for(filepath)
    for image in images():
        if image.packed_file is not None or image.library is not None:
            continue
        target = _copied(image_path(image), new_folder)
        if target is not None and image_path(image).resolve() != target.resolve():
            before.append(("image", image.name, str(target), image.filepath))
            image.filepath = _ref(target, old) if old else str(target)
    for idblock in _holders():  # older bakes' .npz files, where converting them failed
        kind = "meshes" if isinstance(idblock, bpy.types.Mesh) else "objects"
        for method, ref in store.files(idblock).items():
            before.append((kind, idblock.name, method, ref))
            target = _copied(_path(ref, old), new_folder)
            if target is not None:
                store.refer(idblock, method, _ref(target, filepath))


@bpy.app.handlers.persistent
def restore(filepath, *_args) -> None:
    """save_post: after saving a copy (the session's file is still the old one), point the bakes back (Blender put
    the images' paths back already, as it wrote them rebased; ours are set again). Then the bake folder is purged of
    what nothing referred to in this session (``purge_after_save``)."""
    held = current_session()
    copy = bool(filepath) and bpy.data.filepath != filepath
    for kind, name, method, ref in held.before_copy:
        if kind == "image":
            image = bpy.data.images.get(name)
            if image is None:
                continue
            if copy:
                image.filepath = ref
            elif image_path(image).resolve() != Path(method).resolve():  # saved without Remap Relative
                image.filepath = bpy.path.relpath(method)
                print(f"Translucent: '{filepath}' was saved without remapping relative paths; its bake "
                      f"'{name}' now refers to {image.filepath}: save again to keep it", flush=True)
        elif copy:
            idblock = getattr(bpy.data, kind).get(name)
            if idblock is not None and method in store.files(idblock):
                store.refer(idblock, method, ref)
    held.before_copy.clear()
    if not copy and filepath:
        held.bake_files_saved = referenced()
        if held.bake_files_seen is not None:
            held.bake_files_seen |= held.bake_files_saved
            purge_after_save()


BAKE_FILE = re.compile(r"^[0-9a-f]{32}\.(exr|npz)$")  # a data hash names every bake file


def purge(keep: set[Path] = frozenset()) -> tuple[int, int]:
    """Remove the bake files of this file's bake folder that no bake of it refers to, nor ``keep`` names (only
    files named as bakes are: a data hash, ``.exr`` or ``.npz``): (files removed, bytes freed)."""
    folder = folder_for(bpy.data.filepath)
    if not folder.is_dir():
        return 0, 0
    wanted = referenced() | {Path(p).resolve() for p in keep}
    removed = freed = 0
    for path in sorted(folder.iterdir()):
        if BAKE_FILE.match(path.name) and path.is_file() and path.resolve() not in wanted:
            size = path.stat().st_size
            try:
                path.unlink()
            except OSError:
                continue
            removed, freed = removed + 1, freed + size
    return removed, freed


def purge_after_save() -> None:
    """The automatic purge after a save (a preference): only files nothing referred to since the file was opened,
    which neither Undo nor the previous save (``.blend1``, written since or read when it was opened) can need."""
    prefs = preferences.get()
    if prefs is not None and not prefs.purge_on_save:
        return
    removed, freed = purge(current_session().bake_files_seen)
    if removed:
        print(f"Translucent: removed {removed} bake file(s) no longer used, {freed / 2**20:.1f} MB freed "
              f"({folder_for(bpy.data.filepath)})", flush=True)


def convert_loaded() -> tuple[int, list[str]]:
    """Move the arrays of this file's bakes from ``.npz`` files (before bakes were image files) into image files
    beside it: (how many converted, why others were not). The old files stay until purged."""
    converted, failed = 0, []
    for idblock in list(_holders()):
        for method in sorted(store.files(idblock)):
            try:
                store.convert(idblock, method, reader())
                converted += 1
            except (DamagedBakeError, OSError, RuntimeError) as err:
                failed.append(f"'{idblock.name}' {method}: {err}")
    return converted, failed


@bpy.app.handlers.persistent
def forget_loaded(*_args) -> None:
    """load_post: another file's bakes are not this one's, even under the same names and hashes; bakes kept in
    ``.npz`` files are converted (one console line); what the file refers to is remembered for the purges."""
    bake_cache.clear()
    held = current_session()
    held.bake_files_saved = referenced()
    converted, failed = convert_loaded()
    held.bake_files_seen = held.bake_files_saved | referenced()
    if converted or failed:
        print(f"Translucent: {converted} bake(s) of this file moved from .npz into image files that Pack Resources "
              f"and farm packers follow; save the file to keep them"
              + (f"; {len(failed)} not: {'; '.join(failed)}" if failed else ""), flush=True)


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

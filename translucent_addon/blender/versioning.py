"""Files from earlier versions open with the look they were saved with (bpy-facing, thin).

Every save stamps the scenes with ``FILE_VERSION`` (save_pre). A file without the stamp was saved before the
medium moved to the Material (0.1): each object's medium was its own. Its materials would now convert their
Principled BSDF instead, so on opening, a material of an object with a translucency method that has no medium
source stored is set to *Per object*: every object keeps its coefficients (load_post), one line each.
"""
from __future__ import annotations

import bpy

from . import medium_source

FILE_VERSION = 2  # 1 (no stamp): the medium on the Object; 2: the medium on the Material


def _stamped() -> bool:
    return any(scene.translucent.get("file_version", 0) >= FILE_VERSION for scene in bpy.data.scenes)


@bpy.app.handlers.persistent
def stamp(*_args) -> None:
    """save_pre: the file's version on every scene of the file."""
    for scene in bpy.data.scenes:
        if scene.library is None:
            scene.translucent.file_version = FILE_VERSION


@bpy.app.handlers.persistent
def version_loaded(*_args) -> None:
    """load_post: a file from before the medium moved to the Material keeps each object's medium."""
    if _stamped():
        return
    kept = set()
    for ob in bpy.data.objects:
        if ob.type != "MESH" or ob.library is not None or ob.translucent.method == "OFF":
            continue
        mat = medium_source.medium_material(ob)
        if mat is None or mat.library is not None or "source" in mat.translucent or mat.name in kept:
            continue
        mat.translucent.source = "OBJECT"
        kept.add(mat.name)
        print(f"Translucent: material '{mat.name}' keeps each object's own medium, as this file from 0.1 was "
              f"saved; choose From Principled BSDF in its Translucent panel to use the material's")


def register() -> None:
    bpy.app.handlers.save_pre.append(stamp)
    bpy.app.handlers.load_post.append(version_loaded)


def unregister() -> None:
    for handlers, handler in ((bpy.app.handlers.save_pre, stamp), (bpy.app.handlers.load_post, version_loaded)):
        if handler in handlers:
            handlers.remove(handler)

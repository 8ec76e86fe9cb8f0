"""Files from earlier versions open with the look they were saved with (bpy-facing, thin).

The scenes carry ``FILE_VERSION``: stamped when a file is opened (after what follows), when the extension is
enabled and on every save, so that a file Blender writes without a save handler (autosave, quit.blend) keeps it too.
A file without the stamp was saved by 0.1, where

* each object's medium was its own: its materials would now convert their Principled BSDF instead, so a
  material of an object with a translucency method that has no medium source stored is set to *Per object*,
  every object keeping its coefficients (one line each);
* an object's scale was ``mm_per_unit`` (stored) and its lengths were in mm: the scattering scale is set to
  the scene's unit over that value, and the vein spacing, the caustics' colour distance and the layer
  thickness are turned into scene units with it.
"""
from __future__ import annotations

import bpy

from . import medium_source

FILE_VERSION = 2  # 1 (no stamp): the medium on the Object, lengths in mm; 2: on the Material, scene units
MM_LENGTHS = (("veins_scale", 20.0), ("caustics_distance", 50.0), ("layer_thickness", 1.0))  # 0.1's, defaults


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
    """load_post: a file from before the medium moved to the Material keeps each object's medium; then the
    file is stamped, as it now is in this version's terms."""
    if not _stamped():
        _from_0_1()
    stamp()


def _from_0_1() -> None:
    for ob in bpy.data.objects:
        if ob.library is None and ob.translucent.keys():  # settings stored: the file's, not the defaults
            _scale_from_mm(ob.translucent, medium_source.unit_mm(bpy.context.scene))
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


def _scale_from_mm(settings, unit_mm: float) -> None:
    """0.1's stored millimetres per unit and lengths in mm, as the scattering scale and scene units."""
    mm = settings.get("mm_per_unit", 1000.0)
    if not (mm > 0.0):  # a file can hold anything; the range is the property's
        mm = 1000.0
    if "mm_per_unit" in settings:
        del settings["mm_per_unit"]
    settings.scattering_scale = unit_mm / mm
    for name, default_mm in MM_LENGTHS:
        setattr(settings, name, settings.get(name, default_mm) / mm)


def register() -> None:
    bpy.app.handlers.save_pre.append(stamp)
    bpy.app.handlers.load_post.append(version_loaded)
    if isinstance(bpy.data, bpy.types.BlendData):  # enabled in a session (at start-up the data is not open yet)
        version_loaded()


def unregister() -> None:
    for handlers, handler in ((bpy.app.handlers.save_pre, stamp), (bpy.app.handlers.load_post, version_loaded)):
        if handler in handlers:
            handlers.remove(handler)

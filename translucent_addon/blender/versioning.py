"""Files from earlier versions open with the look they were saved with (bpy-facing, thin).

The scenes carry ``FILE_VERSION``: stamped when a file is opened (after what follows), when the extension is
enabled and on every save, so that a file Blender writes without a save handler (autosave, quit.blend) keeps it too.
A file stamped 2 stored a user preset as its position in the list (the 13th item on), which saving or removing
another preset moved: it now names the preset its position named in this user's list (``_user_preset_numbers``).
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

from ..core.physics.presets import load_user_presets
from . import medium_source, props

FILE_VERSION = 3  # 1 (no stamp): the medium on the Object, lengths in mm; 2: on the Material, scene units;
# 3: user presets stored by a number of their name
FIRST_USER_POSITION = 13  # before 3: Custom, the 12 measured presets, then the user's, numbered by position
MM_LENGTHS = (("veins_scale", 20.0), ("caustics_distance", 50.0), ("layer_thickness", 1.0))  # 0.1's, defaults


def _file_version() -> int:
    """The stamp of the file (0: none, a file from 0.1)."""
    return max((int(scene.translucent.get("file_version", 0)) for scene in bpy.data.scenes), default=0)


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
    version = _file_version()
    if version < 2:
        _from_0_1()
    if version < 3:
        _user_preset_numbers()
    stamp()


def _user_preset_numbers() -> None:
    """Presets stored as a position past the measured ones: the user preset at that position of the list."""
    names = sorted(load_user_presets(props.user_presets_path()))
    for owner in (*bpy.data.objects, *bpy.data.materials):
        group = owner.translucent
        stored = group.get("preset")
        if owner.library is not None or not isinstance(stored, int) or not (
                FIRST_USER_POSITION <= stored < props.USER_PRESET_NUMBERS):
            continue
        k = stored - FIRST_USER_POSITION
        group["preset"] = props.user_preset_number(names[k]) if k < len(names) else 0  # gone: Custom


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

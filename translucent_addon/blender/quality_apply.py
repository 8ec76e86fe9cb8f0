"""AUTO quality applied to a Blender object (thin: the choice is ``quality_auto``'s)."""
from __future__ import annotations

from .. import techniques
from ..techniques import quality_auto
from ..techniques.registry import BakeInputError
from .bake_inputs import object_view


def apply_auto(context, ob, previous: dict | None = None) -> quality_auto.Choice:
    """AUTO quality on one object: choose its method's resolutions and write them. A resolution the method
    chooses again every frame (IMAGE_SPACE's splat overlap, from the camera that draws it) is not written: the
    summary says what the scene camera needs now, and the method's ``auto_note`` says so. ``previous``, if
    given, receives the values it overwrites (``restore`` puts them back)."""
    s = ob.translucent
    view = object_view(ob.evaluated_get(context.evaluated_depsgraph_get()))
    tile_mm = s.grass_tile * s.mm_per_unit if s.grass else None
    if s.method == "OFF":
        if tile_mm is None:
            raise BakeInputError(f"'{ob.name}': no translucency method to choose resolutions for")
        choice = quality_auto.Choice("OFF", {"grass_resolution": quality_auto.grass_resolution(view, tile_mm)}, {},
                                     None, {}, [])
    else:
        try:
            choice = quality_auto.choose(s.method, view, s.target_error, grass_tile_mm=tile_mm)
        except ValueError as err:
            raise BakeInputError(f"'{ob.name}': {err}") from err
    if previous is not None:
        previous.update({name: getattr(s, name) for name in (*choice.settings, "auto_summary")})
    for name, value in choice.settings.items():
        setattr(s, name, value)
    technique = techniques.get(choice.method)
    if technique is not None and technique.auto_note:
        choice.notes.append(technique.auto_note)
    s.auto_summary = choice.summary()
    return choice


def restore(ob, previous: dict) -> None:
    """Put back what ``apply_auto`` overwrote (a bake that did not finish changes nothing)."""
    for name, value in previous.items():
        setattr(ob.translucent, name, value)

"""AUTO quality applied to a Blender object (thin: the choice is ``quality_auto``'s)."""
from __future__ import annotations

from . import quality_auto
from .bake.inputs import object_view
from .bake.registry import BakeInputError


def apply_auto(context, ob) -> quality_auto.Choice:
    """AUTO quality on one object: choose its method's resolutions and write them, and the scene's splat
    overlap, which every IMAGE_SPACE object shares: the largest any Auto IMAGE_SPACE object needs."""
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
    for name, value in choice.settings.items():
        setattr(s, name, value)
    if choice.scene_settings:  # IMAGE_SPACE's overlap is the scene's: the largest any Auto object needs
        depsgraph = context.evaluated_depsgraph_get()
        others = [quality_auto.choose("IMAGE_SPACE", object_view(o.evaluated_get(depsgraph)), o.translucent.target_error)
                  for o in context.scene.objects if o is not ob and o.type == "MESH"
                  and o.translucent.method == "IMAGE_SPACE" and o.translucent.quality == "AUTO"]
        need = max([choice, *others], key=lambda c: c.scene_settings["splat_overlap"])
        for name, value in need.scene_settings.items():
            setattr(context.scene.translucent, name, value)
    s.auto_summary = choice.summary()
    return choice

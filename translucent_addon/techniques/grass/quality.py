"""Grass's Auto quality: BTF texels per side from the tile's pixels on screen (pure)."""
from __future__ import annotations

from ...core.quality_model import ObjectView

GRASS_CHOICES = (64, 128, 256)


def grass_resolution(view: ObjectView, tile_mm: float) -> str:
    """BTF texels per side: the fewest of GRASS_CHOICES that are at least the tile's pixels on screen."""
    if view.pixel_mm <= 0:
        return "128"
    tile_pixels = tile_mm / view.pixel_mm
    for res in GRASS_CHOICES:
        if res >= tile_pixels:
            return str(res)
    return str(GRASS_CHOICES[-1])

"""Quality tiers: the resolutions used at Draft, Standard and High (pure).

The preferences' default quality is applied to an object when its method is chosen, and to the scene
with *Apply Quality*; every value stays editable afterwards. Standard is the defaults of the properties. Each
technique declares its own values per tier (``Technique.object_tiers``, ``scene_tiers``); the registry joins
them (``techniques.tier_table``) to the scene-wide ones here.
"""
from __future__ import annotations

from typing import Any

TIERS = ("DRAFT", "STANDARD", "HIGH")

SCENE = {  # Scene.translucent: what every method shares
    "DRAFT": {"shadow_resolution": 512},
    "STANDARD": {"shadow_resolution": 1024},
    "HIGH": {"shadow_resolution": 2048},
}


def apply(settings: Any, table: dict, tier: str) -> list[str]:
    """Set the tier's values on a settings group; returns the names set."""
    if tier not in table:
        raise ValueError(f"unknown quality '{tier}': choose one of {', '.join(TIERS)}")
    for name, value in table[tier].items():
        setattr(settings, name, value)
    return list(table[tier])

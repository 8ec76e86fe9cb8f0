"""Quality tiers: the resolutions each method uses at Draft, Standard and High (pure).

The preferences' default quality is applied to an object when its method is chosen, and to the scene
with *Apply Quality*; every value stays editable afterwards. Standard is the defaults of the properties.
"""
from __future__ import annotations

from typing import Any

TIERS = ("DRAFT", "STANDARD", "HIGH")

OBJECT = {  # Object.translucent
    "DRAFT": {"atlas_resolution": 256, "proxy_spacing": 3.5, "quadgraph_K": 2.0, "geocube_resolution": 32,
              "grass_resolution": "64"},
    "STANDARD": {"atlas_resolution": 512, "proxy_spacing": 3.5, "quadgraph_K": 1.0, "geocube_resolution": 0,
                 "grass_resolution": "128"},
    # TEXTURE_SPACE's error follows the proxy's spacing more than the atlas's (back-lit cow against the
    # dipole model, atlas 512: 9,833 vertices 7.0 %, 18,245 5.0 %, 28,889 4.5 %; atlas 768 at 9,697
    # vertices 6.7 %), so High refines the proxy and keeps the atlas.
    "HIGH": {"atlas_resolution": 512, "proxy_spacing": 2.4, "quadgraph_K": 0.5, "geocube_resolution": 64,
             "grass_resolution": "256"},
}

SCENE = {  # Scene.translucent
    "DRAFT": {"shadow_resolution": 512, "splat_overlap": 16.0, "caustics_grid": 64, "caustics_map": 512},
    "STANDARD": {"shadow_resolution": 1024, "splat_overlap": 32.0, "caustics_grid": 128, "caustics_map": 1024},
    "HIGH": {"shadow_resolution": 2048, "splat_overlap": 48.0, "caustics_grid": 256, "caustics_map": 2048},
}


def apply(settings: Any, table: dict, tier: str) -> list[str]:
    """Set the tier's values on a settings group; returns the names set."""
    if tier not in table:
        raise ValueError(f"unknown quality '{tier}': choose one of {', '.join(TIERS)}")
    for name, value in table[tier].items():
        setattr(settings, name, value)
    return list(table[tier])

"""What differs between the Blenders the extension supports (4.5 LTS, 5.2 LTS, 5.3), in one place.

Blender-facing (imports bpy when called): EEVEE's engine id is ``BLENDER_EEVEE_NEXT`` in 4.2-4.5 and
``BLENDER_EEVEE`` from 5.0 on, in ``RenderSettings.engine`` and in the panels' ``COMPAT_ENGINES``.
"""
from __future__ import annotations

EEVEE_IDS = ("BLENDER_EEVEE", "BLENDER_EEVEE_NEXT")


def eevee_engine_id() -> str:
    """EEVEE's id in this Blender's render engine list."""
    import bpy

    engines = {item.identifier for item in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}
    for name in EEVEE_IDS:
        if name in engines:
            return name
    raise RuntimeError(f"no EEVEE among the render engines {sorted(engines)}")

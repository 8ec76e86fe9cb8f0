"""A property a technique declares, as plain data: the Blender layer turns each into ``bpy.props.<kind>(...)``
on ``Object.translucent``, ``Scene.translucent`` or ``Light.translucent`` (``blender/props.py``). The names are
what .blend files store: a technique keeps them for good."""
from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Prop:
    name: str
    kind: str  # a bpy.props function (FloatProperty, IntProperty, EnumProperty...) or "ImagePointer"
    options: dict  # its keyword arguments: name, description, default, min, max, items...

    def __hash__(self) -> int:
        return hash((self.name, self.kind))

"""Operators of the extension (bpy-facing, thin: the work is in translucent_addon)."""

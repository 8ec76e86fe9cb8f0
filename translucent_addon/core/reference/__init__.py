"""CPU reference renderers of the same models the GPU draws (NumPy, no bpy)."""

"""Translucent: pure and Blender-facing code of the extension.

Pure sub-packages (``physics``, ``geometry``, ``reference``, ``render.scene_data``,
``render.lights``, ``bake.store``) never import ``bpy`` at module level and are
tested without Blender. Blender-facing modules (``props``, ``ui``, ``render.engine``,
``render.pipeline``...) are imported only by the extension's root ``__init__``.
"""

"""Rendering: pure frame description and light model, plus the GPU pipeline.

``scene_data`` and ``lights`` are pure (tested without Blender); ``pipeline``,
``shaders``, ``engine``, ``extract`` and ``draw_handler`` need Blender.
"""

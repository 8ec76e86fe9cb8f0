"""GPU resources the method passes share: textures from arrays, render targets, a screen quad.

Blender-facing (``gpu``), imported only inside a GPU context.
"""
from __future__ import annotations

import numpy as np

from . import shaders


def texture_from_array(image: np.ndarray, fmt: str = "RGBA32F"):
    """A GPUTexture from an (h, w, c) array. Blender fills textures from FLOAT buffers only (integer
    tables travel as exact floats); the buffer takes the NumPy array without a Python list."""
    import gpu

    h, w, _ = image.shape
    flat = np.ascontiguousarray(image, np.float32).reshape(-1)
    return gpu.types.GPUTexture((w, h), format=fmt, data=gpu.types.Buffer("FLOAT", flat.size, flat))


def new_target(size, depth: bool = False, attachments: int = 1):
    """An RGBA32F render target: (framebuffer, color textures, depth texture or None). Keep all three
    referenced: a texture that Python frees is silently detached from the framebuffer."""
    import gpu

    colors = [gpu.types.GPUTexture(size, format="RGBA32F") for _ in range(attachments)]
    depth_tex = gpu.types.GPUTexture(size, format="DEPTH_COMPONENT32F") if depth else None
    fb = gpu.types.GPUFrameBuffer(depth_slot=depth_tex, color_slots=colors if attachments > 1 else colors[0])
    return fb, colors, depth_tex


def screen_quad(pipeline, shader_name: str):
    """Two triangles covering the target (attribute ``corner``), built once per pipeline and pass."""
    key = ("screen_quad", shader_name)
    batch = pipeline.targets.get(key)
    if batch is None:
        from gpu_extras.batch import batch_for_shader

        corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, -1), (1, 1), (-1, 1)], np.float32)
        batch = pipeline.targets[key] = batch_for_shader(shaders.get(shader_name), "TRIS", {"corner": corners})
    return batch

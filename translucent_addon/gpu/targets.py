"""GPU resources the method passes share: textures from arrays, render targets, a screen quad.

Blender-facing (``gpu``), imported only inside a GPU context.
"""
from __future__ import annotations

import numpy as np

from . import draw_state, shaders

# Texture formats every backend Blender runs takes for sampling and as render targets (docs/gpu_backends.md): no
# three-channel format (Metal has no RGB float format; Vulkan drivers need not take R32G32B32 as an image), no packed
# 24-bit depth (Apple GPUs have none). tests/test_backend_rules.py holds every literal format in the code to it.
TEXTURE_FORMATS = frozenset({"RGBA8", "RGBA16F", "RGBA32F", "RG16F", "RG32F", "R16F", "R32F", "R8",
                             "DEPTH_COMPONENT32F"})


def texture_from_array(image: np.ndarray, fmt: str = "RGBA32F"):
    """A GPUTexture from an (h, w, c) array. Blender fills textures from FLOAT buffers only (integer
    tables travel as exact floats); the buffer takes the NumPy array without a Python list."""
    import gpu

    if fmt not in TEXTURE_FORMATS:
        raise ValueError(f"texture format {fmt} is not taken by every GPU backend")
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


SIZES_KEPT = 4  # sizes of one named target kept (per-emitter atlases of a frame; the last viewport sizes)


def cached_target(pipeline, name: str, size, depth: bool = False, attachments: int = 1):
    """``new_target`` kept in ``pipeline.targets`` across frames under (name, size, ...), the SIZES_KEPT sizes of
    a name used last: a viewport dragged through many sizes (or F12 at several) does not keep a full-screen
    target for each (70 MB at 1080p for IMAGE_SPACE's G-buffer and scatter)."""
    key = (name, tuple(size), depth, attachments)
    found = pipeline.targets.pop(key, None)  # put back last: the dict's order is the order of use
    if found is None:
        found = new_target(tuple(size), depth, attachments)
        older = [k for k in pipeline.targets if isinstance(k, tuple) and k[0] == name and len(k) == 4]
        for k in older[:max(0, len(older) - (SIZES_KEPT - 1))]:
            del pipeline.targets[k]
    pipeline.targets[key] = found
    return found


def screen_quad(pipeline, shader_name: str):
    """Two triangles covering the target (attribute ``corner``), built once per pipeline and pass."""
    key = ("screen_quad", shader_name)
    batch = pipeline.targets.get(key)
    if batch is None:
        from gpu_extras.batch import batch_for_shader

        corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, -1), (1, 1), (-1, 1)], np.float32)
        batch = pipeline.targets[key] = batch_for_shader(shaders.get(shader_name), "TRIS", {"corner": corners})
    return batch


def clear_target(fb, color=(0.0, 0.0, 0.0, 0.0), depth: float | None = 1.0) -> None:
    """Clear a bound framebuffer. Depth writes are on for the clear (a depth clear obeys the depth mask: a pass
    that had them off would keep the last frame's depth) and as they were afterwards."""
    with draw_state.draw_pass(None, blend=draw_state.current()[0], depth_write=True):
        if depth is None:
            fb.clear(color=color)
        else:
            fb.clear(color=color, depth=depth)


def read_pixels(fb, width: int, height: int, slot: int = 0, channels: int = 4) -> np.ndarray:
    """Float pixels (height, width, channels: RGBA, or RGB when 3) of a bound framebuffer, row 0 at the bottom.

    Always read as four floats a pixel, then sliced: Blender's Vulkan backend writes every component of the
    texture whatever channel count is asked (5.3: a 3-channel read of an RGBA32F target wrote 4 floats a pixel
    past the end of the buffer, corrupting the heap; docs/gpu_backends.md). Read into a 1-D Buffer: NumPy views
    of multi-dimensional ``gpu.types.Buffer`` objects get wrong strides in Blender 5.0.
    """
    import gpu

    buf = gpu.types.Buffer("FLOAT", width * height * 4)
    fb.read_color(0, 0, width, height, 4, slot, "FLOAT", data=buf)
    pixels = np.asarray(buf, dtype=np.float32).reshape(height, width, 4)
    return (pixels if channels == 4 else pixels[..., :channels]).copy()

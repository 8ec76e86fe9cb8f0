"""Camera rays through pixel centres, matching OpenGL rasterisation."""
from __future__ import annotations

import numpy as np


def pixel_rays(view_proj: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """World-space rays through the centres of a width x height image.

    Row 0 is the bottom row (OpenGL and Blender images). Works for perspective
    and orthographic projections alike: each ray joins the unprojected points
    on the near and far planes of the pixel centre.
    Returns origins and unit directions, each (height, width, 3).
    """
    xs = (np.arange(width) + 0.5) / width * 2.0 - 1.0
    ys = (np.arange(height) + 0.5) / height * 2.0 - 1.0
    x, y = np.meshgrid(xs, ys)  # (H, W)
    inv = np.linalg.inv(view_proj)
    def unproject(z: float) -> np.ndarray:
        clip = np.stack([x, y, np.full_like(x, z), np.ones_like(x)], axis=-1)
        p = clip @ inv.T
        return p[..., :3] / p[..., 3:4]
    near, far = unproject(-1.0), unproject(1.0)
    d = far - near
    return near, d / np.linalg.norm(d, axis=-1, keepdims=True)

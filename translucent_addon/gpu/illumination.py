"""The illumination map in texture space (Lensch Sec. 5.2, Fig. 3 step 1): one point per atlas texel lit at
its surface point with Fresnel and shadows (``gpu_shaders/common/illumination_map.glsl``). TEXTURE_SPACE draws its
irradiance with it; QUADGRAPH its q(n_s) and the exitance its surface term takes over."""
from __future__ import annotations

import numpy as np

from ..core.physics.sh_irradiance import transmittance_kernel
from . import shaders
from .draw_state import draw_pass
from .targets import clear_target, texture_from_array


def draw_illumination(fb, points, size, obj_ubo, frame_ubo, light_ubo, shadow_atlas, mode: int, eta: float,
                      cosine_table, entry=(0.0, 0.0, 0.0)) -> None:
    """The ``ts_illumination`` pass into ``fb``: one point per texel of ``points`` lit at its surface
    point; mode 0 (the world) clears first, mode 1 (one emitter) adds, scaled by ``cosine_table`` at the
    point's cosine (n x 1 texture; one texel of 1 leaves it), its light read where it entered ``entry`` (the
    shift per channel in world units, ``oblique_entry``; 0: at the point). QUADGRAPH uses it for q(n_s) and for
    the exitance its surface term takes over."""
    import gpu

    with draw_pass(fb, blend="ADDITIVE_PREMULT"):
        if mode == 0:
            clear_target(fb, depth=None)
        gpu.state.point_size_set(1.0)
        shader = shaders.bind_lit("ts_illumination", frame_ubo, light_ubo, shadow_atlas, mode)
        shader.uniform_block("object", obj_ubo)
        shader.uniform_float("eta", float(eta))
        shader.uniform_float("world_kernel", tuple(float(x) for x in transmittance_kernel(eta)))
        shader.uniform_float("atlas_size", tuple(float(x) for x in size))
        shader.uniform_float("entry", tuple(float(x) for x in entry))
        shader.uniform_sampler("cosine_table", cosine_table)
        shader.draw(points)


def rgb_table(table):
    """An (n, 3) table as an n x 1 RGBA32F texture (the cosine tables the passes read with ``cosine_lerp`` or
    ``table_lerp``)."""
    image = np.concatenate([table, np.zeros((len(table), 1))], axis=1)[None].astype(np.float32)
    return texture_from_array(image)


class MediumTables:
    """Per-medium tables of one object's resources, each built again only when the medium changes (one entry
    per name: dragging a coefficient does not pile up textures)."""

    def __init__(self):
        self._cached = {}  # name: (medium key, table or texture)

    def get(self, name: str, medium, table_of, texture: bool = True):
        """``table_of(sigma_a, sigma_s_prime, eta)`` (n, 3) as an n x 1 texture (or as it is)."""
        key = (medium.profile, tuple(medium.sigma_a), tuple(medium.sigma_s_prime), medium.eta, medium.g)
        cached = self._cached.get(name)
        if cached is None or cached[0] != key:
            table = table_of(medium.sigma_a, medium.sigma_s_prime, medium.eta)
            cached = self._cached[name] = (key, rgb_table(table) if texture else table)
        return cached[1]


def unit_texture(pipeline):
    """One texel of 1 (RGBA32F), built once per pipeline: the illumination pass's neutral table."""
    tex = pipeline.targets.get("unit_texture")
    if tex is None:
        tex = pipeline.targets["unit_texture"] = texture_from_array(np.ones((1, 1, 4), np.float32))
    return tex

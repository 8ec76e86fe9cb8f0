"""Stability of the drawn image at extreme coefficients (the benchmark issue's stability suite): each
subsurface method draws a small sun-lit ball with no absorption, with very strong scattering, with
very weak scattering and with very strong absorption, and the image stays finite, lit, and within what
the light can give (a white Lambertian ball's brightest radiance E / pi, times a margin for the
concentration a translucent rim may show)."""
from __future__ import annotations

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytest.importorskip("pytetwild")

from blender_helpers import add_camera, add_light, render, set_world  # noqa: E402

SUN = 3.0  # W / m^2: a white Lambertian surface facing it has radiance SUN / pi
EXTREMES = {  # (sigma_a, sigma_s') per mm, the same in R, G and B
    "no absorption": (0.0, 1.0),
    "strong scattering": (0.01, 1000.0),
    "weak scattering": (0.001, 0.001),
    "strong absorption": (100.0, 1.0),
}


def _ball(scene, method: str):
    set_world(scene, (0.0, 0.0, 0.0))
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=0.01, location=(0, 0, 0))
    ob = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    ob.translucent.preset = "marble"
    ob.translucent.method = method
    ob.translucent.atlas_resolution = 128  # TEXTURE_SPACE: a few hundred proxy vertices (512: 10k, 2 min)
    ob.translucent.quadgraph_K = 2.0  # the Draft density
    add_light(scene, "SUN", (0.0, -1.0, 1.0), (0, 0, 0), energy=SUN)
    add_camera(scene, (0.18, -0.18, 0.06), (0, 0, 0), lens=200)  # beyond the 0.1 m clip start
    return ob


@pytest.mark.parametrize("method", ["IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH"])
def test_extreme_coefficients_draw_finite_lit_bounded_images(tr, scene, method):
    ob = _ball(scene, method)
    seen = {}
    for label, (sigma_a, sigma_s_prime) in EXTREMES.items():
        ob.translucent.sigma_a = (sigma_a,) * 3
        ob.translucent.sigma_s_prime = (sigma_s_prime,) * 3
        if method != "IMAGE_SPACE":
            assert bpy.ops.translucent.bake() == {"FINISHED"}, label
        img = render(scene, 48, 48)[..., :3]
        assert np.isfinite(img).all(), f"{method}, {label}: NaN or inf in the image"
        on_ball = img.max(axis=-1) > 1e-6
        # A 500 mm mean free path in a 20 mm ball scatters almost nothing back: near black is right there.
        assert on_ball.sum() > 100 or label == "weak scattering", f"{method}, {label}: the ball is black"
        assert img.max() < 2.0 * SUN / math.pi, f"{method}, {label}: {img.max():.3f} exceeds what the sun gives"
        seen[label] = float(img[on_ball].mean()) if on_ball.any() else 0.0
    # Absorption darkens: no absorption draws the brightest ball, strong absorption the darkest.
    assert seen["no absorption"] > seen["strong absorption"], seen

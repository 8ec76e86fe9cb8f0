"""A thick slab seen from above under a uniform white world, in Cycles (bpy-facing).

Used to calibrate and test the conversions: with a uniform world L_w = 1, the radiance leaving the
top face at normal view is F_r(0) + (1 - F_r(0)) rho, with rho the medium's diffuse albedo
(dipole: rho = R_d (1 - F_dr,in)).
"""
from __future__ import annotations

import bpy
import numpy as np

from .demo import uniform_world

SLAB_HALF_WIDTH = 0.06  # Blender units (60 mm at 1000 mm per unit)
SLAB_DEPTH = 0.04


def build(scene, material) -> bpy.types.Object:
    """A box (outward normals) with its top face at z = 0, an orthographic camera looking down."""
    h, d = SLAB_HALF_WIDTH, SLAB_DEPTH
    verts = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-d, 0)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    me = bpy.data.meshes.new("Slab")
    me.from_pydata(verts, [], faces)
    me.materials.append(material)
    ob = bpy.data.objects.new("Slab", me)
    scene.collection.objects.link(ob)
    cam = bpy.data.objects.new("Slab camera", bpy.data.cameras.new("Slab camera"))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 0.01  # the central 10 mm
    cam.location = (0, 0, 0.5)
    scene.collection.objects.link(cam)
    scene.camera = cam
    uniform_world(scene, (1.0, 1.0, 1.0), "White")
    return ob


def configure_cycles(scene, samples: int, bounces: int = 1024, seed: int = 1) -> None:
    """Unbiased settings: no clamping, no caustic filtering, no denoising, no adaptive stop."""
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = seed
    c.max_bounces = c.volume_bounces = c.transmission_bounces = c.glossy_bounces = c.diffuse_bounces = bounces
    c.transparent_max_bounces = bounces
    c.caustics_reflective = c.caustics_refractive = True
    c.blur_glossy = 0.0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.pixel_filter_type = "BOX"


def mean_radiance(pixels: np.ndarray) -> np.ndarray:
    return pixels[..., :3].reshape(-1, 3).mean(axis=0)

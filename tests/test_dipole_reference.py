"""The CPU dipole model reference against the closed form on a thick plate."""
from __future__ import annotations

import math

import numpy as np
import pytest

from translucent_addon.physics.dipole import total_diffuse_reflectance
from translucent_addon.physics.fresnel import fresnel_dielectric
from translucent_addon.physics.fresnel import hemispherical_transmittance
from translucent_addon.reference.dipole_model import Medium, render_dipole
from translucent_addon.render import blocks
from translucent_addon.render.lights import emitters_from_light
from translucent_addon.render.scene_data import CameraView, FrameInputs, MeshInstance


def _plate(half=0.1, depth=0.05):
    """A box half-width 'half' (units), top face at z = 0 (two triangles per face, flat normals)."""
    h, d = half, depth
    corners = np.array([[x, y, z] for z in (-d, 0.0) for y in (-h, h) for x in (-h, h)], float)
    quads = [(4, 5, 7, 6), (0, 2, 3, 1), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    pos, nor = [], []
    for q in quads:
        a, b, c, dd = corners[list(q)]
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n)
        for tri in ((a, b, c), (a, c, dd)):
            pos.extend(tri)
            nor.extend([n] * 3)
    pos = np.array(pos, np.float32)
    return MeshInstance("plate", "Plate", pos, np.array(nor, np.float32), np.full_like(pos, 0.8), np.eye(4))


def test_plate_under_a_sun_matches_the_closed_form():
    """Centre of a wide, thick plate: L = F_t(w_o)/pi * R_d_total * F_t(w_i) E cos(theta_i)."""
    sa, ss, eta = (0.05, 0.2, 0.5), (1.0, 1.5, 2.0), 1.3
    medium = Medium(sa, ss, eta, mm_per_unit=1000.0)  # a 200 mm plate, 50 mm thick
    theta = math.radians(30)
    rot = np.array([[1, 0, 0], [0, math.cos(theta), -math.sin(theta)], [0, math.sin(theta), math.cos(theta)]])
    m = np.eye(4)
    m[:3, :3] = rot
    sun = emitters_from_light("sun", "SUN", m, (1, 1, 1), 3.0)
    view = blocks.look_at((0, 0, 1.0), (0, 0, -1.0), (0, 1, 0))
    proj = blocks.orthographic(0.01, 0.01, 0.1, 10.0)  # 20 mm field at the centre
    frame = FrameInputs([_plate()], sun, CameraView(view, proj, 6, 6), np.zeros(3))
    img = render_dipole(frame, {"Plate": medium}, samples=300_000)
    expected = ((1 - fresnel_dielectric(1.0, eta)) / math.pi * total_diffuse_reflectance(np.array(sa), np.array(ss), eta)
                * (1 - fresnel_dielectric(math.cos(theta), eta)) * 3.0 * math.cos(theta))
    got = img[..., :3].reshape(-1, 3)
    np.testing.assert_allclose(got, np.broadcast_to(expected, got.shape), rtol=0.01)


def test_surface_quadrature_covers_the_area_exactly():
    from translucent_addon.reference.dipole_model import sample_surface

    plate = _plate()
    points, normals, area, _ = sample_surface(plate, 5000)
    assert area.sum() == pytest.approx(0.2 * 0.2 * 2 + 4 * 0.2 * 0.05, rel=1e-6)
    assert 4000 < len(points) < 8000
    assert np.abs(points[:, :2]).max() <= 0.1 + 1e-6 and np.allclose(np.linalg.norm(normals, axis=1), 1)


def test_uniform_world_enters_through_the_hemispherical_transmittance():
    t = hemispherical_transmittance(1.3)
    mu = np.linspace(0, 1, 100001)
    assert t == pytest.approx(2 * np.trapz((1 - fresnel_dielectric(mu, 1.3)) * mu, mu), rel=1e-5)
    assert 0.85 < t < 0.95

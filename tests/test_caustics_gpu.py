"""Caustics mapping (Shah ch. 5) on the GPU: passes against the NumPy twin, energy, the image."""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_helpers import render  # noqa: E402
from conftest import ext_module  # noqa: E402


def _scene(tr, scene, **kw):
    ext_module(tr, "translucent_addon.demo").build_caustics_scene(scene, **kw)
    scene.translucent.capture_passes = True
    return scene


def _capture(tr):
    return ext_module(tr, "translucent_addon.render.engine").LAST_CAPTURE


def _twin(tr, cap, caster_name="Glass ball"):
    """The NumPy twin over the captured maps of the first emitter and caster."""
    cm = ext_module(tr, "translucent_addon.geometry.caustic_mapping")
    blocks = ext_module(tr, "translucent_addon.render.blocks")
    caustics = ext_module(tr, "translucent_addon.render.caustics")
    frame = cap["frame"]
    e = frame.emitters[0]
    mesh = next(m for m in frame.meshes if m.name == caster_name)
    centre, radius = caustics.bounding_sphere(mesh)
    grid = cm.caster_grid(e, centre, radius, frame.caustics.grid)
    faces, _ = blocks.shadow_projection(e, *frame.bounds())
    N = frame.caustics.texels
    receivers = cm.atlas_lookup(e, faces, cap["caustic_receivers"][0], N)
    return cm.trace_grid(e, grid, mesh.caster, cap["caustic_front_position"][0], cap["caustic_front_normal"][0],
                         cap["caustic_back_position"][0], cap["caustic_back_normal"][0], receivers,
                         frame.caustics.iterations, frame.caustics.guard, frame.caustics.secant), grid


def test_smoke(tr, scene):
    _scene(tr, scene)
    img = render(scene, 128, 128)
    cap = _capture(tr)
    (y, flux, valid), grid = _twin(tr, cap)
    landing = cap["caustic_landing"][0]
    gflux = cap["caustic_trace_flux"][0]
    covered = cap["caustic_front_position"][0][..., 3] > 0.5
    print("covered", covered.sum(), "gpu valid", (landing[..., 3] > 0.5).sum(), "cpu valid", valid.sum())
    both = valid & (landing[..., 3] > 0.5)
    err = np.linalg.norm(y[both] - landing[both, :3], axis=1)
    print("landing err", np.percentile(err, [50, 90, 99, 100]))
    print("flux", gflux[..., :3].sum(), flux.sum())
    lost = covered & ~valid
    print("lost rows", np.argwhere(lost)[:10])
    import pickle
    blocks = ext_module(tr, "translucent_addon.render.blocks")
    frame = cap["frame"]
    faces, _ = blocks.shadow_projection(frame.emitters[0], *frame.bounds())
    import dataclasses; pickle.dump(dict(faces=faces, grid_vp=grid.view_proj, half=grid.half_extent, e=dataclasses.asdict(frame.emitters[0]),
                     caster=dataclasses.asdict(next(m.caster for m in frame.meshes if m.caster)), **{k: cap[k][0] for k in cap if k.startswith("caustic_")}),
                open("/tmp/cx/cap.pkl", "wb"))
    assert np.isfinite(img).all()


def test_explore(tr, scene):
    _scene(tr, scene)
    for est in ("SHAH", "SECANT"):
        for it in (1, 2, 3, 5, 8):
            scene.translucent.caustics_estimator = est
            scene.translucent.caustics_iterations = it
            render(scene, 32, 32)
            cap = _capture(tr)
            print(est, it, cap["caustic_trace_flux"][0][..., :3].sum() / 3 / 0.032703, (cap["caustic_landing"][0][..., 3] > .5).sum())

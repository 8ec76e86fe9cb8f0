"""AUTO quality of IMAGE_SPACE, chosen again every frame (pure).

IMAGE_SPACE has nothing to bake: its one resolution is the splat overlap k (samples per splat radius in
the light views, Shah Eq. 6.17), and what k an object needs depends on how large the camera sees it
(``splat_overlap_for``: no finer than an eighth of a pixel). So for the objects whose
quality is AUTO, k follows the camera, in F12 and in the viewport, from the frame's own camera: a
bunny that walks towards the camera gets more samples, one that walks away fewer.

k is scene-wide (one light-view sampling for every IMAGE_SPACE mesh): the largest any AUTO object needs,
and at least the scene's own value when a manual IMAGE_SPACE object is drawn too. It is rounded up to a
quarter of an octave so that a camera moving smoothly does not change the sample pattern every frame.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from ...core.frame import CameraView, FrameInputs, MeshInstance
from ...core.geometry.mesh_checks import triangle_areas
from ...core.geometry.mesh_measures import stretch_of
from ...core.quality_model import CURVES_JSON, Choice, ObjectView, PowerLaw, load_curves
from .model import SamplingSettings

# IMAGE_SPACE: light-view samples per pixel of the object, at most. Measured: the cow's error at 512x512 still
# fell from k = 32 to 48 (3 to 5 samples per pixel: 5.2 to 3.7 %), and a cap at 2 left it at 8.2 % for a 5 %
# target (bench/results/auto); splat sums alias below a pixel, so the cap only bites where r_max nears a pixel.
PIXEL_SAMPLES = 8.0
SPLAT_OVERLAP_RANGE = (4.0, 64.0)

STEPS_PER_OCTAVE = 4
LARGE_GRID_ABOVE = 32.0  # past this k the light view needs 2048 texels a side (quality_auto._image_space)



@functools.lru_cache(maxsize=2)
def image_space_curve(path: str = str(CURVES_JSON)) -> PowerLaw:
    """Error against 1 / k over every measured scene."""
    rows = load_curves(path)["image_space"]
    return PowerLaw.envelope([1.0 / r["k"] for r in rows], [r["rel_rmse"] for r in rows])


def splat_overlap_for(view: ObjectView, target: float, curves: str = str(CURVES_JSON)) -> tuple[float, list]:
    """IMAGE_SPACE's k: the curve's k for the target, at most PIXEL_SAMPLES samples per pixel of the object."""
    curve = image_space_curve(curves)
    k = 1.0 / curve.inverse(target)
    notes = []
    lo, hi = SPLAT_OVERLAP_RANGE
    if view.pixel_mm > 0:
        k_pixel = PIXEL_SAMPLES * view.r_max_mm / view.pixel_mm
        if k_pixel < k:
            k = k_pixel
            notes.append("samples finer than an eighth of a pixel would not show: "
                         + (f"k capped at {k_pixel:.1f}" if k_pixel >= lo else f"k at its least, {lo:g}"))
    if k > hi:
        notes.append(f"the target needs k = {k:.0f}; k stops at {hi:g}")
    return float(np.clip(round(k, 1), lo, hi)), notes


def quantised(k: float) -> float:
    """k rounded up to the next quarter octave (2^(n/4)), within SPLAT_OVERLAP_RANGE."""
    lo, hi = SPLAT_OVERLAP_RANGE
    q = 2.0 ** (math.ceil(STEPS_PER_OCTAVE * math.log2(max(k, 1e-9)) - 1e-9) / STEPS_PER_OCTAVE)
    return float(min(max(q, lo), hi))


def screen_diagonal(points_world: np.ndarray, view_proj: np.ndarray, width: int, height: int) -> float:
    """The diagonal in pixels of the screen box of world points, each clamped to half an image beyond the
    frame (as ``bake.inputs.screen_pixels`` does for the scene camera); a point behind the camera counts as
    at the far side of that margin."""
    p = np.c_[np.asarray(points_world, np.float64), np.ones(len(points_world))] @ np.asarray(view_proj).T
    w = p[:, 3]
    front = w > 1e-9
    uv = np.empty((len(p), 2))
    uv[front] = 0.5 * (p[front, :2] / w[front, None] + 1.0)
    uv[~front] = np.where(p[~front, :2] >= 0, 1.5, -0.5)
    uv = np.clip(uv, -0.5, 1.5) * np.array([width, height], np.float64)
    return float(np.linalg.norm(uv.max(axis=0) - uv.min(axis=0)))


def _shape(mesh: MeshInstance, shapes: dict | None = None) -> tuple[float, float, np.ndarray]:
    """Diagonal and area in mm (the model's scale applied, as ``bake.inputs.object_view``) and the object
    space bounding box's corners in world space; kept in ``shapes`` (the caller's, across frames) by the mesh's
    geometry key and transform."""
    shapes = {} if shapes is None else shapes
    mm = mesh.medium.mm_per_unit
    key = (mesh.key, np.asarray(mesh.model, np.float64).tobytes(), mm)
    hit = shapes.get(key)
    if hit is None:
        if len(shapes) > 256:
            shapes.clear()
        model = np.asarray(mesh.model, np.float64)
        v_mm = np.asarray(mesh.positions, np.float64) @ stretch_of(model[:3, :3]).T * mm
        area = float(triangle_areas(v_mm, np.arange(len(v_mm)).reshape(-1, 3)).sum())
        lo, hi = mesh.positions.min(axis=0), mesh.positions.max(axis=0)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        world = corners @ model[:3, :3].T + model[:3, 3]
        hit = shapes[key] = (float(np.linalg.norm(np.ptp(v_mm, axis=0))), area, world)
    return hit


def object_view(mesh: MeshInstance, camera: CameraView, shapes: dict | None = None) -> ObjectView:
    """``ObjectView`` of a drawn mesh, seen by this frame's camera (``shapes``: ``_shape``'s cache)."""
    diagonal, area, corners = _shape(mesh, shapes)
    m = mesh.medium
    return ObjectView(diagonal_mm=diagonal, area_mm2=area,
                      screen_pixels=screen_diagonal(corners, camera.view_proj, camera.width, camera.height),
                      sigma_a=tuple(m.sigma_a), sigma_s_prime=tuple(m.sigma_s_prime), eta=float(m.eta),
                      triangles=len(mesh.positions) // 3, profile=m.profile)


def frame_sampling(frame: FrameInputs, manual: SamplingSettings,
                   shapes: dict | None = None) -> tuple[SamplingSettings, dict]:
    """The sampling for this frame and the k each AUTO object asked for ({name: k}); ``manual`` itself
    when no AUTO IMAGE_SPACE object is drawn. ``shapes``: the objects' sizes kept across frames (``_shape``)."""
    drawn = [m for m in frame.meshes if m.method == "IMAGE_SPACE" and m.medium is not None]
    autos = [m for m in drawn if m.auto_target is not None]
    if not autos:
        return manual, {}
    asked = {m.name: quantised(splat_overlap_for(object_view(m, frame.camera, shapes), m.auto_target)[0])
             for m in autos}
    k = max(asked.values())
    if len(autos) < len(drawn):
        k = max(k, manual.overlap)
    grid = max(manual.max_grid, 2048 if k > LARGE_GRID_ABOVE else 1024)
    return dataclasses.replace(manual, overlap=k, max_grid=grid), asked


def auto(view: ObjectView, target: float, curves: str) -> Choice:
    k, notes = splat_overlap_for(view, target, curves)
    curve = image_space_curve(curves)
    if 1.0 / k > curve.x_range[1] or 1.0 / k < curve.x_range[0]:
        notes.append("outside the measured k (extrapolated)")
    samples = (k * view.diagonal_mm / view.r_max_mm) ** 2  # samples on the object (bench: 0.8-1.1x this)
    # Past k = 32 the light view needs more than the default 1024 texels a side (the benchmark's k = 48: 2048).
    scene = {"splat_overlap": k, "splat_max_grid": 2048 if k > 32 else 1024}
    return Choice("IMAGE_SPACE", {}, scene, float(curve(1.0 / k)), {"light_view_samples": int(samples)}, notes)

"""AUTO quality: each method's resolutions for a target error at the least cost (pure).

What the target means: the method's *discretisation* error, its relative RMSE over the object against its
own converged model (for IMAGE_SPACE and TEXTURE_SPACE the CPU dipole model, ``core/reference/dipole_model.py``).
That is the part resolution can buy down. The model's own error against exact transport (the dipole on a
thin ear, diffusion near a light) is not bought down by more texels, and AUTO says so instead of chasing it.

How: from the benchmark's measured curves (``data/quality_curves.json``, written by
``scripts/quality_curves.py`` from ``bench/results``), each made dimensionless so that it carries to
other objects:

* IMAGE_SPACE: error against the splat overlap k (light-view samples per splat radius r_max). The spacing
  r_max / k need not be finer than an eighth of a pixel of the object on screen (``PIXEL_SAMPLES``), which
  caps k for objects far larger than their scattering length or small on screen.
* TEXTURE_SPACE: error against the proxy's edge h over the object's bounding-box diagonal D (the light's
  structure on an object, shadows and terminators, scales with it). Candidates are every atlas resolution
  and proxy spacing; the cheapest (fewest form factors: bake time and memory) that reaches the target wins,
  with no proxy edge below a quarter pixel (``PIXEL_VERTICES``) and no more form factors than
  ``FORM_FACTOR_BUDGET``.
* QUADGRAPH: error against exact transport is flat over K = 1, 0.5, 0.3 (its model's error dominates), so K
  = 1 unless even K = 2's surface nodes are finer than a pixel.
* GEOCUBE: cube texels from the object's pixels (``bake.geocube.resolution_for``).
* Grass: BTF texels per side at least the tile's pixels, at most 256.

A curve is fitted as an upper envelope (``PowerLaw.envelope``): the least-squares slope in log-log, raised
until no measured point lies above it, so a prediction is conservative on the measured scenes.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from ..core.physics.dipole import dipole_parameters
from ..core.physics.presets import load_presets
from .geocube.bake import resolution_for
from .image_space.quality import (  # IMAGE_SPACE's own; AUTO's users import them from here too
    CURVES_JSON,
    PIXEL_SAMPLES,  # noqa: F401
    SPLAT_OVERLAP_RANGE,  # noqa: F401
    ObjectView,
    PowerLaw,
    image_space_curve,
    load_curves,
    splat_overlap_for,
)
from .quadgraph.bake import proxy_triangles
from .texture_space.throughput import Material, throughput_radius

TARGET_DEFAULT = 0.05
ATLAS_CHOICES = (128, 192, 256, 384, 512, 768, 1024)
SPACING_CHOICES = (3.5, 2.4)  # the default and the High tier's proxy spacing (texels)
# TEXTURE_SPACE: proxy vertices per pixel of the object (along a side), at most. Measured: the back-lit cow at
# 192x144 (2.5 mm a pixel) went from 8.6 % at a proxy edge of a pixel and a half to 4.2 % at about one
# (bench/results/summary.md), so a cap at one vertex a pixel stopped short; a quarter pixel is the finest kept.
PIXEL_VERTICES = 4.0
FORM_FACTOR_BUDGET = 20_000_000  # 305 MB of throughput factors (16 bytes each), 100 s of bake here; High takes 14M
BYTES_PER_FORM_FACTOR = 16
QUADGRAPH_K_CHOICES = (2.0, 1.0)
GRASS_CHOICES = (64, 128, 256)
# A mesh coarser than the proxy is refined by longest-edge bisection, which leaves more vertices than an
# equilateral mesh of the same mean edge: the cow at atlas 512 had 2.0x (spacing 3.5) and 1.5x (2.4).
REFINED_VERTEX_FACTOR = 1.75


@dataclasses.dataclass
class Choice:
    """AUTO's answer for one object: the settings, what they should cost and reach, and why."""

    method: str
    settings: dict  # Object.translucent property -> value
    scene_settings: dict  # Scene.translucent property -> value (the splat overlap is the scene's)
    predicted_error: float | None  # discretisation error against the method's model
    cost: dict
    notes: list

    def summary(self) -> str:
        parts = [f"{k} {v}" for k, v in {**self.settings, **self.scene_settings}.items()]
        err = "" if self.predicted_error is None else f"; predicted error {100 * self.predicted_error:.1f} %"
        return ", ".join(parts) + err + "".join(f"; {n}" for n in self.notes)


@dataclasses.dataclass(frozen=True)
class TextureSpaceModel:
    """TEXTURE_SPACE's error: F hypot(a (h / D)^p, b texel / l_min).

    Two sources: the proxy's vertices sample the irradiance (its structure scales with the object, D), and
    the atlas's texels carry the near field of R_d (Lensch's 7x7 local kernels), which falls off over the
    shortest diffusion length l_min = 1 / max sigma_tr. Fitted by least squares in log, then raised by F
    until no measured point lies above it. Measured: the bunny (marble, texel / l_min 0.16-0.32) is bound
    by h / D; the cow (skin, texel / l_min 1-2) levels off at 4.5 % at atlas 512 whatever the spacing.
    """

    a: float
    p: float
    b: float
    F: float
    h_over_D_range: tuple
    ell_over_D_range: tuple  # l_max / D of the measured objects
    texel_over_ell_max: float  # beyond it the near field is inside one texel: not extrapolated

    def __call__(self, h_over_D, texel_over_ell):
        y = np.minimum(np.asarray(texel_over_ell, float), self.texel_over_ell_max)
        return self.F * np.hypot(self.a * np.asarray(h_over_D, float) ** self.p, self.b * y)

    @classmethod
    def fit(cls, rows, scenes, fill: float) -> "TextureSpaceModel":
        """Fitted on the texel AUTO can know before a bake, sqrt(area / (fill atlas^2)) (the real fill
        differs by mesh: the bunny's charts fill 0.52 of its atlas)."""
        from scipy.optimize import least_squares

        texel = np.array([math.sqrt(scenes[r["scene"]]["area_mm2"] / (fill * r["atlas"] ** 2)) for r in rows])
        x = np.array([r["proxy_spacing"] for r in rows]) * texel / [scenes[r["scene"]]["diagonal_mm"] for r in rows]
        y = texel / [scenes[r["scene"]]["ell_min_mm"] for r in rows]
        e = np.array([r["rel_rmse"] for r in rows])

        def residual(q):
            return np.log(np.hypot(np.exp(q[0]) * x ** q[1], np.exp(q[2]) * y)) - np.log(e)

        q = least_squares(residual, [4.0, 1.5, -3.5]).x
        F = float(np.exp(np.max(-residual(q))))
        ell = [scenes[r["scene"]]["ell_max_mm"] / scenes[r["scene"]]["diagonal_mm"] for r in rows]
        return cls(float(np.exp(q[0])), float(q[1]), float(np.exp(q[2])), F, (float(x.min()), float(x.max())),
                   (float(min(ell)), float(max(ell))), float(y.max()))


@functools.lru_cache(maxsize=2)
def texture_space_model(path: str = str(CURVES_JSON)) -> TextureSpaceModel:
    data = load_curves(path)
    return TextureSpaceModel.fit(data["texture_space"], data["scenes"], data["atlas_fill"])


@functools.lru_cache(maxsize=2)
def form_factor_calibration(path: str = str(CURVES_JSON)) -> float:
    """Measured form factors over ``texture_space_candidate``'s estimate, the median over the measured bakes."""
    data = load_curves(path)
    presets = load_presets()
    ratios = []
    for r in data["texture_space"]:
        s = data["scenes"][r["scene"]]
        m = presets[s["preset"]]
        view = ObjectView(s["diagonal_mm"], s["area_mm2"], None, m.sigma_a, m.sigma_s_prime, m.eta, s["triangles"])
        ratios.append(r["form_factors"] / _form_factors(view, r["proxy_vertices"]))
    return float(np.median(ratios))


@functools.lru_cache(maxsize=2)
def bake_seconds_curve(path: str = str(CURVES_JSON)) -> PowerLaw:
    """TEXTURE_SPACE bake seconds against form factors on the benchmark's machine (a fit, not an envelope)."""
    rows = load_curves(path)["texture_space"]
    ff, sec = np.array([r["form_factors"] for r in rows], float), np.array([r["bake_seconds"] for r in rows])
    p, log_a = np.polyfit(np.log(ff), np.log(sec), 1)
    return PowerLaw(math.exp(log_a), float(p), (float(ff.min()), float(ff.max())))


def choose(method: str, view: ObjectView, target: float = TARGET_DEFAULT, *, grass_tile_mm: float | None = None,
           curves: str = str(CURVES_JSON)) -> Choice:
    """The settings of ``method`` for ``view`` that reach ``target`` at the least cost."""
    if not target > 0:
        raise ValueError(f"target error must be positive, not {target}")
    if view.diagonal_mm <= 0 or view.area_mm2 <= 0:
        raise ValueError("the object has no extent: AUTO needs its size")
    pick = {"IMAGE_SPACE": _image_space, "TEXTURE_SPACE": _texture_space, "QUADGRAPH": _quadgraph,
            "GEOCUBE": _geocube}.get(method)
    if pick is None:
        raise ValueError(f"AUTO knows no resolutions for method '{method}'")
    choice = pick(view, target, curves)
    if grass_tile_mm is not None:
        choice.settings["grass_resolution"] = grass_resolution(view, grass_tile_mm)
    return choice


def _image_space(view: ObjectView, target: float, curves: str) -> Choice:
    k, notes = splat_overlap_for(view, target, curves)
    curve = image_space_curve(curves)
    if 1.0 / k > curve.x_range[1] or 1.0 / k < curve.x_range[0]:
        notes.append("outside the measured k (extrapolated)")
    samples = (k * view.diagonal_mm / view.r_max_mm) ** 2  # samples on the object (bench: 0.8-1.1x this)
    # Past k = 32 the light view needs more than the default 1024 texels a side (the benchmark's k = 48: 2048).
    scene = {"splat_overlap": k, "splat_max_grid": 2048 if k > 32 else 1024}
    return Choice("IMAGE_SPACE", {}, scene, float(curve(1.0 / k)), {"light_view_samples": int(samples)}, notes)


def texture_space_candidate(view: ObjectView, atlas: int, spacing: float, curves: str = str(CURVES_JSON)) -> dict:
    """Predicted proxy, form factors, memory, bake time and error of one (atlas, spacing) setting."""
    fill = load_curves(curves)["atlas_fill"]
    texel_mm = math.sqrt(view.area_mm2 / (fill * atlas * atlas))
    h = spacing * texel_mm  # the proxy's mean edge (bake.proxy.target_triangles)
    triangles = view.area_mm2 / (math.sqrt(3.0) / 4.0 * h * h)
    vertices = triangles / 2.0
    if view.triangles is not None and view.triangles < 0.8 * triangles:
        vertices *= REFINED_VERTEX_FACTOR  # longest-edge bisection, not a decimation (bake.proxy)
    form_factors = _form_factors(view, vertices) * form_factor_calibration(curves)
    ell_min = 1.0 / float(np.max(sigma_tr(view)))
    return {"atlas_resolution": atlas, "proxy_spacing": spacing, "h_mm": h, "proxy_vertices": int(vertices),
            "form_factors": int(form_factors), "memory_mb": form_factors * BYTES_PER_FORM_FACTOR / 2**20,
            "bake_seconds": float(bake_seconds_curve(curves)(form_factors)),
            "texel_mm": texel_mm, "error": float(texture_space_model(curves)(h / view.diagonal_mm, texel_mm / ell_min))}


def sigma_tr(view: ObjectView) -> np.ndarray:
    """Effective transport coefficient per channel, sqrt(3 sigma_a sigma_t') (Shah Eq. 6.6)."""
    return dipole_parameters(view.sigma_a, view.sigma_s_prime, view.eta)[1]


def _form_factors(view: ObjectView, vertices: float) -> float:
    """Throughput factors of a proxy of ``vertices``: each vertex keeps those within its reach (Lensch 6.2,
    ``bake.lensch.throughput_radius``), all of them on an object smaller than the reach."""
    A_v = view.area_mm2 / vertices
    reach = throughput_radius(Material(tuple(view.sigma_a), tuple(view.sigma_s_prime), view.eta), A_v)
    return vertices * min(vertices, math.pi * reach * reach / A_v)


def _texture_space(view: ObjectView, target: float, curves: str) -> Choice:
    cands = [texture_space_candidate(view, a, s, curves) for a in ATLAS_CHOICES for s in SPACING_CHOICES]
    visible = [c for c in cands if c["h_mm"] >= view.pixel_mm / PIXEL_VERTICES] or [
        max(cands, key=lambda c: c["h_mm"])]
    affordable = [c for c in visible if c["form_factors"] <= FORM_FACTOR_BUDGET] or [
        min(visible, key=lambda c: c["form_factors"])]
    meeting = [c for c in affordable if c["error"] <= target]
    notes = []
    if meeting:
        best = min(meeting, key=lambda c: (c["form_factors"], c["atlas_resolution"]))
    else:
        best = min(affordable, key=lambda c: (c["error"], c["form_factors"]))
        if not any(c["error"] <= target for c in cands):
            notes.append("the target is beyond the finest setting: the finest")
        elif not any(c["error"] <= target for c in visible):
            notes.append("the target needs a proxy finer than a quarter pixel of the object, which would not "
                         "show: the finest that shows")
        else:
            notes.append(f"the target needs more than {FORM_FACTOR_BUDGET / 1e6:g}M form factors: the finest "
                         "within them")
    model = texture_space_model(curves)
    x = best["h_mm"] / view.diagonal_mm
    if not model.h_over_D_range[0] * 0.7 <= x <= model.h_over_D_range[1] * 1.5:
        notes.append("outside the measured h / D (extrapolated)")
    ell_over_D = 1.0 / float(np.min(sigma_tr(view))) / view.diagonal_mm
    if not 0.5 * model.ell_over_D_range[0] <= ell_over_D <= 2.0 * model.ell_over_D_range[1]:
        notes.append(f"scattering length / size {ell_over_D:.3g} is outside the measured "
                     f"{model.ell_over_D_range[0]:.3g}-{model.ell_over_D_range[1]:.3g} (extrapolated)")
    cost = {k: best[k] for k in ("proxy_vertices", "form_factors", "bake_seconds")}
    cost["memory_mb"] = round(best["memory_mb"], 1)
    settings = {"atlas_resolution": best["atlas_resolution"], "proxy_spacing": best["proxy_spacing"]}
    return Choice("TEXTURE_SPACE", settings, {}, best["error"], cost, notes)


def quadgraph_surface_spacing_mm(view: ObjectView, K: float, mesh_triangles: int | None = None) -> float:
    """Mean edge of QUADGRAPH's finest proxy at density K (its triangle count, bake.quadgraph_bake)."""
    n = proxy_triangles(K, 1, mesh_triangles)[-1]
    return math.sqrt(view.area_mm2 / (math.sqrt(3.0) / 4.0 * n))


def _quadgraph(view: ObjectView, target: float, curves: str) -> Choice:
    rows = load_curves(curves)["quadgraph"]
    by_K = {}
    for r in rows:
        by_K.setdefault(r["K"], []).append(r["rel_rmse"])
    model = {K: max(v) for K, v in by_K.items()}
    K = 1.0
    notes = ["measured against exact transport: "
             f"{', '.join(f'K {k:g} {100 * e:.1f} %' for k, e in sorted(model.items(), reverse=True))}"
             " (the model's error, which finer K does not reduce)"]
    if view.pixel_mm > 0 and quadgraph_surface_spacing_mm(view, 2.0) < view.pixel_mm:
        K = 2.0
        notes.append("K = 2: its surface nodes are already finer than a pixel of the object")
    if model.get(1.0, 0.0) > target:
        notes.append(f"the target {100 * target:g} % is below this model's measured error")
    return Choice("QUADGRAPH", {"quadgraph_K": K}, {}, None,
                  {"proxy_triangles_spacing_mm": round(quadgraph_surface_spacing_mm(view, K), 2)}, notes)


def _geocube(view: ObjectView, target: float, curves: str) -> Choice:
    res = resolution_for(view.screen_pixels)
    return Choice("GEOCUBE", {"geocube_resolution": res}, {}, None, {"cube_texels": 6 * res * res},
                  ["one cube texel per two pixels of the object"])


def grass_resolution(view: ObjectView, tile_mm: float) -> str:
    """BTF texels per side: the fewest of GRASS_CHOICES that are at least the tile's pixels on screen."""
    if view.pixel_mm <= 0:
        return "128"
    tile_pixels = tile_mm / view.pixel_mm
    for res in GRASS_CHOICES:
        if res >= tile_pixels:
            return str(res)
    return str(GRASS_CHOICES[-1])

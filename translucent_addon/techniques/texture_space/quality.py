"""TEXTURE_SPACE's Auto quality: the cheapest (atlas, proxy spacing) that reaches a target discretisation
error, from the benchmark's measured error model (pure)."""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from ...core.physics import slab_through
from ...core.physics.dipole import dipole_parameters
from ...core.physics.presets import load_presets
from ...core.quality_model import CURVES_JSON, Choice, ObjectView, PowerLaw, load_curves
from .throughput import FAR_THRESHOLD, THRESHOLD, Material, throughput_radius

ATLAS_CHOICES = (128, 192, 256, 384, 512, 768, 1024)


SPACING_CHOICES = (3.5, 2.4)  # the default and the High tier's proxy spacing (texels)


# TEXTURE_SPACE: proxy vertices per pixel of the object (along a side), at most. Measured: the back-lit cow at
# 192x144 (2.5 mm a pixel) went from 8.6 % at a proxy edge of a pixel and a half to 4.2 % at about one
# (bench/results/summary.md), so a cap at one vertex a pixel stopped short; a quarter pixel is the finest kept.
PIXEL_VERTICES = 4.0


FORM_FACTOR_BUDGET = 20_000_000  # 305 MB of throughput factors (16 bytes each), 100 s of bake here; High takes 13-15M


BYTES_PER_FORM_FACTOR = 16


# A mesh coarser than the proxy is refined by longest-edge bisection, which leaves more vertices than an
# equilateral mesh of the same mean edge: the cow at atlas 512 had 2.0x (spacing 3.5) and 1.5x (2.4).
REFINED_VERTEX_FACTOR = 1.75


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
        # The bakes' own profile (curves measured before the exact profile were dipole bakes).
        view = ObjectView(s["diagonal_mm"], s["area_mm2"], None, m.sigma_a, m.sigma_s_prime, m.eta, s["triangles"],
                          profile=data.get("profile", "DIPOLE"))
        ratios.append(r["form_factors"] / _form_factors(view, r["proxy_vertices"]))
    return float(np.median(ratios))


@functools.lru_cache(maxsize=2)
def bake_seconds_curve(path: str = str(CURVES_JSON)) -> PowerLaw:
    """TEXTURE_SPACE bake seconds against form factors on the benchmark's machine (a fit, not an envelope)."""
    rows = load_curves(path)["texture_space"]
    ff, sec = np.array([r["form_factors"] for r in rows], float), np.array([r["bake_seconds"] for r in rows])
    p, log_a = np.polyfit(np.log(ff), np.log(sec), 1)
    return PowerLaw(math.exp(log_a), float(p), (float(ff.min()), float(ff.max())))


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
    """Effective transport coefficient per channel, sqrt(3 sigma_a sigma_t') (Shah Eq. 6.6), at least
    ``slab_through.SIGMA_TR_MIN``: a channel that does not absorb (spectralon) has a diffusion length out of reach,
    not a division by zero."""
    return np.maximum(dipole_parameters(view.sigma_a, view.sigma_s_prime, view.eta)[1], slab_through.SIGMA_TR_MIN)


# Entries (near pairs and far clusters, ``far_field``) a receiving vertex keeps: grows with the octaves of the
# sources within the far reach (each level of the hierarchy adds a ring of clusters). Fitted to the bakes of the
# curves (bunny in marble and cow in skin1, 2.3k-29k vertices: within 2 %).
ENTRIES_AT_ONE = -699.0
ENTRIES_PER_OCTAVE = 111.0
ENTRIES_FLOOR = 50.0  # the near pairs of a vertex with next to no far field


def _form_factors(view: ObjectView, vertices: float) -> float:
    """Form factors of a proxy of ``vertices``: ENTRIES_AT_ONE + ENTRIES_PER_OCTAVE log2 n a vertex, n the vertices
    within the reach of a far entry (``throughput_radius`` at THRESHOLD FAR_THRESHOLD), at most all of them."""
    A_v = view.area_mm2 / vertices
    material = Material(tuple(view.sigma_a), tuple(view.sigma_s_prime), view.eta, view.profile)
    reach = throughput_radius(material, A_v, THRESHOLD * FAR_THRESHOLD)
    within = max(min(vertices, math.pi * reach * reach / A_v), 1.0)
    per_vertex = max(ENTRIES_AT_ONE + ENTRIES_PER_OCTAVE * math.log2(within), ENTRIES_FLOOR)
    return vertices * min(per_vertex, vertices - 1.0)


def auto(view: ObjectView, target: float, curves: str) -> Choice:
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

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

# Each technique's model lives in its quality.py; the names are here too for scripts and tests.
from ..core.quality_model import CURVES_JSON, Choice, ObjectView, PowerLaw, load_curves  # noqa: F401
from . import get
from .grass.quality import GRASS_CHOICES, grass_resolution  # noqa: F401
from .image_space.quality import (  # noqa: F401
    PIXEL_SAMPLES,
    SPLAT_OVERLAP_RANGE,
    image_space_curve,
    splat_overlap_for,
)
from .image_space.quality import auto as _image_space  # noqa: F401
from .quadgraph.quality import QUADGRAPH_K_CHOICES, quadgraph_surface_spacing_mm  # noqa: F401
from .texture_space.quality import (  # noqa: F401
    ATLAS_CHOICES,
    BYTES_PER_FORM_FACTOR,
    FORM_FACTOR_BUDGET,
    PIXEL_VERTICES,
    REFINED_VERTEX_FACTOR,
    SPACING_CHOICES,
    TextureSpaceModel,
    bake_seconds_curve,
    form_factor_calibration,
    sigma_tr,
    texture_space_candidate,
    texture_space_model,
)

TARGET_DEFAULT = 0.05


def choose(method: str, view: ObjectView, target: float = TARGET_DEFAULT, *, grass_tile_mm: float | None = None,
           curves: str = str(CURVES_JSON)) -> Choice:
    """The settings of ``method`` for ``view`` that reach ``target`` at the least cost."""
    if not target > 0:
        raise ValueError(f"target error must be positive, not {target}")
    if view.diagonal_mm <= 0 or view.area_mm2 <= 0:
        raise ValueError("the object has no extent: AUTO needs its size")
    technique = get(method)
    choice = technique.auto_quality(view, target, curves) if technique is not None else None
    if choice is None:
        raise ValueError(f"AUTO knows no resolutions for method '{method}'")
    if grass_tile_mm is not None:
        choice.settings["grass_resolution"] = grass_resolution(view, grass_tile_mm)
    return choice



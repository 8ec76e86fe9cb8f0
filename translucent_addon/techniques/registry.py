"""What each method bakes, as a sequence of stages, and what its bake depends on.

Pure. A bake is a generator: it yields (fraction done, status text) so that the
operator can show progress and cancel between steps, and returns the arrays to
store. Nothing is written to the object until the generator has finished, so a
cancelled bake leaves the object as it was.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core import bake_store as store
from ..core import native
from ..core.geometry.mesh_checks import check_mesh, self_intersections
from ..core.physics.presets import validate_coefficients
from . import get


def method_stages(method: str) -> tuple[str, ...]:
    """The named steps of a method's bake, from its technique (none for Off and for unknown ids)."""
    technique = get(method)
    return tuple(technique.bake_stages) if technique is not None else ()


def no_bake_reason(method: str) -> str:
    if method == "OFF":
        return "method is Off: choose a translucency method first"
    technique = get(method)
    return (technique.no_bake_reason if technique is not None else "") or "unknown method"


# Triangle count above which a bake refuses the mesh and asks for a proxy.
MAX_BAKE_TRIANGLES = 2_000_000


class BakeInputError(ValueError):
    """The object cannot be baked; the message says what and why, in one line."""


@dataclasses.dataclass
class BakeInputs:
    """What a bake is made of: the geometry and the medium, which every method's bake reads, and ``params``,
    the method's own part (its ``Technique.bake_parameters``), which only its bake reads."""

    name: str
    method: str
    vertices: np.ndarray  # (V, 3) float32, object space of the evaluated mesh
    triangles: np.ndarray  # (T, 3) int32, inward-wound parts turned (``core/geometry/orientation``)
    mm_per_unit: float
    sigma_a: tuple
    sigma_s_prime: tuple
    eta: float
    g: float
    profile: str = "EXACT"  # the radial profile of a homogeneous medium (``physics.lut.PROFILES``)
    # The triangles as the mesh holds them, which the hash covers: turning follows the pose (a mirroring shape
    # key turns a part inside out), and a geometry-only bake must not go stale with the pose. None: ``triangles``.
    read_triangles: np.ndarray | None = None
    # The shading normals at each triangle corner (T, 3, 3), object space, where the method asks for them
    # (``Technique.bake_corner_normals``), else None (smooth, angle-weighted).
    corner_normals: np.ndarray | None = None
    # The object's stretch (scale without rotation, 3x3, the symmetric factor of the polar
    # decomposition of its world matrix): the physical size is stretch @ vertex * mm_per_unit.
    stretch: np.ndarray | None = None
    params: Any = None  # the method's own part (``Technique.bake_parameters``); None: its defaults
    screen_pixels: float | None = None  # the object's size on the camera's image (``Technique.needs_screen_pixels``)
    # Makes a ray tracer from the triangles ((T, 3, 3), bake frame): Blender's BVH, which the Blender side
    # passes in (blender/bake_inputs.py); None: brute force (core/geometry/raycast.py). Not part of the hash:
    # any tracer finds the same hits.
    tracer_factory: Callable | None = None

    def __post_init__(self) -> None:
        if self.params is None:
            technique = get(self.method)
            self.params = technique.bake_parameters({}) if technique is not None else None

    def stretch_matrix(self) -> np.ndarray:
        return np.eye(3) if self.stretch is None else np.asarray(self.stretch, np.float64)

    def hash(self) -> str:
        """Hash of what the bake depends on (``hash_parts``)."""
        return store.inputs_hash(*self.hash_parts())

    def hash_parts(self) -> tuple[dict, dict]:
        """(geometry arrays, parameters) the bake depends on: the method's own choice (``Technique.hash_parts``)
        from the geometry and the material, with the method, its stages and the scale."""
        material = {"sigma_a": list(self.sigma_a), "sigma_s_prime": list(self.sigma_s_prime), "eta": self.eta,
                    "g": self.g}
        triangles = self.triangles if self.read_triangles is None else self.read_triangles
        geometry = {"vertices": self.vertices, "triangles": triangles}
        technique = get(self.method)
        if technique is not None:
            geometry, material = technique.hash_parts(self, geometry, material)
        return geometry, {
            "method": self.method,
            "stages": list(method_stages(self.method)),
            "mm_per_unit": self.mm_per_unit,
            **material,
        }


def needs_bake(method: str) -> bool:
    return bool(method_stages(method))


def bakes_auto(method: str) -> bool:
    """Whether a bake of ``method`` uses the resolutions Auto quality chooses (it bakes and has an Auto)."""
    technique = get(method)
    return needs_bake(method) and technique.has_auto_quality


def refuse_size(name: str, triangles: int) -> None:
    """BakeInputError for a mesh of more triangles than a bake takes: asked before anything is made of it
    (a 2.56M-triangle mesh was decimated for 49-116 s and 4 GB before this said no)."""
    if triangles > MAX_BAKE_TRIANGLES:
        raise BakeInputError(f"'{name}': {triangles:,} triangles is more than a bake takes "
                             f"({MAX_BAKE_TRIANGLES:,}); decimate it or bake a proxy")


# What a bake takes, in physical size across (mm): from a micrometre to 10 km. Past these the compiled steps get
# coordinates they were not made for: xatlas spun for ever at 1e30 and at mm per unit >= 1e11, fTetWild crashed
# on a surface scaled to zero.
PHYSICAL_SIZE_MM = (1e-3, 1e7)


def check_physical_size(inputs: BakeInputs) -> None:
    """BakeInputError unless the object's physical geometry (stretch, then mm per unit) is finite, has volume
    along every axis of its scale, and lies within ``PHYSICAL_SIZE_MM``: checked before xatlas, fTetWild or
    SciPy sees it."""
    name, mm = inputs.name, inputs.mm_per_unit
    if not (0.0 < mm < np.inf):
        raise BakeInputError(f"'{name}': mm per unit is {mm} (the scene's unit over the scattering scale), must be "
                             f"a positive number")
    S = inputs.stretch_matrix()
    scale = np.linalg.svd(S, compute_uv=False) if np.isfinite(S).all() else np.array([np.nan])
    if not np.isfinite(scale).all() or scale.min() <= 1e-9 * scale.max():
        raise BakeInputError(f"'{name}': its scale is zero (or not a number) along an axis, so it has no "
                             "volume to bake; give it a size or hide it")
    vertices = np.asarray(inputs.vertices, np.float64)
    if not np.isfinite(vertices).all():
        raise BakeInputError(f"'{name}': some of its vertices are not numbers (NaN or infinite)")
    with np.errstate(over="ignore", invalid="ignore"):
        size = float(np.linalg.norm(np.ptp(vertices @ S.T, axis=0)) * mm) if len(vertices) else 0.0
    lo, hi = PHYSICAL_SIZE_MM
    if not np.isfinite(size) or not (lo <= size <= hi):
        raise BakeInputError(f"'{name}': it is {size:.3g} mm across (scale times mm per unit); a bake takes "
                             f"{lo:g} mm to {hi / 1e6:g} km: check its scale, its vertices and its scattering scale")


def validate(inputs: BakeInputs) -> list[str]:
    """Raise BakeInputError for input no bake can use; return warnings for the rest."""
    if not needs_bake(inputs.method):
        raise BakeInputError(f"'{inputs.name}': nothing to bake, {no_bake_reason(inputs.method)}")
    if len(inputs.triangles) == 0:
        raise BakeInputError(f"'{inputs.name}': the mesh is empty (no faces), nothing to bake")
    refuse_size(inputs.name, len(inputs.triangles))
    try:
        validate_coefficients(inputs.sigma_a, inputs.sigma_s_prime, inputs.eta, inputs.g, name=f"'{inputs.name}'")
    except ValueError as err:
        raise BakeInputError(str(err)) from None
    report = check_mesh(inputs.vertices, inputs.triangles)
    if report.zero_area_triangles == report.triangles:
        raise BakeInputError(f"'{inputs.name}': every face has zero area, nothing to bake")
    check_physical_size(inputs)
    warnings = []
    if report.zero_area_triangles:
        warnings.append(f"'{inputs.name}': {report.zero_area_triangles} zero-area faces carry no light and are ignored")
    if report.boundary_edges:
        warnings.append(f"'{inputs.name}': the mesh is open ({report.boundary_edges} boundary edges); "
                        "light leaks where the surface has holes")
    if report.non_manifold_edges:
        warnings.append(f"'{inputs.name}': {report.non_manifold_edges} non-manifold edges")
    crossing = self_intersections(inputs.vertices, inputs.triangles)
    if crossing:
        warnings.append(f"'{inputs.name}': the surface intersects itself ({crossing} pairs of faces cross); "
                        "its inside is ambiguous, so light may leak or be trapped there")
    return warnings


def run(inputs: BakeInputs):
    """Generator: yields (fraction, text); returns (arrays, meta). Each stage is the technique's bake; its
    declared refusals become one-line BakeInputErrors."""
    technique = get(inputs.method)
    stages = method_stages(inputs.method)
    arrays: dict[str, np.ndarray] = {}
    meta_extra: dict = {}
    for i, stage in enumerate(stages):
        yield i / len(stages), f"{inputs.method}: {stage}"
        job = technique.bake(inputs, stage)
        try:
            while True:
                fraction, text = next(job)
                yield (i + fraction) / len(stages), text
        except StopIteration as done:
            stage_arrays, stage_meta = done.value
        except (*technique.bake_errors, native.NativeStepError) as err:
            raise BakeInputError(f"'{inputs.name}': {err}") from None
        finally:
            job.close()  # cancelled (Esc closes this generator): the stage's child process is stopped now
        arrays.update(stage_arrays)
        meta_extra.update(stage_meta)
    yield 1.0, f"{inputs.method}: done"
    meta = {"stages": list(stages), "vertices": int(len(inputs.vertices)), "triangles": int(len(inputs.triangles)),
            **meta_extra}
    return arrays, meta

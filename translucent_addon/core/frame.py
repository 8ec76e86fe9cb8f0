"""Pure description of one frame: what the GPU pipeline and the CPU references draw.

Blender data is turned into this by ``blender.extract`` (the only bpy-facing step), so
the GPU pipeline and the NumPy reference renderers see exactly the same inputs.
Conventions: right-handed world space in Blender units, matrices column-vector
(``p_world = model @ p_object``), OpenGL clip space, image row 0 at the bottom.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from .lights import Emitter
from .physics.microfacet import f0_of
from .physics.sh_irradiance import project_equirect, uniform_coefficients
from .surface import Surface, plain


@dataclasses.dataclass(frozen=True)
class Medium:
    """A homogeneous scattering medium: coefficients in mm^-1 and the object's scale."""

    sigma_a: tuple
    sigma_s_prime: tuple
    eta: float
    mm_per_unit: float
    g: float = 0.0
    # The radial profile of a homogeneous medium (``physics.lut.PROFILES``): exact transport or the dipole.
    profile: str = "EXACT"
    # Optional multipole: this medium as a layer of the given thickness over a base (Shah 6.5).
    layer_thickness_mm: float | None = None
    base_sigma_a: tuple | None = None
    base_sigma_s_prime: tuple | None = None
    # What the method drawing it adds of its own (its ``Technique.medium_extras``: frozen and hashable), or None.
    extras: Any = None


# Painted heterogeneity per corner (Shah ch. 7): translucency mask m, distance multiplier M_d
# (blur), glow factor; the RGB tint is a separate array. Neutral: (1, 1, 1, 0) and tint (1, 1, 1).
NEUTRAL_PAINT = (1.0, 1.0, 1.0, 0.0)


class Lost(str):
    """A frame warning that says an object is not drawn as the file asks because its data is bad (a damaged
    bake, vertices that are not numbers, a medium out of range): a batch render fails on it (issue 37)."""


class BakeHandle:
    """An up-to-date bake of a drawn object: ``key`` names its content (method, data hash, where it is read from:
    every object drawing the same bake shares its GPU data), ``owner`` the object it is drawn for, ``load()``
    reads its arrays (only when the GPU data of that key is not cached yet)."""

    def __init__(self, key: str, load: Callable[[], Any], owner: str = ""):
        self.key = key
        self.load = load
        self.owner = owner


@dataclasses.dataclass
class MeshInstance:
    """One drawn mesh: triangle corners in object space and a model matrix."""

    key: str  # stable identity for GPU caches (object name + data + geometry hash)
    name: str
    positions: np.ndarray  # (3T, 3) float32, object space, triangle corners in order
    normals: np.ndarray  # (3T, 3) float32, object-space corner normals (Blender's split normals)
    colors: np.ndarray  # (3T, 3) float32, linear base colour per corner (from the material)
    model: np.ndarray  # (4, 4) float64
    method: str = "OFF"
    medium: Medium | None = None
    paint: np.ndarray | None = None  # (3T, 4) float32: mask, M_d, glow, 0
    tint: np.ndarray | None = None  # (3T, 3) float32
    bake: object = None  # BakeHandle of an up-to-date bake (methods that bake), else None
    # What techniques other than its method draw of it, by technique id (``Technique.object_extras``: a caustics
    # caster, a grass field growing on it, a height field displacing it); a technique absent here does not.
    extras: dict = dataclasses.field(default_factory=dict)
    auto_target: float | None = None  # AUTO quality's target error (IMAGE_SPACE chooses k per frame); None: manual
    bound_points: np.ndarray | None = None  # (V, 3) object-space points holding the mesh (its vertices); None: corners
    # The materials' surface per corner: colour textures, gloss, normal maps (core/surface.py). None: a plain one,
    # the methods' colour and a smooth boundary's gloss for a medium (``surface_or_plain``).
    surface: Surface | None = None
    _box: tuple | None = dataclasses.field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = len(self.positions)
        if n % 3 or self.normals.shape != (n, 3) or self.colors.shape != (n, 3):
            raise ValueError(f"{self.name}: corner arrays must be (3T, 3) and of equal length")
        if self.paint is None:
            self.paint = np.tile(np.asarray(NEUTRAL_PAINT, np.float32), (n, 1))
        if self.tint is None:
            self.tint = np.ones((n, 3), np.float32)
        if self.paint.shape != (n, 4) or self.tint.shape != (n, 3):
            raise ValueError(f"{self.name}: paint must be (3T, 4) and tint (3T, 3)")

    @property
    def source(self) -> str:
        """What stays the same across frames of this geometry while its arrays change (a deforming mesh): its key
        without the serial after '#' (the object's name, or its mesh's that linked duplicates share)."""
        return self.key.split("#")[0]

    @property
    def triangle_count(self) -> int:
        return len(self.positions) // 3

    @property
    def normal_matrix(self) -> np.ndarray:
        """Inverse transpose of the model's linear part, padded to 4x4 (std140 friendly)."""
        m = np.eye(4)
        m[:3, :3] = np.linalg.inv(self.model[:3, :3]).T
        return m

    def world_positions(self) -> np.ndarray:
        p = self.positions.astype(np.float64)
        return p @ self.model[:3, :3].T + self.model[:3, 3]

    def world_box(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) world-space box around the mesh: from its vertices, not the 3T corners (a sixth of the work
        per frame)."""
        if self._box is None:
            p = self.positions if self.bound_points is None else self.bound_points
            w = np.asarray(p, np.float64) @ self.model[:3, :3].T + self.model[:3, 3]
            self._box = (w.min(axis=0), w.max(axis=0))
        return self._box

    def surface_or_plain(self) -> Surface:
        """The mesh's surface, or the one it has without materials: a medium's smooth boundary (roughness 0, F_0
        of its eta), no gloss on a Lambert object."""
        if self.surface is not None:
            return self.surface
        if self.medium is None:
            return plain(len(self.positions))
        return plain(len(self.positions), 0.0, f0_of(self.medium.eta), True)

    def world_normals(self) -> np.ndarray:
        n = self.normals.astype(np.float64) @ self.normal_matrix[:3, :3].T
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)


@dataclasses.dataclass
class CameraView:
    """A camera: view and projection matrices and the image size in pixels."""

    view: np.ndarray  # (4, 4) world -> camera
    projection: np.ndarray  # (4, 4) camera -> clip (OpenGL)
    width: int
    height: int

    @property
    def view_proj(self) -> np.ndarray:
        return self.projection @ self.view

    @property
    def position(self) -> np.ndarray:
        return np.linalg.inv(self.view)[:3, 3]

    def sees_box(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        """Whether a world box may show in the image: False only when all eight corners lie outside one plane of the
        view frustum (clip space, x, y, z against +-w), so a box the camera sees in part is always kept."""
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        clip = corners @ np.asarray(self.view_proj, np.float64).T
        w = clip[:, 3]
        return not any(bool(np.all(sign * clip[:, axis] > w)) for axis in range(3) for sign in (1.0, -1.0))


@dataclasses.dataclass
class Environment:
    """The world as an equirectangular radiance image (Blender's Environment Texture, times the
    Background strength), for the methods that look it up by direction (GEOCUBE). ``key`` names the
    image and strength for GPU caches."""

    key: str
    image: np.ndarray  # (H, W, 3) float32 linear radiance, row 0 at the bottom
    mean: np.ndarray  # (3,) its solid-angle-weighted average: the uniform world the base pass uses
    _sh: np.ndarray | None = dataclasses.field(default=None, init=False, repr=False, compare=False)

    def sh(self) -> np.ndarray:
        """Its radiance in SH bands 0-2 (``project_equirect``), projected once: the Blender layer hands the same
        Environment to every frame while the image is unchanged, and the renderer and the references ask for it
        every frame."""
        if self._sh is None:
            self._sh = project_equirect(self.image)
        return self._sh


@dataclasses.dataclass(frozen=True)
class DrawSettings:
    """The scene's drawing settings for one frame, read by the Blender layer (``Scene.translucent``): each
    technique's own settings by its id (what its ``settings`` made of the properties it declares), IMAGE_SPACE's
    frame-to-frame sample coherence, and whether the passes read back their intermediate targets (tests)."""

    techniques: dict = dataclasses.field(default_factory=dict)  # technique id -> its settings object
    coherence_key: str | None = None  # the name of a sequence of frames whose samples are reused; None: off
    coherence_frame: int = 0  # this frame's number in that sequence
    capture: bool = False
    passes: bool = False  # keep the surface layer's Specular, Normal and Depth for the render passes (F12)

    def of(self, technique_id: str, default: Any = None) -> Any:
        """One technique's settings (``default`` where the frame has none for it)."""
        return self.techniques.get(technique_id, default)


@dataclasses.dataclass
class FrameInputs:
    """Everything one frame needs, in plain arrays."""

    meshes: list[MeshInstance]
    emitters: list[Emitter]
    camera: CameraView
    world_color: np.ndarray  # (3,) linear radiance of the uniform world
    film_transparent: bool = False
    environment: Environment | None = None  # None: the uniform world_color in every direction
    shadow_resolution: int = 1024  # texels per shadow-map face
    warnings: list[str] = dataclasses.field(default_factory=list)  # ``Lost`` ones name undrawable objects
    settings: DrawSettings = dataclasses.field(default_factory=DrawSettings)
    _bounds: tuple | None = dataclasses.field(default=None, init=False, repr=False, compare=False)

    @property
    def lost(self) -> list[str]:
        """The warnings of objects not drawn as the file asks (``Lost``)."""
        return [w for w in self.warnings if isinstance(w, Lost)]

    def world_sh(self) -> np.ndarray:
        """The world's radiance in SH bands 0-2, L_lm (9, 3): the environment image's (projected once per
        image), or the uniform colour's."""

        if self.environment is None:
            return uniform_coefficients(self.world_color)
        return self.environment.sh()

    def bounds(self) -> tuple[np.ndarray, float]:
        """Centre and radius of a sphere around every mesh (for directional shadow maps), computed once."""
        if self._bounds is None:
            if not self.meshes:
                self._bounds = (np.zeros(3), 1.0)
            else:
                lo, hi = box_of(self.meshes)
                self._bounds = (0.5 * (lo + hi), max(float(np.linalg.norm(hi - lo)) * 0.5, 1e-4))
        return self._bounds


def box_of(meshes: list[MeshInstance]) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) world-space box around meshes."""
    boxes = [m.world_box() for m in meshes]
    return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)

"""IMAGE_SPACE (Shah ch. 6-7): the per-frame plan, uniform data and a CPU twin of the splats. Pure.

Light is carried from light-view samples x_i to camera-view points x_o (Shah Eq. 6.13):

    L(x_o) = F_t(w_o) / pi * sum_i R_d(M_i |x_o - x_i|) M_i^2 Phi_i        (splats, far field)
           + F_t(w_o) / pi * E_t(x_o) near(M)                              (lighting pass, near field)

Each sample carries Phi_i = E_t(x_i) dA_i, the power entering the medium through its light-view
texel: I F_t dw_texel for a point emitter (the 1/d^2 and the texel's footprint cancel), E F_t
texel_area for a directional one. The profile is split by a smooth partition at rho, two sample
spacings (see physics.lut.image_space_tables): samples only carry the far field, which is smooth
on the sample grid, and the sharp peak is integrated exactly. So the sample count follows the
profile's spread, not its peak. (Shah's Eq. 6.17 taken as printed asks for 10^5 to 10^6
overlapping splats per point for the measured materials; we choose the spacing as r_max / k with
the overlap factor k instead, and measure the error against splat count.)
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from ...core.frame import FrameInputs, MeshInstance, box_of
from ...core.lights import DIRECTIONAL, Emitter
from ...core.physics import angular_law, exit_lean, oblique_entry, slab_through
from ...core.physics.dipole import r_max
from ...core.physics.lut import (
    BLUR_MIN,
    TAIL_BLOCK,
    TAIL_REACH,
    ImageSpaceTables,
    crossover,
    image_space_tables,
    multipole_profile,
    partition_off_plane,
    profile_model,
    profile_tables,
)
from ...core.physics.sh_irradiance import transmittance_kernel
from ...gpu.blocks import look_at, orthographic, perspective, shadow_projection

MAX_MATERIALS = 32
FAR_SAMPLES = 256
NEAR_SAMPLES = 32
MIN_GRID = 16
FIT_MARGIN = 1.2  # a point light farther than this many bounding radii gets a fitted frustum
FIT_MARGIN_ANGLE = 1.05  # the fitted frustum's half angle, over the sphere's angular radius


@dataclasses.dataclass(frozen=True)
class SamplingSettings:
    epsilon: float = 0.01  # Shah Eq. 6.16: the share of R_d's integral beyond the splat radius
    overlap: float = 32.0  # k: sample spacing = r_max / k at the object (bench: 5 % against the model)
    max_grid: int = 1024  # texels per light-view face side, at most
    world_layers: int = 4  # depth-peeled layers per axis for world light (Shah 6.4.2); 0: locally flat closed form
    world_overlap: float = 16.0  # k of the world samples (a thin marble slab: 47 % off at 4, 26 % at 8, 3.4 % at 16)


@dataclasses.dataclass
class WorldSampling:
    """World light (Shah 6.4.2): every surface receives it, so the IMAGE_SPACE meshes are depth peeled
    along the three axes (orthographic, ``layers`` each). A texel on a facet of normal n_g stands for
    texel_area / |n_g . a| of surface; weighting the three axes by |n_g . a| / sum_b |n_g . b| (a
    partition of unity) gives each sample the power E_sh(n) texel_area / sum_b |n_g . b|, bounded."""

    faces: np.ndarray  # (3, 4, 4) view-projection per axis +X, +Y, +Z
    grid: int
    texel_area: float  # world units^2
    layers: int
    depth_epsilon: float  # window depth ([0, 1]) a layer must lie beyond the previous one
    rho_mm: list  # the world splats' partition radius per material slot


@dataclasses.dataclass
class EmitterSampling:
    emitter: Emitter
    faces: np.ndarray  # (6, 4, 4) view-projection per face (face 0 only for directional)
    origin: np.ndarray
    n_faces: int
    grid: int  # texels per face side
    texel_measure: float  # directional: texel area (world units^2); point: solid angle at the face centre
    tan_half: float = 1.0  # point: tangent of the face's half angle (1 for cube faces)

    @property
    def sample_count(self) -> int:
        return self.n_faces * self.grid * self.grid


TAG_SLOTS = 64  # a tag holds the object's number times this plus its material slot (common.glsl material_slot)


def object_tag(number: int, slot: int) -> int:
    """The tag of the ``number``-th subsurface object of a frame (from 0) with material slot ``slot``: what its
    object block and its samples and pixels carry (float32-exact up to 2^24 / 64 = 262,144 objects). Splats land
    only on pixels of the same tag (Shah 6.4.3's id clipping: no light crosses between objects), and the slot names
    its medium's tables, which objects of one medium share: any number of objects, at most MAX_MATERIALS media."""
    return (number + 1) * TAG_SLOTS + slot


@dataclasses.dataclass
class ImageSpacePlan:
    slot_of: dict  # mesh index in frame.meshes -> material slot (0-based), shared by meshes of one medium and rho
    tables: list[ImageSpaceTables]
    media: list
    samplings: list[EmitterSampling]
    rho_world: list[float]
    world: WorldSampling | None = None
    epsilon: float = 0.01  # the profile share beyond the splat radius (SamplingSettings.epsilon)
    tag_of: dict = dataclasses.field(default_factory=dict)  # mesh index -> its tag (``object_tag``)

    def far_lut(self) -> np.ndarray:
        """(3 rows per slot, FAR_SAMPLES, 4) float32: rows 0..n-1 the profile to r_max, rows n..2n-1 its tail
        to TAIL_REACH r_max, rows 2n..3n-1 the exit lean beta(r) to r_max (``lean_row``)."""
        n = max(1, len(self.tables))
        out = np.zeros((3 * n, FAR_SAMPLES, 4), np.float32)
        for k, t in enumerate(self.tables):
            out[k, :, :3] = t.far
            out[n + k, :, :3] = t.tail
            out[2 * n + k, :, :3] = self.lean_row(k)
        return out

    def lean_row(self, slot: int) -> np.ndarray:
        """(FAR_SAMPLES, 3): how the light leaving leans away from where it entered, beta(r) at r = u^2 r_max
        (``physics.exit_lean``): the EXACT profile's; 0 for DIPOLE and a layer over a base (no lean)."""
        med = self.media[slot]
        if med.profile != "EXACT" or med.layer_thickness_mm is not None:
            return np.zeros((FAR_SAMPLES, 3))
        u = np.linspace(0.0, 1.0, FAR_SAMPLES)
        return exit_lean.beta(u * u * self.tables[slot].r_max, med.sigma_a, med.sigma_s_prime, med.eta)

    def near_lut(self) -> np.ndarray:
        """(2 rows per slot, NEAR_SAMPLES, 4): rows 0..n-1 the lights' near field near(M) at rho, rows n..2n-1
        the world's: near(M) at the world splats' rho, or the whole profile (closed form) when not peeled."""
        n = max(1, len(self.tables))
        out = np.zeros((2 * n, NEAR_SAMPLES, 4), np.float32)
        for k, (t, med) in enumerate(zip(self.tables, self.media)):
            out[k, :, :3] = t.near
            if self.world is None:
                out[n + k, :, :3] = t.total
            else:
                out[n + k, :, :3] = material_tables(med, self.world.rho_mm[k], self.epsilon).near
        return out


def slab_constants(med) -> tuple[np.ndarray, np.ndarray, float]:
    """``slab_through.constants`` of a medium (a layer over a base keeps its own profile: factor 1)."""
    return slab_through.constants(med.sigma_a, med.sigma_s_prime, med.eta, layered=med.layer_thickness_mm is not None)


def materials_block(p: "ImageSpacePlan | None") -> bytes:
    """The MaterialsData block (common/structs.glsl). params, 2 vec4 per slot: (mm_per_unit, r_max_mm,
    rho_mm, eta) and (A_0, A_1, A_2 of the world's transmittance kernel, the world splats' rho mm); slab, 2 vec4
    per slot: (sigma_tr rgb, A(eta)) and (z_r rgb, 0) of ``slab_through``; angular, ``angular_law.SAMPLES`` vec4
    per slot: the medium's profile's angular law; through_exit, 3 vec4 per slot: ``angular_law.through_constants``
    and 1 for the EXACT profile (the DIPOLE keeps the Lambertian law); entry, 1 vec4 per slot:
    (``oblique_entry.medium_shift_mm``, 0); lean, 1 vec4 per slot: (``exit_lean.near_constant`` at the lights' rho,
    0; zeros where ``lean_row`` is). Zeros for None."""
    data = np.zeros((MAX_MATERIALS, 2, 4), np.float32)
    slab = np.zeros((MAX_MATERIALS, 2, 4), np.float32)
    angular = np.zeros((MAX_MATERIALS, angular_law.SAMPLES, 4), np.float32)
    through = np.zeros((MAX_MATERIALS, 3, 4), np.float32)
    entry = np.zeros((MAX_MATERIALS, 4), np.float32)
    lean = np.zeros((MAX_MATERIALS, 4), np.float32)
    for k, (t, m) in enumerate(zip(p.tables, p.media) if p is not None else ()):
        data[k, 0] = (m.mm_per_unit, t.r_max, t.rho, m.eta)
        data[k, 1, :3] = transmittance_kernel(m.eta)
        data[k, 1, 3] = p.world.rho_mm[k] if p.world is not None else 0.0
        sigma_tr, z_r, A_eta = slab_constants(m)
        slab[k, 0] = (*sigma_tr, A_eta)
        slab[k, 1, :3] = z_r
        angular[k, :, :3] = angular_table(m)
        if m.profile == "EXACT":
            through[k, :, :3] = angular_law.through_constants(m.sigma_a, m.sigma_s_prime, m.eta)
            through[k, 0, 3] = 1.0
        entry[k, :3] = oblique_entry.medium_shift_mm(m)
        lean[k, :3] = near_lean(m, t.rho)
    return data.tobytes() + slab.tobytes() + angular.tobytes() + through.tobytes() + entry.tobytes() + lean.tobytes()


@functools.lru_cache(maxsize=64)
def _near_lean(sigma_a: tuple, sigma_s_prime: tuple, eta: float, rho_mm: float) -> np.ndarray:
    return exit_lean.near_constant(sigma_a, sigma_s_prime, eta, rho_mm)


def near_lean(med, rho_mm: float) -> np.ndarray:
    """K (3,) mm of the near field's lean (``exit_lean.near_constant``): the EXACT profile's; 0 for DIPOLE and a
    layer over a base. Cached: the block is written every frame."""
    if med.profile != "EXACT" or med.layer_thickness_mm is not None:
        return np.zeros(3)
    return _near_lean(tuple(map(float, med.sigma_a)), tuple(map(float, med.sigma_s_prime)), float(med.eta),
                      float(rho_mm))



def through_exit_law(med, mu_o: float, ramp: np.ndarray) -> np.ndarray:
    """(..., 3): the light of pairs across a thin part (``ramp`` of ``slab_through``, per channel) leaves by the
    diffusion mode's law over the angular law, M(mu_o) / a(mu_o) (``angular_law.through_exit``); 1 for DIPOLE."""
    if med.profile != "EXACT":
        return np.ones_like(ramp)
    ratio = angular_law.through_exit_ratio(med.sigma_a, med.sigma_s_prime, med.eta, mu_o)
    return 1.0 + (ratio - 1.0) * ramp


def angular_table(med) -> np.ndarray:
    """The angular law's a(mu) (``angular_law.SAMPLES``, 3) of a medium under its profile (ones for DIPOLE)."""
    return profile_model(med.profile).angular_table(med.sigma_a, med.sigma_s_prime, med.eta)


def world_sampling(meshes: list[MeshInstance], media, tables, settings: SamplingSettings) -> WorldSampling | None:
    """The depth-peeling plan of world light, or None when it is off (no layers)."""
    if settings.world_layers <= 0:
        return None
    centre, radius = _bounds(meshes)
    spacing = min(t.r_max / settings.world_overlap / med.mm_per_unit for t, med in zip(tables, media))
    grid = int(np.clip(math.ceil(2 * radius / spacing), MIN_GRID, settings.max_grid))
    reach = 2.0 * radius
    faces = np.stack([orthographic(radius, radius, 0.0, 2.0 * reach) @ look_at(centre - axis * reach, axis, up)
                      for axis, up in zip(np.eye(3), np.roll(np.eye(3), -1, axis=0))])
    texel = 2.0 * radius / grid
    rho_mm = [partition_radius(2.0 * texel) * med.mm_per_unit for med in media]
    # One part in 2^13 of the window depth range: far below a texel, far above float32 depth noise.
    return WorldSampling(faces, grid, texel * texel, int(settings.world_layers), 2.0 / 16384.0, rho_mm)


def _bounds(meshes: list[MeshInstance]):
    lo, hi = box_of(meshes)
    return 0.5 * (lo + hi), max(float(np.linalg.norm(hi - lo)) * 0.5, 1e-6)


def plan(frame: FrameInputs, settings: SamplingSettings = SamplingSettings()) -> ImageSpacePlan | None:
    """Material slots, tags, sampling grids and partition radii for the IMAGE_SPACE meshes of a frame: any number
    of objects; the objects of one medium and partition radius share a material slot (at most MAX_MATERIALS)."""
    idx = [k for k, m in enumerate(frame.meshes) if m.method == "IMAGE_SPACE" and m.medium is not None]
    if not idx:
        return None
    meshes = [frame.meshes[k] for k in idx]
    media = [m.medium for m in meshes]
    # A layer the multipole cannot model is drawn as the top layer alone (a homogeneous medium with the
    # profile the other methods take for a layer), and the frame says so.
    for j, (mesh, med) in enumerate(zip(meshes, media)):
        if med.layer_thickness_mm is not None:
            try:
                material_tables(med, 1.0, settings.epsilon)
            except ValueError as err:
                frame.warnings.append(f"'{mesh.name}': {err}; drawn as the top layer alone, without its base")
                media[j] = dataclasses.replace(med, layer_thickness_mm=None)
    # Splat radius per material: r_max of its profile (rho does not change it).
    radii_mm = [material_tables(med, 1.0, settings.epsilon).r_max for med in dict.fromkeys(media)]
    spacing_world = min(r / settings.overlap / med.mm_per_unit for r, med in zip(radii_mm, dict.fromkeys(media)))
    centre, radius = _bounds(meshes)
    scene_centre, scene_radius = frame.bounds()
    samplings = []
    for e in frame.emitters:
        if e.kind == DIRECTIONAL:
            axis = np.asarray(e.direction)
            reach = float(np.linalg.norm(centre - scene_centre)) + 2.0 * scene_radius
            origin = centre - axis * reach
            faces = np.tile(np.eye(4), (6, 1, 1))
            faces[0] = orthographic(radius, radius, 0.0, 2.0 * reach) @ look_at(origin, axis, (0, 0, 1))
            grid = int(np.clip(math.ceil(2 * radius / spacing_world), MIN_GRID, settings.max_grid))
            samplings.append(EmitterSampling(e, faces, origin, 1, grid, (2 * radius / grid) ** 2))
        else:
            position = np.asarray(e.position, float)
            d = float(np.linalg.norm(position - centre))
            if d > FIT_MARGIN * radius:
                # A frustum fitted to the objects' bounding sphere, as Shah fits the light view to the
                # object (the width W of Eq. 6.18): every texel can land on the objects.
                half = math.asin(min(radius / d, 0.99)) * FIT_MARGIN_ANGLE
                tan_half = math.tan(half)
                faces = np.tile(np.eye(4), (6, 1, 1))
                far = d + 2.0 * scene_radius
                faces[0] = perspective(2 * half, 1.0, max(far * 1e-4, 1e-5), far) @ look_at(position, centre - position,
                                                                                             (0, 0, 1))
                grid = int(np.clip(math.ceil(2 * d * tan_half / spacing_world), MIN_GRID, settings.max_grid))
                samplings.append(EmitterSampling(e, faces, position, 1, grid, (2.0 * tan_half / grid) ** 2, tan_half))
            else:
                # The light is among the objects: all directions, a cube map.
                faces, origin = shadow_projection(e, scene_centre, scene_radius)
                grid = int(np.clip(math.ceil(2 * max(d, radius) / spacing_world), MIN_GRID, settings.max_grid))
                samplings.append(EmitterSampling(e, faces, origin, 6, grid, (2.0 / grid) ** 2, 1.0))
    rho_of = []
    for m in meshes:
        c_m = _bounds([m])[0]
        spacing = spacing_world
        for s in samplings:
            if s.emitter.kind == DIRECTIONAL:
                spacing = max(spacing, math.sqrt(s.texel_measure))
            else:
                d = max(float(np.linalg.norm(np.asarray(s.emitter.position) - c_m)), 1e-6)
                spacing = max(spacing, 2.0 * d * s.tan_half / s.grid)
        rho_of.append(partition_radius(2.0 * spacing))
    # One material slot per medium and partition radius (rho is rounded to RHO_STEPS per doubling, so objects
    # of one material mostly share it).
    slots: dict = {}
    slot_of, tag_of, dropped = {}, {}, []
    for k, med, rho in zip(idx, media, rho_of):
        slot = slots.setdefault((med, rho), len(slots))
        if slot >= MAX_MATERIALS:
            dropped.append(k)
            continue
        slot_of[k] = slot
        tag_of[k] = object_tag(len(tag_of), slot)
    if dropped:  # one material slot per medium in the shaders' uniform block
        names = ", ".join(f"'{frame.meshes[k].name}'" for k in dropped)
        frame.warnings.append(f"IMAGE_SPACE draws at most {MAX_MATERIALS} different media a frame: {names} drawn "
                              "without subsurface light (give them a medium another object has, or another method)")
    keys = list(slots)[:MAX_MATERIALS]
    media = [med for med, _ in keys]
    rho_world = [rho for _, rho in keys]
    tables = [material_tables(med, rho * med.mm_per_unit, settings.epsilon) for med, rho in keys]
    has_world = bool(np.any(np.asarray(frame.world_color) > 0)) or frame.environment is not None
    drawn = [frame.meshes[k] for k in slot_of]
    world = world_sampling(drawn, media, tables, settings) if has_world else None
    return ImageSpacePlan(slot_of, tables, media, samplings, rho_world, world, settings.epsilon, tag_of)


RHO_STEPS = 8  # partition radii per doubling


def partition_radius(rho: float) -> float:
    """The partition radius rho (near field at E(x_o) inside, splats outside: any rho is consistent) rounded up
    to one of RHO_STEPS per doubling: a light or an object that moves changes the sample spacing every frame,
    and rho names the material's tables, which took 30-130 ms to make again each time (issue 36)."""
    if not rho > 0 or not math.isfinite(rho):
        return rho
    return float(2.0 ** (math.ceil(math.log2(rho) * RHO_STEPS - 1e-9) / RHO_STEPS))


@functools.lru_cache(maxsize=64)
def material_tables(med, rho_mm: float, epsilon: float) -> ImageSpaceTables:
    """The tables of a medium with its profile (exact or dipole), or the multipole ones when it is a layer
    over a base.

    Cached: ``plan`` asks for them (and for r_max at rho = 1) every frame.
    """
    if med.layer_thickness_mm is None:
        return image_space_tables(med.sigma_a, med.sigma_s_prime, med.eta, rho_mm, epsilon, FAR_SAMPLES,
                                  NEAR_SAMPLES, med.profile)

    # The grid follows the materials: cells a quarter of the layer's shortest mean free path, wide
    # enough for the base's profile as far as the tail splats reach (TAIL_REACH r_max), at most 2048 cells a side.
    z_r = min(1.0 / (a + s) for a, s in zip(med.sigma_a, med.sigma_s_prime))
    extent = TAIL_REACH * float(np.max(r_max(np.asarray(med.base_sigma_a, float),
                                             np.asarray(med.base_sigma_s_prime, float), med.eta, epsilon)))
    h = max(z_r / 4.0, extent / 1024.0)
    radii, profile = multipole_profile(tuple(med.sigma_a), tuple(med.sigma_s_prime), float(med.layer_thickness_mm),
                                       tuple(med.base_sigma_a), tuple(med.base_sigma_s_prime), float(med.eta),
                                       extent_mm=round(extent, 3), h_mm=round(h, 4))
    return profile_tables(radii, profile, rho_mm, epsilon, FAR_SAMPLES, NEAR_SAMPLES)


def lean_lookup(row: np.ndarray, r_mm, r_max: float) -> np.ndarray:
    """CPU twin of the shader's lean lookup: beta(r) from ``ImageSpacePlan.lean_row`` by linear interpolation in
    u = sqrt(r / r_max), held at r_max beyond."""
    u = np.sqrt(np.clip(np.asarray(r_mm, np.float64) / r_max, 0.0, 1.0)) * (FAR_SAMPLES - 1)
    i0 = np.minimum(np.floor(u).astype(int), FAR_SAMPLES - 1)
    i1 = np.minimum(i0 + 1, FAR_SAMPLES - 1)
    f = (u - i0)[..., None]
    return (1 - f) * row[i0] + f * row[i1]


def far_lookup(table: ImageSpaceTables, s_mm, tail: bool = False):
    """CPU twin of the shader's far lookup: R_d(s) by linear interpolation in u = sqrt(s / reach), reach r_max
    (or TAIL_REACH r_max in the tail's table)."""
    s_mm = np.asarray(s_mm, dtype=np.float64)
    reach, values = (TAIL_REACH * table.r_max, table.tail) if tail else (table.r_max, table.far)
    u = np.sqrt(np.clip(s_mm / reach, 0.0, 1.0)) * (FAR_SAMPLES - 1)
    i0 = np.floor(u).astype(int)
    i1 = np.minimum(i0 + 1, FAR_SAMPLES - 1)
    f = (u - i0)[..., None]
    value = (1 - f) * values[i0] + f * values[i1]
    return np.where((s_mm < reach)[..., None], value, 0.0)


def tail_samples(sample_pos_id: np.ndarray, sample_flux: np.ndarray):
    """CPU twin of the tail splats' samples: each TAIL_BLOCK x TAIL_BLOCK block of the light-view atlas
    (H, W, 4) becomes one sample of its first object's texels (row-major within the block): their summed
    power at their power-weighted mean position and blur. Returns (pos_id, flux), (blocks, 4) each."""
    pos_id = np.asarray(sample_pos_id, np.float64)
    flux = np.asarray(sample_flux, np.float64)
    h, w = pos_id.shape[:2]
    b = TAIL_BLOCK
    rows, cols = -(-h // b), -(-w // b)
    pad = ((0, rows * b - h), (0, cols * b - w), (0, 0))
    blocks = [np.pad(a, pad).reshape(rows, b, cols, b, 4).transpose(0, 2, 1, 3, 4).reshape(rows * cols, b * b, 4)
              for a in (pos_id, flux)]
    pid, fl = blocks
    valid = (pid[..., 3] > 0.5) & (fl[..., :3].max(axis=-1) > 0.0)
    first = np.argmax(valid, axis=1)
    slot = np.where(valid.any(axis=1), pid[np.arange(len(pid)), first, 3], 0.0)
    mine = valid & (np.abs(pid[..., 3] - slot[:, None]) < 0.5)
    weight = fl[..., :3].sum(axis=-1) * mine
    total = np.maximum(weight.sum(axis=1), 1e-30)
    out_pid = np.zeros((len(pid), 4))
    out_flux = np.zeros((len(pid), 4))
    out_pid[:, :3] = (pid[..., :3] * weight[..., None]).sum(axis=1) / total[:, None]
    out_pid[:, 3] = slot
    out_flux[:, :3] = (fl[..., :3] * mine[..., None]).sum(axis=1)
    out_flux[:, 3] = np.where(slot > 0, (fl[..., 3] * weight).sum(axis=1) / total, 1.0)
    return out_pid, out_flux


def splat_cpu(plan_: ImageSpacePlan, sample_pos_id: np.ndarray, sample_flux: np.ndarray, x_o: np.ndarray,
              id_o: np.ndarray, n_o: np.ndarray, to_eye: np.ndarray, world: bool = False,
              tail: bool = False) -> np.ndarray:
    """The scatter sum S(x_o) = sum_i [id_i = id_o] R_d(M_i r) M_i^2 w(r) Phi_i, as the splat pass computes it.

    sample_pos_id: (S, 4) world xyz and the object's tag (``object_tag``; 0: no sample); sample_flux: (S, 4) Phi
    rgb and M_d; x_o: (P, 3) world positions; id_o: (P,) the tag there; n_o: (P, 3) facet normals (w leaves out
    samples off x_o's tangent plane, ``physics.lut.partition_off_plane``); to_eye: (P, 3) unit directions to the
    eye (the light across a thin part leaves by ``through_exit_law``). Light samples take R_d (1 - t(M r)), their
    tail splats (``tail``, from ``tail_samples``) R_d t(M r) out to TAIL_REACH r_max (``physics.lut.crossover``);
    ``world``: world samples, the whole profile to r_max, split at the world's rho.
    """
    out = np.zeros((len(x_o), 3))
    valid = sample_pos_id[:, 3] > 0.5
    pos, ids, flux = sample_pos_id[valid, :3], np.rint(sample_pos_id[valid, 3]).astype(int), sample_flux[valid]
    leans = [plan_.lean_row(k) for k in range(len(plan_.tables))]  # once, not per pixel
    for p in range(len(x_o)):
        same = ids == int(round(id_o[p]))
        if not same.any() or id_o[p] < 0.5:
            continue
        slot = int(round(id_o[p])) % TAG_SLOTS  # the tag's material slot (common.glsl material_slot)
        table, med = plan_.tables[slot], plan_.media[slot]
        r_mm = np.linalg.norm(pos[same] - x_o[p], axis=1) * med.mm_per_unit
        M = np.clip(flux[same, 3], BLUR_MIN, 1.0)
        rho = plan_.world.rho_mm[slot] if world else table.rho
        h_mm = np.abs((pos[same] - x_o[p]) @ n_o[p]) * med.mm_per_unit
        t = crossover(r_mm * M, table.r_max)
        share = np.ones_like(t) if world else (t if tail else 1.0 - t)
        value = far_lookup(table, r_mm * M, tail) * (M * M * share * partition_off_plane(r_mm, rho, h_mm))[:, None]
        # Light through thin parts: x_i below x_o's tangent plane by h (slab_through).
        depth_mm = ((x_o[p] - pos[same]) @ n_o[p]) * med.mm_per_unit
        slab = slab_constants(med)
        ramp = slab_through.ramp(depth_mm, slab[1])
        value = value * slab_through.factor(depth_mm, *slab) * through_exit_law(med, float(n_o[p] @ to_eye[p]), ramp)
        # The light leaving leans away from x_i (physics.exit_lean), across a thin part too.
        beta = lean_lookup(leans[slot], r_mm, table.r_max)
        value = value * exit_lean.pair_factor(beta, pos[same], x_o[p], n_o[p], to_eye[p])
        out[p] = (value * flux[same, :3]).sum(axis=0)
    return out

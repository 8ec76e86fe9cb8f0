"""QUADGRAPH: the bake's levels laid out as GPU images, node materials, and the CPU twin of a frame (pure).

Every level is one block layout (``bake.quadgraph.TextureLayout``, Sec. 5.1): node n sits at the
texel of its slot; links hold slots (exact floats below 2^24), so a fragment finds its four
neighbours with four ``texelFetch``. Material images (kappa, mu) are rebuilt when the material or
the paint changes; the link weights when the bake or the pose does (``LevelEmbedding.deform``).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.bake_checks import count, indices, shaped
from ...core.bake_store import DamagedBakeError
from ...core.geometry.mesh_measures import vertex_normals
from ...core.physics import diffusion as df
from ...core.physics.lut import BLUR_MIN
from . import deformation as vd
from .graph import TextureLayout, layout_for, link_geometry
from .tetra import face_adjacency, signed_volumes


@dataclasses.dataclass
class LevelTables:
    layout: TextureLayout
    positions_mm: np.ndarray  # (N, 3)
    normals: np.ndarray  # (S, 3) unit, mm space
    facets: np.ndarray  # (S, 3) unit normals of the nodes' surface triangles, mm space (bake.quadgraph.QuadGraph)
    neighbours: np.ndarray  # (N, 4) node ids
    weights: np.ndarray  # (N, 4)
    d_surface: np.ndarray  # (S,)
    links_image: np.ndarray  # (h, w, 4) neighbour slots, -1 unused
    weights_image: np.ndarray  # (h, w, 4) a_ij; surface texels: (d_sk, 0, 0, 0)
    surface_texels: np.ndarray  # (S, 2) float32 texel of each surface node
    up_index: np.ndarray | None = None  # (N, 8) node ids in the coarser level
    up_weight: np.ndarray | None = None  # (N, 8)
    up_images: tuple | None = None  # (index 0-3, index 4-7, weight 0-3, weight 4-7) images
    sky: np.ndarray | None = None  # (S,) the sky each surface node sees past the object (bake, rest pose)

    @property
    def count(self) -> int:
        return len(self.positions_mm)

    @property
    def n_surface(self) -> int:
        return len(self.d_surface)

    def image(self, per_node: np.ndarray, channels: int = 4) -> np.ndarray:
        """An (h, w, channels) image holding per-node values (N, c) at their texels."""
        w, h = self.layout.size
        per_node = np.asarray(per_node, np.float32).reshape(self.count, -1)
        img = np.zeros((h, w, channels), np.float32)
        t = self.layout.texels(np.arange(self.count))
        img[t[:, 1], t[:, 0], :per_node.shape[1]] = per_node
        return img

    def link_image(self) -> np.ndarray:
        """The weights image: a_ij of inner nodes; a surface node's texel holds (d_sk, 0, 0, 0)."""
        w = self.weights.copy()
        w[:self.n_surface, 0] = self.d_surface
        return self.image(w)

    def from_image(self, image: np.ndarray, channels: int = 3) -> np.ndarray:
        t = self.layout.texels(np.arange(self.count))
        return np.asarray(image)[t[:, 1], t[:, 0], :channels]


def level_tables(arrays: dict, h: int, coarser: LevelTables | None) -> LevelTables:
    p = f"qg{h}_"
    # A stored count or index out of range asked for 16 GiB (n_surface 2^31 - 1) or read past an array, and a
    # zero distance or negative weight divides by zero: refused as damage (``bake_cache`` says so and draws the
    # base colour). ``core/bake_checks``.
    positions = shaped(arrays, p + "positions", (None, 3)).astype(np.float64)
    N = len(positions)
    S = count(np.asarray(arrays.get(p + "n_surface", [None])).reshape(-1)[0], f"level {h} surface node count", 1, N)
    nb = indices(arrays, p + "neighbours", (N, 4), N, none=True).astype(np.int64)
    d = shaped(arrays, p + "d_surface", (S,)).astype(np.float64)
    weights = shaped(arrays, p + "weights", (N, 4)).astype(np.float64)
    if not (d > 0).all() or (weights < 0).any():
        raise DamagedBakeError(f"its level {h} holds a distance that is not positive or a negative weight")
    normals = shaped(arrays, p + "normals", (S, 3)).astype(np.float64)
    if coarser is not None:
        indices(arrays, p + "up_index", (N, 8), coarser.count)
        if (shaped(arrays, p + "up_weight", (N, 8)) < 0).any():
            raise DamagedBakeError(f"its level {h} holds a negative upsampling weight")
    layout = layout_for(S, N)
    slots = np.where(nb >= 0, layout.slots(np.maximum(nb, 0)), -1)
    # A bake from before the facets were stored: its normals stand in (no facet rule).
    facets = shaped(arrays, p + "facets", (S, 3)).astype(np.float64) if p + "facets" in arrays else normals
    t = LevelTables(layout=layout, positions_mm=positions, normals=normals, facets=facets,
                    neighbours=nb, weights=weights, d_surface=d, links_image=None, weights_image=None,
                    surface_texels=layout.texels(np.arange(S)).astype(np.float32))
    t.links_image = t.image(slots)
    t.weights_image = t.link_image()
    # A bake from before the sky was stored sees all of it.
    t.sky = shaped(arrays, p + "sky", (S,)).astype(np.float32) if p + "sky" in arrays else np.ones(S, np.float32)
    if coarser is not None:
        t.up_index = arrays[p + "up_index"].astype(np.int64)
        t.up_weight = arrays[p + "up_weight"].astype(np.float64)
        up_slots = coarser.layout.slots(t.up_index)
        t.up_images = (t.image(up_slots[:, :4]), t.image(up_slots[:, 4:]), t.image(t.up_weight[:, :4]),
                       t.image(t.up_weight[:, 4:]))
    return t


# -- the volume behind the surface: poses and painted maps ----------------------------------------
class LevelEmbedding:
    """Where one level's points lie relative to the mesh (``geometry.volume_deformation``): the
    tetrahedra's boundary points and the surface nodes in their nearest triangle of the rest surface,
    the inner points harmonically behind them, the inner nodes by their barycentrics in their
    tetrahedra. A pose moves the nodes with it (``deform``); painted corner values fill the volume
    (``carry``). Built once per bake, when a pose or paint first needs it."""

    def __init__(self, rest: LevelTables, points, tets, inner_bary, rest_vertices, triangles):

        self.rest = rest
        self.points = np.asarray(points, np.float64)
        self.tets = np.asarray(tets, np.int64)
        bary = np.asarray(inner_bary, np.float64)
        self.inner_bary = bary / bary.sum(axis=1, keepdims=True)  # stored as float32: sum to 1 again (translations)
        self.rest_volumes = signed_volumes(self.points, self.tets)
        self.fixed = fixed = vd.boundary_points(self.tets, face_adjacency(self.tets), len(self.points))
        self.point_embedding = vd.embed(self.points[fixed], rest_vertices, triangles)
        self.node_embedding = e = vd.embed(rest.positions_mm[:rest.n_surface], rest_vertices, triangles)
        self.harmonic = vd.HarmonicInterpolation(self.points, self.tets, fixed)
        self.triangles = np.asarray(triangles, np.int64)
        self.rest_node_frames, _ = vd.point_frames(rest_vertices, self.triangles, e.triangle, e.bary)

    def deform(self, vertices: np.ndarray, label: str = "", normals: np.ndarray | None = None) -> LevelTables:
        """The level's tables with the surface at ``vertices`` (mm, the rest surface's triangles; ``normals``
        its vertex normals, computed here if not given); raises DeformationError when the pose folds the
        volume over (``volume_deformation.check_folds``)."""

        rest = self.rest
        S = rest.n_surface
        normals = vertex_normals(vertices, self.triangles) if normals is None else normals
        u_fixed = vd.place(self.point_embedding, vertices, self.triangles, normals) - self.points[self.fixed]
        points = self.points + self.harmonic(u_fixed)
        positions = np.empty_like(rest.positions_mm)
        e = self.node_embedding
        positions[:S] = vd.place(e, vertices, self.triangles, normals)
        positions[S:] = np.einsum("tk,tkd->td", self.inner_bary, points[self.tets])
        weights, d_surface, volumes = link_geometry(positions, rest.neighbours, S, points, self.tets,
                                                    volume_floor=1e-3 * self.rest_volumes)
        vd.check_folds(self.rest_volumes, volumes, label)
        frames, _ = vd.point_frames(vertices, self.triangles, e.triangle, e.bary, normals)
        moved = dataclasses.replace(rest, positions_mm=positions, weights=weights, d_surface=d_surface,
                                    normals=vd.rotate_with_surface(rest.normals, self.rest_node_frames, frames),
                                    facets=vd.rotate_with_surface(rest.facets, self.rest_node_frames, frames))
        moved.weights_image = moved.link_image()
        return moved

    def carry(self, corner_values: np.ndarray) -> np.ndarray:
        """(N, C) node values from (3T, C) values at the mesh's triangle corners (paint): surface
        points take their closest point's barycentric mix, inner points the harmonic field behind."""
        corners = np.asarray(corner_values, np.float64).reshape(len(self.triangles), 3, -1)

        def on_surface(embedding):
            return np.einsum("nc,ncd->nd", embedding.bary, corners[embedding.triangle])

        at_points = self.harmonic(on_surface(self.point_embedding))
        S = self.rest.n_surface
        out = np.empty((self.rest.count, corners.shape[2]))
        out[:S] = on_surface(self.node_embedding)
        out[S:] = np.einsum("tk,tkd->td", self.inner_bary, at_points[self.tets])
        return out


def node_paint(embedding: LevelEmbedding, paint: np.ndarray, tint: np.ndarray):
    """Painted maps in the volume (Shah Eq. 7.4, carried from the surface): (M_d (N,), q factor (N, 3)).

    M_d, the blur's distance multiplier, scales the coefficients (sigma M_d: every length over M_d);
    the q factor, mask x glow x tint, scales the light entering at each surface node (inner rows unused).
    """
    values = embedding.carry(np.concatenate([paint[:, :3], tint], axis=1))
    M_d = np.clip(values[:, 1], BLUR_MIN, 1.0)
    q_factor = np.clip(values[:, 0:1], 0.0, 1.0) * np.maximum(values[:, 2:3], 0.0) * np.maximum(values[:, 3:6], 0.0)
    return M_d, q_factor


# A bake makes at most 5 levels (the Levels setting); a stored count past this is damage.
MAX_LEVELS = 8


def load(arrays: dict) -> list[LevelTables]:
    """Tables of every level, coarsest first, and the arrays that map them to the mesh, checked."""
    levels: list[LevelTables] = []
    for h in range(count(shaped(arrays, "qg_levels", (1,))[0], "level count", 1, MAX_LEVELS)):
        levels.append(level_tables(arrays, h, levels[-1] if levels else None))
        points = shaped(arrays, f"qg{h}_points", (None, 3))
        inner = levels[-1].count - levels[-1].n_surface  # one tetrahedron holds each inner node
        tets = indices(arrays, f"qg{h}_tets", (inner, 4), len(points))
        shaped(arrays, f"qg{h}_inner_bary", (len(tets), 4))
    # A displayed corner is lit by surface nodes of the finest level, and the rest pose has one per corner.
    corners = len(indices(arrays, "qg_display_index", (None, 4), levels[-1].n_surface))
    shaped(arrays, "qg_display_weight", (corners, 4))
    indices(arrays, "qg_rest_triangles", (corners // 3, 3), len(shaped(arrays, "qg_rest_vertices", (None, 3))))
    if corners % 3:
        raise DamagedBakeError(f"its display has {corners} corners, not three a triangle")
    return levels


# -- node materials (Sec. 3: kappa, mu per node; heterogeneous) ----------------------------------
def vein_field(positions_mm: np.ndarray, spacing_mm: float) -> np.ndarray:
    """A marble vein field in [0, 1] (1 on a vein): |sin| of a plane wave bent by a few octaves of
    smooth trigonometric noise, as in Perlin's marble that Lensch's marble follows. Deterministic."""
    p = np.asarray(positions_mm, np.float64) / max(float(spacing_mm), 1e-6)
    turbulence = np.zeros(len(p))
    rng = np.random.default_rng(7)
    for octave in range(4):
        f = 2.0**octave
        for _ in range(3):
            direction = rng.normal(size=3)
            direction /= np.linalg.norm(direction)
            turbulence += np.sin(f * p @ direction * 2.3 + rng.uniform(0, 2 * np.pi)) / (f * 3.0)
    wave = np.sin(np.pi * (p[:, 0] + 0.6 * p[:, 2] + 1.5 * turbulence))
    return (1.0 - np.abs(wave)) ** 6


@dataclasses.dataclass(frozen=True)
class MediumExtras:
    """QUADGRAPH's own part of an object's medium (``Medium.extras``): procedural marble veins in the volume
    (strength 0..1, spacing in mm) and whether the surface term (single and local multiple scattering) is drawn."""

    veins: float = 0.0
    veins_spacing_mm: float = 20.0
    single_scattering: bool = True


def extras_of(medium) -> MediumExtras:
    """A medium's QUADGRAPH part (the defaults for a medium made without one)."""
    return medium.extras if isinstance(medium.extras, MediumExtras) else MediumExtras()


def node_material(positions_mm, sigma_a, sigma_s_prime, veins: float = 0.0, veins_spacing_mm: float = 20.0,
                  M_d: np.ndarray | None = None):
    """(kappa, mu) per node, (N, 3) each. Veins raise absorption (x8) and scattering (x2) along the
    vein field, so that they show as darker, sharper streaks under the surface. A painted blur M_d
    (N,) scales both coefficients: the profile spreads 1 / M_d further at the same albedo."""
    sa = np.broadcast_to(np.asarray(sigma_a, np.float64), (len(positions_mm), 3)).copy()
    ss = np.broadcast_to(np.asarray(sigma_s_prime, np.float64), (len(positions_mm), 3)).copy()
    if veins > 0:
        v = float(veins) * vein_field(positions_mm, veins_spacing_mm)[:, None]
        sa *= 1.0 + 7.0 * v
        ss *= 1.0 + 1.0 * v
    if M_d is not None:
        sa *= np.asarray(M_d, np.float64)[:, None]
        ss *= np.asarray(M_d, np.float64)[:, None]
    return df.kappa(sa, ss), sa


# -- the CPU twin of a frame ---------------------------------------------------------------------
@dataclasses.dataclass
class Solution:
    phi: list  # per level (N, 3)
    iterations: list  # per level
    B_surface: np.ndarray  # (S, 3) radiosity at the finest surface nodes


def solve_frame(levels: list[LevelTables], q_levels: list, materials: list, eta: float, tolerance: float,
                max_iterations: int, check_every: int = 16, multiresolution: bool = True,
                start: np.ndarray | None = None) -> Solution:
    """Relaxation coarse to fine (Wang Fig. 9) with the convergence test of the GPU path: every
    ``check_every`` iterations, the relative change of the last iteration."""
    phis, its = [], []
    phi_prev = None
    for h, t in enumerate(levels):
        if not multiresolution and h < len(levels) - 1:
            continue
        kappa, mu = materials[h]
        if h == len(levels) - 1 and start is not None:
            phi = np.array(start, np.float64)
        elif phi_prev is not None and multiresolution:
            phi = df.upsample(phi_prev, t.up_index, t.up_weight)
        else:
            phi = np.zeros((t.count, 3))
        n = 0
        args = (t.neighbours, t.weights, t.d_surface, kappa, mu, q_levels[h], eta)
        while n < max_iterations:
            step = min(check_every, max_iterations - n)
            before = df.relax(*args, phi, step - 1)
            phi = df.relax(*args, before, 1)
            n += step
            if df.relative_change(phi, before) < tolerance:
                break
        phis.append(phi)
        its.append(n)
        phi_prev = phi
    t = levels[-1]
    return Solution(phis, its, df.radiosity(phis[-1][:t.n_surface], eta))

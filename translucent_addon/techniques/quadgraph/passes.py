"""QUADGRAPH: the diffusion equation solved on the GPU every frame (Wang et al. 2010, Blender-facing).

Per frame, for each mesh with an up-to-date bake (Wang Fig. 9):
1. q(n_s) at the surface nodes of every level: one point per surface node at its texel, lit at its
   surface point with Fresnel and shadows, the world first and then each emitter inside the
   pipeline's emitter loop (the ``ts_illumination`` pass of TEXTURE_SPACE, pointed at the level);
2. coarse to fine: start each level from the coarser solution (``qg_upsample``, Eq. 10), the
   coarsest from zero (or the finest from the last frame when nothing but the lights moved is not
   assumed: lights do move), then Jacobi steps (``qg_relax``, Eq. 8-9) into two textures in turn;
   every ``CHECK_EVERY`` steps the last step's relative change is read back and the level stops
   below the scene's tolerance or at its iteration cap (Sec. 5.2);
3. the surface's own response to the light entering it, which diffusion draws with the wrong angular
   law and without single scattering (Wang Sec. 7; ``core/physics/single_scattering.py``): the nearest
   QUADGRAPH surface's depth into a screen target in the world pass, then per emitter the refracted
   view ray marched through the emitter's distance map (single scattering L^(1)) plus Chandrasekhar's
   multiple scattering of a lit half-space at the pixel (L^(ms)), added into it (``qg_single``). The
   diffusion's exitance where light enters stood for that response: the finest level's surface nodes
   sum R q per emitter, R the diffusion's own flat-face reflectance
   (``single_scattering.exitance_loss``), and the display takes it from B; the world's R q apart; the term
   also writes what the diffusion draws of the light its effective cosine spreads past the terminator
   (a second attachment), which the display takes from B too, at most all of it;
4. display: the original mesh interpolates B = (1 - F_dr) phi_s / (2 (1 + F_dr)) from four surface
   nodes per vertex, less the losses above, and draws L = F_t / pi (B + w(mu_o) R q_world) + L^(1) +
   L^(ms) + F_r L_world over the base pass (``qg_display``): w is a half-space's law under uniform light
   (``single_scattering.uniform_light_table``), 1 where the surface term is off (Wang's display).
kappa and mu are set per node from the current material and veins (``quadgraph_data``), so material
edits need no bake. A deformed mesh (armature, lattice, shape keys) moves the nodes first
(``Resources.follow``), and the solve above runs on the moved graph. Painted maps (Shah ch. 7) are
carried into the volume (``Resources.set_paint``): the blur scales kappa and mu per node, mask x glow x
tint scales q at the surface nodes, and the mask blends the display over the base pass's Lambert. The
maths is in ``core/physics/diffusion.py``; the CPU twin in ``quadgraph_data``.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from ...core.frame import Lost
from ...core.geometry.mesh_measures import vertex_normals
from ...core.physics import boundary_gain as bg
from ...core.physics import diffusion as df
from ...core.physics import single_scattering as ss
from ...core.physics import terminator
from ...core.physics.dipole import A as internal_reflection
from ...core.physics.fresnel import F_dr as diffuse_fresnel
from ...core.properties import Prop
from ...gpu import bake_cache, shaders
from ...gpu.bake_cache import Active
from ...gpu.draw_state import draw_pass
from ...gpu.frame_context import FrameContext
from ...gpu.illumination import MediumTables, draw_illumination, unit_texture
from ...gpu.targets import clear_target, new_target, read_pixels, screen_quad, texture_from_array
from ..protocol import Technique, Variant
from . import bake as quadgraph_bake
from . import model as qgd
from . import quality as quadgraph_quality
from .deformation import DeformationError
from .tetra import TetrahedraError

# The GLSL interface of this technique's passes (one file each in gpu_shaders/), joined to the
# shader table by the registry.
SHADER_SPECS = {
    "qg_relax": shaders.ShaderSpec(
        source="quadgraph/relaxation.glsl",
        libraries=("quadgraph/block_layout.glsl",),
        vertex_in=(("VEC2", "corner"),),
        samplers=((0, "FLOAT_2D", "phi"), (1, "FLOAT_2D", "incident"), (2, "FLOAT_2D", "links_map"),
                  (3, "FLOAT_2D", "weights_map"), (4, "FLOAT_2D", "node_kappa"), (5, "FLOAT_2D", "node_mu"),
                  (6, "FLOAT_2D", "q_factor")),
        push_constants=(("INT", "blocks_per_row"), ("INT", "n_surface"), ("INT", "inner_start"),
                        ("INT", "inner_end"), ("FLOAT", "A")),
        fragment_out=((0, "VEC4", "out_phi"),),
    ),
    "qg_upsample": shaders.ShaderSpec(
        source="quadgraph/upsample.glsl",
        libraries=("quadgraph/block_layout.glsl",),
        vertex_in=(("VEC2", "corner"),),
        samplers=((0, "FLOAT_2D", "coarse_phi"), (1, "FLOAT_2D", "up_index0"), (2, "FLOAT_2D", "up_index1"),
                  (3, "FLOAT_2D", "up_weight0"), (4, "FLOAT_2D", "up_weight1")),
        push_constants=(("INT", "coarse_blocks_per_row"),),
        fragment_out=((0, "VEC4", "out_phi"),),
    ),
    "qg_display": shaders.ShaderSpec(
        source="quadgraph/display.glsl",
        libraries=("common/common.glsl", "quadgraph/block_layout.glsl"),
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC4", "links"), ("VEC4", "link_weights"), ("FLOAT", "mask")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_radiosity"),
                  ("smooth", "VEC3", "v_world_local"), ("smooth", "FLOAT", "v_mask"), ("smooth", "VEC3", "v_factor"),
                  ("smooth", "VEC3", "v_gain")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object")),
        samplers=((0, "FLOAT_2D", "phi"), (1, "FLOAT_2D", "q_factor"), (2, "FLOAT_2D", "single"),
                  (3, "FLOAT_2D", "loss"), (4, "FLOAT_2D", "loss_world"), (5, "FLOAT_2D", "world_law"),
                  (6, "FLOAT_2D", "loss_scale"), (7, "FLOAT_2D", "spread_target")),
        push_constants=(("INT", "blocks_per_row"), ("FLOAT", "eta"), ("FLOAT", "F_dr"), ("INT", "display_output")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "qg_single": shaders.ShaderSpec(
        source="quadgraph/surface_term.glsl",
        libraries=shaders.SHADOW_LIBS,
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "corner")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_corner")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "depths"), (2, "FLOAT_2D", "h_table"),
                  (3, "FLOAT_2D", "terminator_table")),
        push_constants=(("INT", "mode"), ("FLOAT", "eta"), ("FLOAT", "g"), ("VEC4", "sigma_a"), ("VEC4", "sigma_s"),
                        ("VEC4", "terminator_rho"), ("INT", "segments"), ("FLOAT", "tau_max"), ("INT", "terms"),
                        ("VEC4", "boundary_gain"), ("VEC4", "R_loss")),
        fragment_out=((0, "VEC4", "out_color"), (1, "VEC4", "out_spread")),
    ),
}

CHECK_EVERY = 16


class LevelGpu:
    """Textures and targets of one level."""

    def __init__(self, t: qgd.LevelTables, stretch_inv: np.ndarray, mm: float):
        self.stretch_inv, self.mm = stretch_inv, mm
        size = t.layout.size
        self.links = texture_from_array(t.links_image)
        self.up = tuple(texture_from_array(img) for img in t.up_images) if t.up_images else None
        self.set_geometry(t)
        self.phi = [new_target(size), new_target(size)]  # one instance's relaxation at a time: shared
        self.kappa = self.mu = self.q_factor = None  # set by Resources.set_material and set_paint

    def set_q_factor(self, q_factor: np.ndarray) -> None:
        """The painted factor (mask x glow x tint) on the light entering at each surface node."""
        self.q_factor = texture_from_array(self.tables.image(q_factor))

    def set_geometry(self, t: qgd.LevelTables) -> None:
        """The link weights and the surface nodes' points for the illumination pass (rest or deformed)."""
        from gpu_extras.batch import batch_for_shader

        self.tables = t
        self.weights = texture_from_array(t.weights_image)
        S = t.n_surface
        pos = (t.positions_mm[:S] @ self.stretch_inv.T / self.mm).astype(np.float32)
        nor, facet = (self._object_normals(n) for n in (t.normals, t.facets))
        flat = np.zeros((S, 3), np.float32)  # no shape operator: QUADGRAPH's light enters where it lands
        self.points = batch_for_shader(shaders.get("ts_illumination"), "POINTS", {
            "texel": t.surface_texels, "pos": pos, "nor": nor, "facet": facet, "sky": t.sky, "curv_d": flat,
            "curv_o": flat})

    def _object_normals(self, normals_mm: np.ndarray) -> np.ndarray:
        """Unit normals in object space from mm space: normals transform with S (S symmetric)."""
        n = normals_mm @ np.linalg.inv(self.stretch_inv)
        return (n / np.linalg.norm(n, axis=1, keepdims=True)).astype(np.float32)

    def set_material(self, kappa: np.ndarray, mu: np.ndarray) -> None:
        self.kappa = texture_from_array(self.tables.image(kappa))
        self.mu = texture_from_array(self.tables.image(mu))


class Lit:
    """One instance's light: q(n_s) at every level's nodes, and what the surface term takes over at the finest
    level's surface nodes (its sum over emitters, and the world's R q_world)."""

    def __init__(self, sizes: list):
        self.incident = [new_target(size) for size in sizes]
        self.loss = new_target(sizes[-1])
        self.loss_world = new_target(sizes[-1])


class Resources:
    """GPU data of one bake: its levels, the material images and the display batch."""

    def __init__(self, arrays: dict, mm: float):
        self.rest_levels = self.levels_cpu = qgd.load(arrays)
        self.stretch = np.asarray(arrays["stretch"], np.float64).reshape(3, 3)
        self.mm = mm
        self.levels = [LevelGpu(t, np.linalg.inv(self.stretch), mm) for t in self.levels_cpu]
        self.rest_vertices = np.asarray(arrays["qg_rest_vertices"], np.float64)
        self.rest_triangles = np.asarray(arrays["qg_rest_triangles"], np.int64)
        self.tetrahedra = [(arrays[f"qg{h}_points"], arrays[f"qg{h}_tets"], arrays[f"qg{h}_inner_bary"])
                           for h in range(len(self.levels))]
        self._embeddings = None
        self.pose = None  # the surface vertices [mm] the nodes were last placed for
        self.followed = None  # the mesh key (its corner arrays) the nodes were last placed for
        self.paint = None  # the painted corner values (paint, tint) the nodes were last set for
        self.M_d = [None] * len(self.levels)  # painted blur per node, None where unpainted
        self.q_factors = [np.ones((t.count, 3)) for t in self.rest_levels]
        self.display_index = arrays["qg_display_index"]
        self.display_weight = arrays["qg_display_weight"]
        self.material_key = None
        self.materials = None
        self.display = {}
        self.surface = {}
        self._loss_scale = None  # (material key, finest tables, texture): Resources.loss_scale
        self.medium_tables = MediumTables()  # the tables below
        self._lit: list[Lit] = []  # what each instance drawing this bake in a frame gathers of its light (``lit``)
        self.iterations: list[int] = []

    def lit(self, slot: int) -> Lit:
        """The light targets of the ``slot``-th instance drawing this bake: they add the world's and every
        emitter's light before the solve reads them, so each instance keeps its own (made on first use)."""
        while len(self._lit) <= slot:
            self._lit.append(Lit([lg.tables.layout.size for lg in self.levels]))
        return self._lit[slot]

    @property
    def embeddings(self) -> list[qgd.LevelEmbedding]:
        """Where each level's nodes lie relative to the mesh (for poses and paint): built on first use."""
        if self._embeddings is None:
            self._embeddings = [qgd.LevelEmbedding(t, *tet, self.rest_vertices, self.rest_triangles)
                                for t, tet in zip(self.rest_levels, self.tetrahedra)]
        return self._embeddings

    def set_paint(self, mesh) -> None:
        """Painted maps (Shah ch. 7: mask, blur, glow, tint) carried into every level's volume; unpainted
        meshes skip the work."""
        paint = (mesh.paint, mesh.tint)
        if self.paint is not None and all(np.array_equal(a, b) for a, b in zip(paint, self.paint)):
            return
        neutral = bool((mesh.paint[:, :3] == 1.0).all() and (mesh.tint == 1.0).all())
        for h, (lg, rest) in enumerate(zip(self.levels, self.rest_levels)):
            if neutral:
                self.M_d[h], self.q_factors[h] = None, np.ones((rest.count, 3))
            else:
                self.M_d[h], self.q_factors[h] = qgd.node_paint(self.embeddings[h], mesh.paint, mesh.tint)
            lg.set_q_factor(self.q_factors[h])
        self.paint = tuple(np.array(a) for a in paint)
        self.material_key = None  # the blur changes kappa and mu ...
        self._loss_scale = None  # ... and the held-source gain made of them (set_material keeps its key)

    def loss_scale(self):
        """The finest level's surface nodes' held_source_gain as a texture (1 at inner nodes), which
        qg_display applies to the losses: built again when the material or the pose changes."""
        finest = self.levels_cpu[-1]
        cached = self._loss_scale
        if cached is None or cached[0] != self.material_key or cached[1] is not finest:
            kappa, mu = self.materials[-1]
            gain = np.ones((finest.count, 3))
            gain[:finest.n_surface] = df.held_source_gain(kappa, mu, finest.d_surface)
            cached = self._loss_scale = (self.material_key, finest,
                                         texture_from_array(self.levels[-1].tables.image(gain)))
        return cached[2]

    def set_material(self, medium) -> None:
        extras = qgd.extras_of(medium)
        key = (tuple(medium.sigma_a), tuple(medium.sigma_s_prime), extras.veins, extras.veins_spacing_mm)
        if key == self.material_key:
            return
        self.materials = []
        for lg, rest, M_d in zip(self.levels, self.rest_levels, self.M_d):
            # Veins are set at the rest pose's positions, so they stay in the material as it deforms.
            kappa, mu = qgd.node_material(rest.positions_mm, medium.sigma_a, medium.sigma_s_prime,
                                          extras.veins, extras.veins_spacing_mm, M_d)
            lg.set_material(kappa, mu)
            self.materials.append((kappa, mu))
        self.material_key = key

    def follow(self, mesh, label: str = "") -> None:
        """Move the nodes to the mesh's current pose (armature, lattice, shape keys): Wang Sec. 6's
        deformable objects; raises DeformationError when the pose folds the volume over (more than
        ``volume_deformation.FOLD_LIMIT`` of it in tetrahedra turned inside out)."""
        if self.pose is not None and self.followed == mesh.key:
            return  # the same corner arrays as last frame (a mesh key names its content)
        self.followed = mesh.key
        vertices = self.rest_vertices.copy()  # loose vertices (in no triangle) keep their rest place
        vertices[self.rest_triangles.reshape(-1)] = np.asarray(mesh.positions, np.float64) @ self.stretch.T * self.mm
        if self.pose is not None and np.array_equal(vertices, self.pose):
            return
        extent = float(np.ptp(self.rest_vertices, axis=0).max())
        if np.abs(vertices - self.rest_vertices).max() <= 1e-5 * extent:
            tables = self.rest_levels
        else:
            normals = vertex_normals(vertices, self.rest_triangles)  # one mesh for every level
            tables = [e.deform(vertices, label, normals) for e in self.embeddings]
        if tables is not self.levels_cpu:  # the rest tables are on the GPU from the start
            for lg, t in zip(self.levels, tables):
                lg.set_geometry(t)
            self.levels_cpu = tables
        self.pose = vertices

    def display_batch(self, mesh):
        batch = self.display.get(mesh.key)
        if batch is None:
            from gpu_extras.batch import batch_for_shader

            self.display.clear()
            finest = self.levels_cpu[-1]
            slots = finest.layout.slots(self.display_index).astype(np.float32)
            batch = self.display[mesh.key] = batch_for_shader(shaders.get("qg_display"), "TRIS", {
                "pos": np.ascontiguousarray(mesh.positions, np.float32),
                "nor": np.ascontiguousarray(mesh.normals, np.float32),
                "links": slots, "link_weights": np.ascontiguousarray(self.display_weight, np.float32),
                "mask": np.ascontiguousarray(np.clip(mesh.paint[:, 0], 0.0, 1.0), np.float32)})
        return batch

    def surface_batch(self, mesh):
        """The mesh's triangles for ``qg_single``: positions, smooth normals and each corner's barycentric
        (1, 0, 0), (0, 1, 0), (0, 0, 1), from which the pass has a point's distances to its triangle's
        edges (the triangle's share in the medium's normal at the kernel's scale)."""
        batch = self.surface.get(mesh.key)
        if batch is None:
            from gpu_extras.batch import batch_for_shader

            self.surface.clear()
            corner = np.tile(np.eye(3, dtype=np.float32), (len(mesh.positions) // 3, 1))
            batch = self.surface[mesh.key] = batch_for_shader(shaders.get("qg_single"), "TRIS", {
                "pos": np.ascontiguousarray(mesh.positions, np.float32),
                "nor": np.ascontiguousarray(mesh.normals, np.float32), "corner": corner})
        return batch

    def exitance_loss(self, medium):
        """What a lit node's exitance gives up per unit q to the surface term, R, as a one-texel table
        for ``ts_illumination``'s cosine table (``single_scattering.exitance_loss``), rebuilt when the
        medium changes."""
        return self.medium_tables.get("loss", medium, ss.exitance_loss)

    def exitance_reflectance(self, medium):
        """R per channel, (3,): the same loss as numbers, for what ``qg_single`` writes of the
        terminator's spread as the graph draws it."""
        return self.medium_tables.get("loss_R", medium, ss.exitance_loss, texture=False)[0]

    def chandrasekhar_h(self, medium):
        """H(mu) of the medium's albedo per channel (``single_scattering.h_table``), rebuilt when it changes."""
        return self.medium_tables.get("H", medium,
                                      lambda sigma_a, sigma_s_prime, eta: ss.h_table(sigma_a, sigma_s_prime))

    def boundary_gain(self, medium):
        """C per channel on the local multiple scattering at eta != 1 (``physics.boundary_gain``), (3,),
        computed again when the medium changes."""
        return self.medium_tables.get("gain", medium, lambda sigma_a, sigma_s_prime, eta: bg.boundary_gain(
            sigma_a, sigma_s_prime, medium.g, eta), texture=False)[0]

    def terminator(self, medium):
        """The clamped ramp's excess G per channel as a texture and the kernel's mean radius rho in mm
        (``physics.terminator``), rebuilt when the medium changes."""
        rho = self.medium_tables.get("rho", medium, terminator.kernel_mean_radii, texture=False)
        return self.medium_tables.get("terminator", medium, terminator.excess_table), rho

    def world_law(self, medium):
        """The angular law of the world's light entering a flat face over Lambert's per channel
        (``single_scattering.uniform_light_table``), rebuilt when the medium changes."""
        return self.medium_tables.get("world", medium, ss.uniform_light_table)


def prepare(frame) -> list[Active]:
    """The QUADGRAPH meshes of a frame whose bake is loaded (on first use) and current, with the
    current material's kappa and mu."""
    # The nodes follow a mesh's pose, paint and medium: instances agreeing in those (one mesh key, one medium)
    # share an entry, others take one each.
    active = bake_cache.prepare(frame, "QUADGRAPH",
                                lambda arrays, mesh: Resources(arrays, mesh.medium.mm_per_unit),
                                lambda res, mesh: len(res.display_index) == len(mesh.positions),
                                variant=lambda mesh: (mesh.key, mesh.medium), in_view=True)
    last = {id(a.resources): a for a in active}  # the highest slot of each entry (slots count up)
    for a in last.values():  # instances no longer drawn give their light targets back
        del a.resources._lit[a.slot + 1:]
    followed = []
    for a in active:
        try:
            a.resources.follow(a.mesh, f"'{a.mesh.name}': ")
        except DeformationError as err:
            frame.warnings.append(Lost(f"{err} (QUADGRAPH; drawn with its base colour)"))
            continue
        a.resources.set_paint(a.mesh)
        a.resources.set_material(a.mesh.medium)
        followed.append(a)
    return followed


def illuminate(actives: list[Active], objects, frame_ubo, light_ubo, shadow_atlas, mode: int, pipeline,
               size, output: int = 0) -> None:
    """Add one emitter's (mode 1) or the world's (mode 0, clears first) q(n_s) at every level (Eq. 3),
    and the emitter's single scattering into the screen target (mode 0: its depth, zero colour)."""

    for a in actives:
        m, res = a.mesh.medium, a.resources
        lit = res.lit(a.slot)
        surface_term = qgd.extras_of(m).single_scattering
        for lg, incident in zip(res.levels, lit.incident):
            draw_illumination(incident[0], lg.points, lg.tables.layout.size, objects[a.index], frame_ubo,
                              light_ubo, shadow_atlas, mode, m.eta, unit_texture(pipeline))
        # The exitance the surface term takes over at the finest level's surface nodes.
        finest = res.levels[-1]
        if mode == 0:
            with lit.loss[0].bind():
                clear_target(lit.loss[0], depth=None)
            if surface_term:  # the world's flat-face response R q_world, drawn with its own law
                draw_illumination(lit.loss_world[0], finest.points, finest.tables.layout.size, objects[a.index],
                                  frame_ubo, light_ubo, shadow_atlas, mode, m.eta, res.exitance_loss(m))
            else:
                with lit.loss_world[0].bind():
                    clear_target(lit.loss_world[0], depth=None)
        elif surface_term:
            draw_illumination(lit.loss[0], finest.points, finest.tables.layout.size, objects[a.index], frame_ubo,
                              light_ubo, shadow_atlas, mode, m.eta, res.exitance_loss(m))
    draw_single(actives, objects, frame_ubo, light_ubo, shadow_atlas, mode, pipeline, size, output)


def single_target(pipeline, size, name: str = "qg_single"):
    """A screen target of the single-scattering pass (RGBA32F and its own depth), reused across frames
    and rebuilt when the image size changes: "qg_single" sums L^(1) (alpha: the eye's distance to the
    surface), "qg_exit" holds where the view ray leaves the medium."""
    size = tuple(size)
    found = pipeline.targets.get(name)
    if found is None or found[0] != size:
        found = pipeline.targets[name] = (size, new_target(size, depth=True, attachments=2))
    return found[1]


def draw_single(actives, objects, frame_ubo, light_ubo, shadow_atlas, mode: int, pipeline, size,
                output: int = 0) -> None:
    """mode 0: clear the targets, lay down the nearest QUADGRAPH surface (depth, eye distance), then the
    next surface behind it (the view ray's exit, mode 2); mode 1: add one emitter's surface term on the
    nearest surface, single scattering L^(1) and local multiple scattering L^(ms) (objects with the term
    switched off add none; the pipeline's QUADGRAPH output 2 or 3 keeps one of the two)."""

    single, exit_ = single_target(pipeline, size), single_target(pipeline, size, "qg_exit")
    # (target drawn into, pass mode, target read as ``depths``)
    passes = ((single, 0, exit_), (exit_, 2, single)) if mode == 0 else ((single, 1, exit_),)
    for target, pass_mode, source in passes:
        fb, depths = target[0], source[1][0]
        with draw_pass(fb, blend="ADDITIVE_PREMULT" if pass_mode == 1 else "NONE", depth_test="LESS_EQUAL",
                       depth_write=pass_mode != 1):
            if pass_mode != 1:
                clear_target(fb, (3.0e38,) * 4 if pass_mode == 2 else (0.0,) * 4)
            shader = shaders.bind_lit("qg_single", frame_ubo, light_ubo, shadow_atlas, pass_mode)
            shader.uniform_sampler("depths", depths)
            shader.uniform_int("segments", ss.SEGMENTS)
            shader.uniform_float("tau_max", ss.TAU_MAX)
            shader.uniform_int("terms", {2: 1, 3: 2}.get(int(output), 3))
            for a in actives:
                m = a.mesh.medium
                if pass_mode == 1 and not qgd.extras_of(m).single_scattering:
                    continue
                sigma_s, sigma_t = ss.coefficients(m.sigma_a, m.sigma_s_prime, m.g)
                shader.uniform_block("object", objects[a.index])
                shader.uniform_float("eta", float(m.eta))
                shader.uniform_float("g", float(m.g))
                shader.uniform_float("sigma_a", (*map(float, (sigma_t - sigma_s) * m.mm_per_unit), 0.0))
                shader.uniform_float("sigma_s", (*map(float, sigma_s * m.mm_per_unit), 0.0))
                shader.uniform_sampler("h_table", a.resources.chandrasekhar_h(m))
                shader.uniform_float("boundary_gain", (*map(float, a.resources.boundary_gain(m)), 0.0))
                shader.uniform_float("R_loss", (*map(float, a.resources.exitance_reflectance(m)), 0.0))
                table, rho_mm = a.resources.terminator(m)
                shader.uniform_sampler("terminator_table", table)
                shader.uniform_float("terminator_rho", (*map(float, rho_mm / m.mm_per_unit), 0.0))
                shader.draw(a.resources.surface_batch(a.mesh))


def _relative_change(fb_new, fb_old, size) -> float:
    """The convergence test of ``physics.diffusion.relative_change`` on two read-back phi targets."""

    with fb_new.bind():
        new = read_pixels(fb_new, *size, channels=3)
    with fb_old.bind():
        old = read_pixels(fb_old, *size, channels=3)
    return df.relative_change(new, old)


def _relax_uniforms(shader, lg, incident, t, A: float) -> None:
    """What every relaxation step of a level reads besides phi (Wang Eq. 8): set once per level."""
    shader.uniform_sampler("incident", incident[1][0])
    shader.uniform_sampler("links_map", lg.links)
    shader.uniform_sampler("weights_map", lg.weights)
    shader.uniform_sampler("node_kappa", lg.kappa)
    shader.uniform_sampler("node_mu", lg.mu)
    shader.uniform_sampler("q_factor", lg.q_factor)
    shader.uniform_int("blocks_per_row", t.layout.blocks_per_row)
    shader.uniform_int("n_surface", t.n_surface)
    shader.uniform_int("inner_start", t.layout.inner_start)
    shader.uniform_int("inner_end", t.layout.inner_start + t.count - t.n_surface)
    shader.uniform_float("A", A)


def solve(a: Active, pipeline, tolerance: float, max_iterations: int, multiresolution: bool = True):
    """Relax every level coarse to fine; returns the finest level's current phi target index."""

    res = a.resources
    tolerance = df.reachable_tolerance(tolerance)
    eta = float(a.mesh.medium.eta)
    A = float(internal_reflection(eta))
    res.iterations = []
    previous = None  # (LevelGpu, index of its current phi target)
    lit = res.lit(a.slot).incident
    levels = list(zip(res.levels, lit)) if multiresolution else [(res.levels[-1], lit[-1])]
    for lg, incident in levels:
        t = lg.tables
        size = t.layout.size
        cur = 0
        fb = lg.phi[cur][0]
        with draw_pass(fb):
            if previous is None or lg.up is None:
                clear_target(fb, depth=None)
            else:
                shader = shaders.pass_shader("qg_upsample")
                shader.bind()
                shader.uniform_sampler("coarse_phi", previous[0].phi[previous[1]][1][0])
                for name, tex in zip(("up_index0", "up_index1", "up_weight0", "up_weight1"), lg.up):
                    shader.uniform_sampler(name, tex)
                shader.uniform_int("coarse_blocks_per_row", previous[0].tables.layout.blocks_per_row)
                shader.draw(screen_quad(pipeline, "qg_upsample"))
        shader = shaders.pass_shader("qg_relax")
        quad = screen_quad(pipeline, "qg_relax")
        # Bound once a level: its tables, the state and the shader stay (each draw binds the shader again;
        # nothing between two steps binds another), so a step sets phi and draws.
        with draw_pass():
            shader.bind()
            _relax_uniforms(shader, lg, incident, t, A)
            n = 0
            while n < max_iterations:
                step = min(CHECK_EVERY, max_iterations - n)
                for _ in range(step):
                    src, dst = lg.phi[cur], lg.phi[1 - cur]
                    with dst[0].bind():
                        shader.uniform_sampler("phi", src[1][0])
                        shader.draw(quad)
                    cur = 1 - cur
                n += step
                if _relative_change(lg.phi[cur][0], lg.phi[1 - cur][0], size) < tolerance:
                    break
        res.iterations.append(n)
        previous = (lg, cur)
    return previous[1]


def finish(actives: list[Active], frame, frame_ubo, objects, target_fb, pipeline, tolerance: float,
           max_iterations: int, output: int = 0) -> dict:
    """Solve and display; returns seconds per step (summed over meshes)."""

    timings = {"qg_solve": 0.0, "qg_display": 0.0}
    for a in actives:
        t0 = time.perf_counter()
        cur = solve(a, pipeline, tolerance, max_iterations)
        finest = a.resources.levels[-1]
        if pipeline.capture is not None:
            size = finest.tables.layout.size
            # "q": the light entering each level's nodes before the painted factor (resources.q_factors).
            record = {"name": a.mesh.name, "iterations": list(a.resources.iterations), "q": [],
                      "resources": a.resources}
            for lg, incident in zip(a.resources.levels, a.resources.lit(a.slot).incident):
                with incident[0].bind():
                    record["q"].append(lg.tables.from_image(read_pixels(incident[0], *lg.tables.layout.size)))
            with finest.phi[cur][0].bind():
                record["phi"] = finest.tables.from_image(read_pixels(finest.phi[cur][0], *size))
            # "spread": what B gives up of the terminator's spread per pixel (qg_single's second attachment).
            width, height = frame.camera.width, frame.camera.height
            term_fb = single_target(pipeline, (width, height))[0]
            with term_fb.bind():
                record["spread"] = read_pixels(term_fb, width, height, slot=1)[..., :3]
            pipeline.capture.setdefault("quadgraph", []).append(record)
        t1 = time.perf_counter()
        eta = float(a.mesh.medium.eta)
        # ALPHA: the painted mask; the base pass's Lambert shows where it is 0
        with draw_pass(target_fb, blend="ALPHA", depth_test="LESS_EQUAL"):
            shader = shaders.pass_shader("qg_display")
            shader.bind()
            shader.uniform_block("frame", frame_ubo)
            shader.uniform_block("object", objects[a.index])
            shader.uniform_sampler("phi", finest.phi[cur][1][0])
            shader.uniform_sampler("q_factor", finest.q_factor)
            lit = a.resources.lit(a.slot)
            shader.uniform_sampler("loss", lit.loss[1][0])
            shader.uniform_sampler("loss_world", lit.loss_world[1][0])
            shader.uniform_sampler("loss_scale", a.resources.loss_scale())
            term = qgd.extras_of(a.mesh.medium).single_scattering
            shader.uniform_sampler("world_law",
                                   a.resources.world_law(a.mesh.medium) if term else unit_texture(pipeline))
            surface_term = single_target(pipeline, (frame.camera.width, frame.camera.height))[1]
            shader.uniform_sampler("single", surface_term[0])
            shader.uniform_sampler("spread_target", surface_term[1])
            shader.uniform_int("blocks_per_row", finest.tables.layout.blocks_per_row)
            shader.uniform_float("eta", eta)
            shader.uniform_float("F_dr", float(diffuse_fresnel(eta)))
            shader.uniform_int("display_output", int(output))
            shader.draw(a.resources.display_batch(a.mesh))
        t2 = time.perf_counter()
        timings["qg_solve"] += t1 - t0
        timings["qg_display"] += t2 - t1
    return timings


@dataclasses.dataclass(frozen=True)
class QuadgraphSettings:
    tolerance: float = 2e-5  # relative change per Jacobi step at which a level stops
    iterations: int = 1000  # cap on the steps per level
    output: int = 0  # 0 colour; 1 diffusion; 2 single; 3 local multiple scattering (tests)


class Quadgraph(Technique):
    """Wang 2010: q(n_s) lit at the surface nodes in the world pass and each emitter's, relaxed coarse to
    fine and displayed over the base."""

    object_props = (
        Prop("quadgraph_K", "FloatProperty", {
            "name": "Density K",
            "description": ("Size of the volume cells light flows through: smaller is more accurate (about 2 % error "
                            "at 0.1, 10 % at 1) and slower. Changing it needs a new bake"),
            "min": 0.05,
            "max": 2.0,
            "default": 1.0,
            "precision": 2,
        }),
        Prop("quadgraph_levels", "IntProperty", {
            "name": "Levels",
            "description": ("Coarser copies of the volume the light solver starts from: more settles the light in "
                            "fewer steps. Changing it needs a new bake"),
            "min": 1,
            "max": 5,
            "default": 3,
        }),
        Prop("veins", "FloatProperty", {
            "name": "Veins",
            "description": ("Strength of procedural marble veins through the volume (darker, denser streaks); 0 is "
                            "uniform"),
            "min": 0.0,
            "max": 1.0,
            "default": 0.0,
        }),
        Prop("single_scattering", "BoolProperty", {
            "name": "Surface term",
            # Light scattered once (marched along the view ray through the light's distance map) and the
            # multiple scattering of a lit half-space (Chandrasekhar): the diffusion alone is Lambertian and
            # leaves out the first order.
            "description": ("Add the surface's own response to each light: the bright rims where a light grazes a "
                            "back-lit object"),
            "default": True,
        }),
        Prop("veins_scale", "FloatProperty", {
            "name": "Vein spacing",
            "description": "Distance between the marble veins",
            "subtype": "DISTANCE",
            "unit": "LENGTH",
            "min": 1e-4,
            "soft_max": 0.2,
            "default": 0.02,
        }),
    )
    scene_props = (
        Prop("quadgraph_tolerance", "FloatProperty", {
            "name": "Solver tolerance",
            # Checked every 16 iterations, relative to the largest flux; the GPU holds the flux in 32-bit floats,
            # so 1e-6 is the smallest change it can resolve.
            "description": ("The light solver stops refining a level once a step changes the light by less than this "
                            "share of its brightest value: smaller is more exact, slower"),
            "min": 1e-06,
            "max": 0.1,
            "default": 2e-05,
            "precision": 6,
        }),
        Prop("quadgraph_iterations", "IntProperty", {
            "name": "Max iterations",
            "description": "Most light solver steps per level: caps the time a frame spends settling the light",
            "min": 8,
            "max": 20000,
            "default": 1000,
        }),
        Prop("quadgraph_output", "IntProperty", {
            "name": "QUADGRAPH output",
            "description": ("QUADGRAPH display output (tests, debugging): 0 colour, 1 the diffusion alone, 2 "
                            "single scattering alone, 3 the local multiple scattering alone"),
            "min": 0,
            "max": 3,
            "default": 0,
            "options": {"HIDDEN"},
        }),
    )
    shader_specs = SHADER_SPECS
    id, label, method_number, timing = "QUADGRAPH", "QuadGraph", 3, "QUADGRAPH"
    description = ("Light flowing through a baked volume of the object: thin parts, veins; materials change without a "
                   "new bake")
    scene_properties = ("quadgraph_tolerance", "quadgraph_iterations", "quadgraph_output")
    bake_stages, bake_errors = ("quadgraph",), (TetrahedraError,)
    bake_properties = ("quadgraph_K", "quadgraph_levels")
    medium_properties = ("veins", "veins_scale", "single_scattering")
    draws_paint = True  # carries the paint into its volume (kappa and mu per node)
    panel = (("quadgraph_K", "quadgraph_levels", "single_scattering"), ("veins", "veins_scale"))
    scene_panel, scene_panel_label = (("quadgraph_tolerance", "quadgraph_iterations"),), "QuadGraph Solver"
    object_tiers = {"DRAFT": {"quadgraph_K": 2.0}, "STANDARD": {"quadgraph_K": 1.0}, "HIGH": {"quadgraph_K": 0.5}}

    def bake(self, inputs, stage: str):
        return quadgraph_bake.bake(inputs)

    def bake_parameters(self, values: dict) -> quadgraph_bake.BakeParameters:
        return quadgraph_bake.BakeParameters.from_values(values)

    def make_proxies(self, inputs, decimate):
        return quadgraph_bake.make_proxies(inputs, decimate)

    def hash_parts(self, inputs, geometry: dict, material: dict) -> tuple[dict, dict]:
        return quadgraph_bake.hash_parts(inputs, geometry, material)

    def bake_summary(self, meta: dict) -> list[str]:
        return quadgraph_bake.summary(meta)

    compare_defaults = ()  # drawn at its own K; the benchmark names a series (2, 1, 0.5)

    def compare_variants(self, values: tuple) -> list[Variant]:
        """One image per density K."""
        return [Variant(f"K={K:g}", {"quadgraph_K": float(K)}, {}, {"quadgraph_K": float(K)}) for K in values]

    def medium_extras(self, values: dict, mm_per_unit: float) -> qgd.MediumExtras:
        return qgd.MediumExtras(veins=float(values["veins"]),
                                veins_spacing_mm=float(values["veins_scale"]) * mm_per_unit,
                                single_scattering=bool(values["single_scattering"]))

    def settings(self, values: dict) -> QuadgraphSettings:
        return QuadgraphSettings(values["quadgraph_tolerance"], values["quadgraph_iterations"],
                                 int(values["quadgraph_output"]))

    def _settings(self, ctx) -> QuadgraphSettings:
        return ctx.frame.settings.of(self.id) or QuadgraphSettings()

    def auto_quality(self, view, target: float, curves: str):
        return quadgraph_quality.auto(view, target, curves)

    def prepare(self, ctx: FrameContext):
        return prepare(ctx.frame) or None

    def world(self, ctx: FrameContext, state, light_ubo) -> None:
        illuminate(state, ctx.objects, ctx.frame_ubo, light_ubo, ctx.shadow_atlas, mode=0, pipeline=ctx.resources,
                   size=ctx.size, output=self._settings(ctx).output)

    def emitter(self, ctx: FrameContext, state, emitter, light_ubo) -> None:
        illuminate(state, ctx.objects, ctx.frame_ubo, light_ubo, ctx.shadow_atlas, mode=1, pipeline=ctx.resources,
                   size=ctx.size, output=self._settings(ctx).output)

    def finish(self, ctx: FrameContext, state) -> dict:
        s = self._settings(ctx)
        return finish(state, ctx.frame, ctx.frame_ubo, ctx.objects, ctx.target, ctx.resources, s.tolerance,
                      s.iterations, output=s.output)


TECHNIQUE = Quadgraph()

"""TEXTURE_SPACE: Lensch 2002 at run time, every step on the GPU (Blender-facing).

Per frame, for each mesh with an up-to-date bake (Lensch Fig. 3):
1. illumination map: one point per atlas texel, lit at its surface point with Fresnel and
   shadows; the world term first, then one additive pass per emitter, inside the pipeline's
   emitter loop so that each reuses that emitter's shadow atlas (``ts_illumination``);
2. vertex gather (Eq. 10) and direct radiosity B^d (Sec. 5.4): three points per surface texel,
   additive into per-vertex textures (``ts_gather``);
3. global response F^0 E^g + G E_P + B^d per vertex, divided by T_p (Eq. 11, 13): the far field's cluster
   power E_P gathered from E^g first (``ts_gather`` over the vertex image, ``far_field.py``), then a fragment
   per vertex walking its row of the sparse matrix (``ts_product``), or scipy.sparse on the CPU
   (``Scene.translucent.texture_product``);
4. local response, the 7x7 filter (Eq. 15), and the interpolated global response (Eq. 12): a
   point per texel (``ts_filter``);
5. display (Eq. 1, 14): the displayed mesh reads both maps through its atlas coordinates
   (``ts_display``), over the base pass.
The maths and layouts are in ``model.py``, the GLSL in ``gpu_shaders/texture_space/``.
"""
from __future__ import annotations

import time

import numpy as np

from ...core.physics import oblique_entry
from ...core.physics.lut import profile_model
from ...core.properties import Prop
from ...gpu import bake_cache, shaders
from ...gpu.bake_cache import Active
from ...gpu.draw_state import draw_pass
from ...gpu.frame_context import FrameContext
from ...gpu.illumination import MediumTables, draw_illumination, unit_texture
from ...gpu.targets import clear_target, new_target, read_pixels, screen_quad, texture_from_array
from ..protocol import Technique, Variant
from . import bake as texture_space_bake
from . import model as tsd
from . import proxy
from . import quality as texture_space_quality
from .throughput import LenschBake, has_through, product_matrices, vertex_product

# The GLSL interface of this technique's passes (one file each in gpu_shaders/), joined to the
# shader table by the registry.
SHADER_SPECS = {
    "ts_gather": shaders.ShaderSpec(
        source="texture_space/vertex_gather.glsl",
        vertex_in=(("VEC2", "texel"), ("FLOAT", "target"), ("FLOAT", "dual"), ("VEC3", "blend")),
        varyings=(("flat", "VEC3", "v_eg"), ("flat", "VEC3", "v_bd")),
        samplers=((0, "FLOAT_2D", "irradiance"),),
        push_constants=(("INT", "vertex_width"), ("VEC2", "vertex_size")),
        fragment_out=((0, "VEC4", "out_eg"), (1, "VEC4", "out_bd")),
    ),
    "ts_product": shaders.ShaderSpec(
        source="texture_space/sparse_product.glsl",
        vertex_in=(("VEC2", "corner"),),
        samplers=((0, "FLOAT_2D", "F_indptr"), (1, "FLOAT_2D", "F_indices"), (2, "FLOAT_2D", "F_data"),
                  (3, "FLOAT_2D", "E_vertex"), (4, "FLOAT_2D", "B_direct"), (5, "FLOAT_2D", "T_p_vertex"),
                  (6, "FLOAT_2D", "E_cluster")),
        push_constants=(("INT", "vertex_width"), ("INT", "vertex_count"), ("INT", "cluster_count"),
                        ("INT", "row_split"), ("VEC3", "z_r")),
        fragment_out=((0, "VEC4", "out_vertex"), (1, "VEC4", "out_through")),
    ),
    "ts_filter": shaders.ShaderSpec(
        source="texture_space/local_filter.glsl",
        vertex_in=(("VEC2", "texel"), ("VEC2", "source"), ("FLOAT", "row"), ("VEC3", "bary"), ("VEC3", "verts")),
        varyings=(("flat", "VEC2", "v_source"), ("flat", "FLOAT", "v_row"), ("flat", "VEC3", "v_bary"),
                  ("flat", "VEC3", "v_verts")),
        samplers=((0, "FLOAT_2D", "irradiance"), (1, "FLOAT_2D", "kernels"), (2, "FLOAT_2D", "B_vertex"),
                  (3, "FLOAT_2D", "B_through")),
        push_constants=(("INT", "vertex_width"), ("INT", "local_half"), ("VEC2", "atlas_size")),
        fragment_out=((0, "VEC4", "out_local"), (1, "VEC4", "out_global"), (2, "VEC4", "out_through")),
    ),
    "ts_display": shaders.ShaderSpec(
        source="texture_space/display.glsl",
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "col"), ("VEC2", "uv")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_color"),
                  ("smooth", "VEC2", "v_uv")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object")),
        samplers=((0, "FLOAT_2D", "local_map"), (1, "FLOAT_2D", "global_map"), (2, "FLOAT_2D", "angular_table"),
                  (3, "FLOAT_2D", "through_map"), (4, "FLOAT_2D", "exit_table")),
        push_constants=(("FLOAT", "eta"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
}


class Resources:
    """Textures, point batches and render targets of one bake."""

    def __init__(self, tables: tsd.GpuTables, arrays: dict):
        from gpu_extras.batch import batch_for_shader

        self.tables = t = tables
        self.arrays = arrays  # for the CPU product and the tests' twin
        self.kernels = texture_from_array(t.kernels, "RGBA16F")
        if t.gpu_product:
            self.F_indptr = texture_from_array(t.F_indptr, "RG32F")
            self.F_indices = texture_from_array(t.F_indices, "R32F")
            self.F_data = texture_from_array(t.F_data, "RGBA32F")
        self.illumination_points = batch_for_shader(shaders.get("ts_illumination"), "POINTS", {
            "texel": t.texel, "pos": t.position, "nor": t.normal, "facet": t.facet,
            "sky": np.ones(len(t.texel), np.float32), "curv_d": t.curvature_d, "curv_o": t.curvature_o})
        self.gather_points = batch_for_shader(shaders.get("ts_gather"), "POINTS", {
            "texel": t.gather_texel, "target": t.gather_target, "dual": t.gather_dual, "blend": t.gather_blend})
        self.filter_points = batch_for_shader(shaders.get("ts_filter"), "POINTS", {
            "texel": t.texel, "source": t.source_texel, "row": t.row, "bary": t.bary, "verts": t.verts})
        self._irradiance = []  # one map per instance drawing this bake in a frame (``irradiance``)
        # What one instance's finish step fills and reads before the next one's: made once, shared by all.
        self.maps = new_target(t.atlas_size, attachments=3)  # local, global, global through thin parts
        self.vertex_in = new_target(t.vertex_size, attachments=2)  # E^g, B^d
        self.vertex_out = new_target(t.vertex_size, attachments=2)  # B / T_p, B^t / T_p
        # The far field's clusters: their power gathered from E^g (``ts_gather`` over the vertex image; its second
        # output, B^d, stays zero there).
        self.cluster_points = self.cluster_in = None
        if t.cluster_points is not None:
            texel, slot, weight = t.cluster_points
            self.cluster_points = batch_for_shader(shaders.get("ts_gather"), "POINTS", {
                "texel": texel, "target": slot, "dual": weight, "blend": np.zeros((len(slot), 3), np.float32)})
            self.cluster_in = new_target(t.cluster_size, attachments=2)
        self.display = {}  # display batch by mesh key
        self.medium_tables = MediumTables()
        self._sparse = None

    def irradiance(self, slot: int):
        """The irradiance map of the ``slot``-th instance drawing this bake: it gathers the world's and every
        emitter's light before the finish step reads it, so each instance keeps its own (made on first use)."""
        while len(self._irradiance) <= slot:
            self._irradiance.append(new_target(self.tables.atlas_size))
        return self._irradiance[slot]

    def display_batch(self, mesh):
        batch = self.display.get(mesh.key)
        if batch is None:
            from gpu_extras.batch import batch_for_shader

            drawn = self.tables.drawn_corners
            batch = self.display[mesh.key] = batch_for_shader(shaders.get("ts_display"), "TRIS", {
                "pos": np.ascontiguousarray(drawn(mesh.positions), np.float32),
                "nor": np.ascontiguousarray(drawn(mesh.normals), np.float32),
                "col": np.ascontiguousarray(drawn(mesh.colors), np.float32),
                "uv": self.tables.display_uv})
        return batch

    def sparse(self):
        """(the bake's tables, ``product_matrices`` of B and of B^t) for the CPU product, built once."""
        if self._sparse is None:
            lensch = LenschBake.from_arrays(self.arrays)
            self._sparse = (lensch, product_matrices(lensch),
                            product_matrices(lensch, through=True) if has_through(lensch) else None)
        return self._sparse

    def cpu_product(self, E_g: np.ndarray, B_d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B^d + F^0 E^g + G E_P, its share through thin parts B^t) at the vertices (V, 3) with SciPy (Lensch
        Eq. 11, the far field and ``throughput.through_share``)."""
        lensch, matrices, through = self.sparse()
        E_P = lensch.cluster_power(E_g) if lensch.has_far_field else None
        B = vertex_product(lensch, E_g, B_d, matrices, E_P)
        B_t = vertex_product(lensch, E_g, None, through, E_P) if through is not None else np.zeros_like(B)
        return B, B_t


def prepare(frame) -> list[Active]:
    """The TEXTURE_SPACE meshes of a frame whose bake is loaded (on first use) and current."""
    active = bake_cache.prepare(
        frame, "TEXTURE_SPACE",
        lambda arrays, mesh: Resources(tsd.gpu_tables(arrays, mesh.medium.mm_per_unit), arrays),
        lambda res, mesh: res.tables.fits(len(mesh.positions)), in_view=True)
    bake_cache.keep_drawn(active, "display")
    last = {id(a.resources): a for a in active}  # the highest slot of each bake (slots count up)
    for a in last.values():  # instances no longer drawn give their irradiance maps back
        del a.resources._irradiance[a.slot + 1:]
    return active


def illuminate(actives: list[Active], objects, frame_ubo, light_ubo, shadow_atlas, mode: int, pipeline) -> None:
    """Add one emitter's (mode 1, weighed by the angular law at its cosine) or the world's (mode 0, clears first;
    diffuse, over which the law averages 1) irradiance to each map."""
    for a in actives:
        medium, res = a.mesh.medium, a.resources
        draw_illumination(res.irradiance(a.slot)[0], res.illumination_points, res.tables.atlas_size,
                          objects[a.index], frame_ubo, light_ubo, shadow_atlas, mode, medium.eta,
                          angular_texture(a) if mode == 1 else unit_texture(pipeline),
                          oblique_entry.medium_shift_mm(medium) / medium.mm_per_unit)


def exit_texture(a: Active):
    """How light that crossed a thin part leaves, M(mu) (``angular_law.through_exit_table``; ones for the DIPOLE
    profile, which keeps the Lambertian law), as an n x 1 table."""
    medium = a.mesh.medium
    return a.resources.medium_tables.get("through_exit", medium, profile_model(medium.profile).through_exit_table)


def angular_texture(a: Active):
    """The medium's angular law a(mu) (``angular_law``; ones for the DIPOLE profile) as an n x 1 table."""
    medium = a.mesh.medium
    return a.resources.medium_tables.get("angular", medium, profile_model(medium.profile).angular_table)


def _gather(fb, points, source, size: tuple) -> None:
    """``ts_gather`` into ``fb`` (cleared first, additive): each point adds its weights times its texel of
    ``source`` to its slot of an image ``size`` wide and high (vertices from the atlas; clusters from the vertices)."""
    with draw_pass(fb, blend="ADDITIVE_PREMULT"):
        clear_target(fb, depth=None)
        shader = shaders.pass_shader("ts_gather")
        shader.bind()
        shader.uniform_sampler("irradiance", source)
        shader.uniform_int("vertex_width", tsd.VERTEX_WIDTH)
        shader.uniform_float("vertex_size", tuple(float(x) for x in size))
        shader.draw(points)


def finish(actives: list[Active], frame, frame_ubo, objects, target_fb, pipeline, product: str = "GPU") -> dict:
    """Gather, product, filter and display; returns seconds per step (summed over meshes)."""

    timings = {"ts_gather": 0.0, "ts_product": 0.0, "ts_filter": 0.0, "ts_display": 0.0}
    for a in actives:
        for key, dt in zip(timings, _finish_mesh(a, frame, frame_ubo, objects, target_fb, pipeline, product)):
            timings[key] += dt
    return timings


def _finish_mesh(a: Active, frame, frame_ubo, objects, target_fb, pipeline, product: str) -> tuple:
    """Steps 2 to 5 for one mesh; returns the seconds of gather, product, filter and display, for ``finish``."""
    res, t = a.resources, a.resources.tables
    product_here = _product_site(a, frame, product)
    t0 = time.perf_counter()
    E_vertex, B_direct, E_g, B_d = _gather_vertices(res, a.slot, product_here)
    t1 = time.perf_counter()
    T_p = t.drawn_corners(np.asarray(a.mesh.colors, np.float32))[t.vertex_corner]
    if product_here == "CPU":
        B_vertex, B_through = _product_on_cpu(res, T_p, E_g, B_d)
    else:
        B_vertex, B_through = _product_on_gpu(res, T_p, E_vertex, B_direct, pipeline)
    t2 = time.perf_counter()
    local_map, global_map, through_map = _filter_maps(a, T_p, B_vertex, B_through, pipeline)
    t3 = time.perf_counter()
    _display(a, frame_ubo, objects, target_fb, local_map, global_map, through_map)
    t4 = time.perf_counter()
    return t1 - t0, t2 - t1, t3 - t2, t4 - t3


def _product_site(a: Active, frame, product: str) -> str:
    """Where this mesh's product runs: ``product``, or the CPU (with a warning) past the GPU product's indexing."""
    t = a.resources.tables
    product_here = product if t.gpu_product else "CPU"
    if product_here != product:
        frame.warnings.append(f"'{a.mesh.name}': {t.form_factors:,} form factors are more than the GPU product "
                              "indexes; F^0 E runs on the CPU (a smaller atlas makes fewer)")
    return product_here


def _gather_vertices(res: Resources, slot: int, product_here: str) -> tuple:
    """Step 2: E^g and B^d gathered to the vertices; returns their textures and, for the CPU product, their values."""
    t = res.tables
    E_g = B_d = None
    _, (irradiance,), _ = res.irradiance(slot)
    vin_fb, (E_vertex, B_direct), _ = res.vertex_in
    _gather(vin_fb, res.gather_points, irradiance, t.vertex_size)
    with vin_fb.bind():
        if product_here == "CPU":
            E_g = read_pixels(vin_fb, *t.vertex_size, slot=0).reshape(-1, 4)[:t.vertex_count, :3]
            B_d = read_pixels(vin_fb, *t.vertex_size, slot=1).reshape(-1, 4)[:t.vertex_count, :3]
    return E_vertex, B_direct, E_g, B_d


def _product_on_cpu(res: Resources, T_p, E_g, B_d) -> tuple:
    """Step 3 with SciPy: (B / T_p, B^t / T_p) as vertex textures, kept on ``res`` until drawn."""
    t = res.tables
    B, B_t = (x / np.maximum(T_p, 1e-4) for x in res.cpu_product(E_g, B_d))
    B_vertex = texture_from_array(tsd.vertex_image(B.astype(np.float32), t.vertex_count), "RGBA32F")
    B_through = texture_from_array(tsd.vertex_image(B_t.astype(np.float32), t.vertex_count), "RGBA32F")
    res.cpu_vertex = (B_vertex, B_through)  # referenced until drawn
    return B_vertex, B_through


def _product_on_gpu(res: Resources, T_p, E_vertex, B_direct, pipeline) -> tuple:
    """Step 3 on the GPU: cluster power E_P, then ``ts_product`` per vertex; returns the (B, B^t) / T_p textures."""
    t = res.tables
    vout_fb, (B_vertex, B_through), _ = res.vertex_out
    T_p_texture = texture_from_array(tsd.vertex_image(T_p, t.vertex_count), "RGBA32F")
    E_cluster = unit_texture(pipeline)  # read by no entry where the bake has no far field
    if res.cluster_in is not None:
        cl_fb, (E_cluster, _), _ = res.cluster_in
        _gather(cl_fb, res.cluster_points, E_vertex, t.cluster_size)
    with draw_pass(vout_fb):
        shader = shaders.pass_shader("ts_product")
        shader.bind()
        shader.uniform_sampler("F_indptr", res.F_indptr)
        shader.uniform_sampler("F_indices", res.F_indices)
        shader.uniform_sampler("F_data", res.F_data)
        shader.uniform_sampler("E_vertex", E_vertex)
        shader.uniform_sampler("B_direct", B_direct)
        shader.uniform_sampler("T_p_vertex", T_p_texture)
        shader.uniform_int("vertex_width", tsd.VERTEX_WIDTH)
        shader.uniform_int("vertex_count", t.vertex_count)
        shader.uniform_int("cluster_count", t.cluster_count)
        shader.uniform_sampler("E_cluster", E_cluster)
        shader.uniform_int("row_split", tsd.ROW_SPLIT)
        shader.uniform_float("z_r", t.z_r)
        shader.draw(screen_quad(pipeline, "ts_product"))
    return B_vertex, B_through


def _filter_maps(a: Active, T_p, B_vertex, B_through, pipeline) -> tuple:
    """Step 4: local response (Eq. 15) and interpolated global response (Eq. 12) per texel; returns the three maps."""
    res, t = a.resources, a.resources.tables
    irr_fb, (irradiance,), _ = res.irradiance(a.slot)
    maps_fb, (local_map, global_map, through_map), _ = res.maps
    with draw_pass(maps_fb):
        clear_target(maps_fb, depth=None)
        shader = shaders.pass_shader("ts_filter")
        shader.bind()
        shader.uniform_sampler("irradiance", irradiance)
        shader.uniform_sampler("kernels", res.kernels)
        shader.uniform_sampler("B_vertex", B_vertex)
        shader.uniform_sampler("B_through", B_through)
        shader.uniform_int("vertex_width", tsd.VERTEX_WIDTH)
        shader.uniform_int("local_half", t.local_half)
        shader.uniform_float("atlas_size", tuple(float(x) for x in t.atlas_size))
        shader.draw(res.filter_points)
        if pipeline.capture is not None:
            _capture_maps(a, maps_fb, T_p, pipeline)
    if pipeline.capture is not None:
        with irr_fb.bind():
            w, h = t.atlas_size
            pipeline.capture["texture_space"][-1]["irradiance"] = read_pixels(irr_fb, w, h)
    return local_map, global_map, through_map


def _capture_maps(a: Active, maps_fb, T_p, pipeline) -> None:
    """For the tests: the bound maps, T_p and the bake's arrays of one mesh (its irradiance is added after)."""
    res = a.resources
    w, h = res.tables.atlas_size
    pipeline.capture.setdefault("texture_space", []).append({
        "name": a.mesh.name, "irradiance": None, "local": read_pixels(maps_fb, w, h, slot=0),
        "global": read_pixels(maps_fb, w, h, slot=1), "through": read_pixels(maps_fb, w, h, slot=2),
        "T_p_vertex": T_p, "arrays": res.arrays})


def _display(a: Active, frame_ubo, objects, target_fb, local_map, global_map, through_map) -> None:
    """Step 5: the mesh drawn over the base pass, reading both maps through its atlas coordinates (Eq. 1, 14)."""
    with draw_pass(target_fb, depth_test="LESS_EQUAL"):
        shader = shaders.pass_shader("ts_display")
        shader.bind()
        shader.uniform_block("frame", frame_ubo)
        shader.uniform_block("object", objects[a.index])
        shader.uniform_sampler("local_map", local_map)
        shader.uniform_sampler("global_map", global_map)
        shader.uniform_float("eta", float(a.mesh.medium.eta))
        shader.uniform_sampler("angular_table", angular_texture(a))
        shader.uniform_sampler("through_map", through_map)
        shader.uniform_sampler("exit_table", exit_texture(a))
        shader.draw(a.resources.display_batch(a.mesh))


class TextureSpace(Technique):
    """Lensch 2002: maps lit in texture space in the world pass and each emitter's, then gather, product,
    filter and display over the base."""

    object_props = (
        Prop("atlas_resolution", "IntProperty", {
            "name": "Atlas texels",
            "description": ("Texels along each side of the object's light atlas: more resolves finer light detail, "
                            "bakes slower and takes more memory. Changing it needs a new bake"),
            "min": 64,
            "max": 4096,
            "soft_max": 2048,
            "default": 512,
        }),
        Prop("proxy_spacing", "FloatProperty", {
            "name": "Proxy spacing",
            # Measured (docs/texture_space.md): back-lit bunny, atlas 512: 6.9 % from the dipole model at 3.5 and
            # 4.7 % at 2.4, baked in 44 s and 76 s, with 3.4 times the form factors.
            "description": ("Mean edge of the proxy mesh in atlas texels: finer follows shadow edges more "
                            "closely, but bakes longer and stores more (needs a new bake)"),
            "min": 1.5,
            "max": 8.0,
            "default": 3.5,
            "precision": 2,
        }),
        Prop("texture_blending", "BoolProperty", {
            "name": "Blend local and global",
            "description": ("Blend the light where it enters with the light spread from elsewhere, removing a bright "
                            "band near lit edges (off shows it)"),
            "default": True,
        }),
    )
    scene_props = (
        Prop("texture_product", "EnumProperty", {
            "name": "Global product",
            "description": "Where the light's long-range spread through the object is computed each frame",
            "items": (
                ("GPU", "GPU", "A fragment per vertex walks its row of the sparse matrix"),
                ("CPU", "CPU", "scipy.sparse after reading the vertex irradiance back"),
            ),
            "default": "GPU",
        }),
    )
    shader_specs = SHADER_SPECS
    id, label, method_number, timing = "TEXTURE_SPACE", "Texture Space", 2, "TEXTURE_SPACE"
    description = "Light spread through a baked texture atlas of the object: for rigid hero objects"
    scene_properties = ("texture_product",)
    bake_stages, bake_errors = ("texture_space",), (tsd.KernelTableError,)
    bake_properties = ("atlas_resolution", "proxy_spacing", "texture_blending")
    bake_corner_normals = True  # the illumination map lights each texel with the normal the display shows
    panel = (("atlas_resolution", "proxy_spacing", "texture_blending"),)
    scene_panel = (("texture_product",),)
    # Its error follows the proxy's spacing more than the atlas's (back-lit cow against the dipole model, atlas
    # 512: 9,833 vertices 7.0 %, 18,245 5.0 %, 28,889 4.5 %; atlas 768 at 9,697 vertices 6.7 %), so High refines
    # the proxy and keeps the atlas.
    object_tiers = {"DRAFT": {"atlas_resolution": 256, "proxy_spacing": 3.5},
                    "STANDARD": {"atlas_resolution": 512, "proxy_spacing": 3.5},
                    "HIGH": {"atlas_resolution": 512, "proxy_spacing": 2.4}}

    def bake(self, inputs, stage: str):
        return texture_space_bake.bake(inputs)

    def bake_parameters(self, values: dict) -> texture_space_bake.BakeParameters:
        return texture_space_bake.BakeParameters.from_values(values)

    def make_proxies(self, inputs, decimate):
        return texture_space_bake.make_proxies(inputs, decimate)

    def hash_parts(self, inputs, geometry: dict, material: dict) -> tuple[dict, dict]:
        return texture_space_bake.hash_parts(inputs, geometry, material)

    def bake_summary(self, meta: dict) -> list[str]:
        return texture_space_bake.summary(meta)

    compare_defaults = (256, 512)

    def compare_variants(self, values: tuple) -> list[Variant]:
        """One image per atlas resolution (or pair of it and the proxy spacing), drawn with the GPU product; the
        first also with the CPU one (scipy.sparse)."""
        variants = []
        for i, item in enumerate(values):
            res, spacing = proxy.atlas_setting(item)
            for product in ("GPU", "CPU") if i == 0 else ("GPU",):
                object_values = {"atlas_resolution": res, "proxy_spacing": spacing}
                variants.append(Variant(f"{proxy.atlas_label(res, spacing)}, {product} product", object_values,
                                        {"texture_product": product}, {**object_values, "product": product}))
        return variants

    def settings(self, values: dict) -> str:
        return values["texture_product"]

    def auto_quality(self, view, target: float, curves: str):
        return texture_space_quality.auto(view, target, curves)

    def prepare(self, ctx: FrameContext):
        return prepare(ctx.frame) or None

    def world(self, ctx: FrameContext, state, light_ubo) -> None:
        illuminate(state, ctx.objects, ctx.frame_ubo, light_ubo, ctx.shadow_atlas, mode=0, pipeline=ctx.resources)

    def emitter(self, ctx: FrameContext, state, emitter, light_ubo) -> None:
        illuminate(state, ctx.objects, ctx.frame_ubo, light_ubo, ctx.shadow_atlas, mode=1, pipeline=ctx.resources)

    def finish(self, ctx: FrameContext, state) -> dict:
        return finish(state, ctx.frame, ctx.frame_ubo, ctx.objects, ctx.target, ctx.resources,
                      ctx.frame.settings.of(self.id, "GPU"))


TECHNIQUE = TextureSpace()

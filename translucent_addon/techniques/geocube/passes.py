"""GEOCUBE: refraction through both sides, one internal reflection and thickness-dependent blur on the
GPU every frame (Chan & Wang 2005, Blender-facing).

Per frame, for each mesh with an up-to-date bake, one pass over its front faces (``gc_refract``) after
the base pass: Fresnel reflection of the world, refraction in, the cone-propelled exit search through
the object's geocubes (``geocube/cube_search.glsl``, twin of ``model``), refraction out or one total internal
reflection, then the world in the leaving direction from the key filtered environment chain
(``core/environment.py``) at the blur of the slab transfer fit for the path's scattering depth
(``core/physics/slab_transfer.py``), with coloured Beer absorption. The refracted scene is the world only:
other objects behind a glass object are not seen through it (the paper's environment-map model).
The GPU data of the world and of each anisotropy g are built once and cached.
"""
from __future__ import annotations

import time

import numpy as np

from ...core.physics.slab_transfer import transfer_table
from ...core.properties import Prop
from ...gpu import bake_cache, resources, shaders
from ...gpu.bake_cache import Active
from ...gpu.draw_state import draw_pass
from ...gpu.environment import environment
from ...gpu.frame_context import FrameContext
from ...gpu.targets import texture_from_array
from ..protocol import Technique
from . import bake as geocube_bake
from . import model as gcd
from . import quality as geocube_quality
from .bake import GeocubeError, from_arrays

# The GLSL interface of this technique's passes (one file each in gpu_shaders/), joined to the
# shader table by the registry.
SHADER_SPECS = {
    "gc_refract": shaders.ShaderSpec(
        source="geocube/refraction.glsl",
        libraries=("common/common.glsl", "common/cube_atlas.glsl", "geocube/cube_search.glsl"),
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("FLOAT", "start_cube")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("flat", "INT", "v_cube")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "GeocubeData", "gc")),
        samplers=((0, "FLOAT_2D", "gc_cones"), (1, "FLOAT_2D", "gc_normals"), (2, "FLOAT_2D", "gc_centres"),
                  (3, "FLOAT_2D", "env_atlas"), (4, "FLOAT_2D", "transfer_table")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
}


class Resources:
    """GPU data of one bake: the cone and normal atlases, the centres, and the draw batch."""

    def __init__(self, arrays: dict):
        self.gset = from_arrays(arrays)
        self.atlases = gcd.atlases(self.gset)
        self.stretch = np.asarray(arrays["stretch"], np.float64).reshape(3, 3)
        self.cones = texture_from_array(self.atlases.cones)
        self.normals = texture_from_array(self.atlases.normals)
        self.centres = texture_from_array(self.atlases.centres[None].astype(np.float32))
        self.batches: dict = {}

    def batch(self, mesh):
        """pos, nor and the starting cube of each corner (the bake's per-triangle choice, Sec. 2.3)."""
        b = self.batches.get(mesh.key)
        if b is None:
            from gpu_extras.batch import batch_for_shader

            start = np.repeat(self.gset.start_cube, 3).astype(np.float32)
            b = self.batches[mesh.key] = batch_for_shader(shaders.get("gc_refract"), "TRIS", {
                "pos": np.ascontiguousarray(mesh.positions, np.float32),
                "nor": np.ascontiguousarray(mesh.normals, np.float32),
                "start_cube": start})
        return b


def transfer(g: float):
    """(texture, log(1 + tau_max)) of the slab transfer fit for anisotropy g (Monte Carlo, ~1 s, cached)."""

    key = round(float(g), 3)
    transfers = resources.current().cache("geocube/transfer")
    cached = transfers.get(key)
    if cached is None:
        image, log_max = gcd.transfer_image(transfer_table(key))
        cached = transfers[key] = (texture_from_array(image), log_max)
    return cached


def prepare(frame) -> list[Active]:
    """The GEOCUBE meshes of a frame whose bake is loaded (on first use) and matches the mesh."""
    active = bake_cache.prepare(frame, "GEOCUBE", lambda arrays, mesh: Resources(arrays),
                                lambda res, mesh: len(res.gset.start_cube) == mesh.triangle_count)
    bake_cache.keep_drawn(active, "batches")
    return active


def max_steps_of(medium) -> int:
    """The exit search's cap on steps of a medium (its GEOCUBE part, else the default)."""
    extras = medium.extras if isinstance(medium.extras, gcd.MediumExtras) else gcd.MediumExtras()
    return extras.max_steps


def block_for(a: Active, frame, mode: int = 0) -> bytes:
    m = a.mesh.medium
    chain, _ = environment(frame)
    _, log_max = transfer(m.g)
    g = a.resources.gset
    sigma_s = np.asarray(m.sigma_s_prime, np.float64) / max(1.0 - float(m.g), 1e-3)
    to_bake = gcd.bake_from_world(a.mesh.model, a.resources.stretch, m.mm_per_unit)
    return gcd.gc_block(to_bake, m.sigma_a, sigma_s, m.eta, g.min_step, g.res, g.count, max_steps_of(m), chain,
                        log_max, mode)


def draw(actives: list[Active], frame, frame_ubo, objects, target_fb, pipeline, mode: int = 0) -> dict:
    """The refraction pass of every GEOCUBE mesh over the base; returns seconds spent."""
    import gpu

    t0 = time.perf_counter()
    _, env_tex = environment(frame)
    mode = int(mode)
    with draw_pass(target_fb, depth_test="LESS_EQUAL"):
        shader = shaders.pass_shader("gc_refract")
        shader.bind()
        shader.uniform_block("frame", frame_ubo)
        shader.uniform_sampler("env_atlas", env_tex)
        for a in actives:
            table_tex, _ = transfer(a.mesh.medium.g)
            r = a.resources
            shader.uniform_block("object", objects[a.index])
            gc_ubo = gpu.types.GPUUniformBuf(block_for(a, frame, mode))  # referenced until drawn
            shader.uniform_block("gc", gc_ubo)
            shader.uniform_sampler("gc_cones", r.cones)
            shader.uniform_sampler("gc_normals", r.normals)
            shader.uniform_sampler("gc_centres", r.centres)
            shader.uniform_sampler("transfer_table", table_tex)
            shader.draw(r.batch(a.mesh))
    return {"geocube": time.perf_counter() - t0}


def clear_caches() -> None:
    resources.current().cache("geocube/transfer").clear()


class Geocube(Technique):
    """Chan & Wang 2005: each glass mesh's refraction of the world drawn over the base."""

    surface_layer = False  # glass: its refraction draws its own reflection
    dipole_modelled = False  # glass: the CPU dipole model draws no refraction

    object_props = (
        Prop("geocube_resolution", "IntProperty", {
            "name": "Cube texels",
            "description": ("Texels along each face of the object's distance cube: more follows finer shapes; 0 "
                            "chooses it from the object's size in the camera's view at bake time. Changing it needs a "
                            "new bake"),
            "min": 0,
            "max": 256,
            "default": 0,
        }),
        Prop("geocube_steps", "IntProperty", {
            "name": "Max steps",
            "description": ("Most steps a ray takes inside the object: more follows thick or winding shapes further, "
                            "slower; a ray that runs out leaves at the last surface it saw"),
            "min": 1,
            "max": 256,
            "default": 32,
        }),
    )
    scene_props = (
        Prop("geocube_output", "IntProperty", {
            "name": "GEOCUBE output",
            "description": ("GEOCUBE pass output (tests, debugging): 0 colour, 1 entry point, 2 exit point, 3 "
                            "refracted direction (bake frame); 4 entry point, 5 refracted direction, 6 last exit "
                            "point and legs inside, 7 leaving direction and exit transmittance (world)"),
            "min": 0,
            "max": 7,
            "default": 0,
            "options": {"HIDDEN"},
        }),
    )
    shader_specs = SHADER_SPECS
    id, label, method_number = "GEOCUBE", "Geocube", 4
    description = "Refraction through a baked distance cube, blurred by thickness: glass and slightly cloudy materials"
    scene_properties = ("geocube_output",)
    bake_stages, bake_errors = ("geocube",), (GeocubeError,)
    bake_properties = ("geocube_resolution",)
    medium_properties = ("geocube_steps",)
    panel = (("geocube_resolution", "geocube_steps"),)
    object_tiers = {"DRAFT": {"geocube_resolution": 32}, "STANDARD": {"geocube_resolution": 0},
                    "HIGH": {"geocube_resolution": 64}}

    def bake(self, inputs, stage: str):
        return geocube_bake.bake(inputs)

    def bake_parameters(self, values: dict) -> geocube_bake.BakeParameters:
        return geocube_bake.BakeParameters.from_values(values)

    def needs_screen_pixels(self, params) -> bool:
        return params is not None and params.resolution == 0  # the automatic cube resolution follows it

    def hash_parts(self, inputs, geometry: dict, material: dict) -> tuple[dict, dict]:
        return geocube_bake.hash_parts(inputs, geometry, material)

    def bake_summary(self, meta: dict) -> list[str]:
        return geocube_bake.summary(meta)

    def medium_extras(self, values: dict, mm_per_unit: float) -> gcd.MediumExtras:
        return gcd.MediumExtras(max_steps=int(values["geocube_steps"]))

    def settings(self, values: dict) -> int:
        return int(values["geocube_output"])

    def auto_quality(self, view, target: float, curves: str):
        return geocube_quality.auto(view, target, curves)

    def prepare(self, ctx: FrameContext):
        return prepare(ctx.frame) or None

    def finish(self, ctx: FrameContext, state) -> dict:
        return draw(state, ctx.frame, ctx.frame_ubo, ctx.objects, ctx.target, ctx.resources,
                    mode=ctx.frame.settings.of(self.id, 0))

    def clear_caches(self) -> None:
        clear_caches()


TECHNIQUE = Geocube()

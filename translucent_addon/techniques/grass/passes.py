"""Grass fields (Shah ch. 4): the GPU pass drawing each grass-covered ground mesh as a BTF layer.

Blender-facing (``gpu``). The pipeline calls ``draw`` right after the base pass in the world pass
(mode 0) and in each emitter's lighting pass (mode 1), so the grass takes part in the same depth
test as everything else: blades in front of an object hide it, gaps show what is behind, and the
base pass adds light only to what the blades leave visible. Per-pixel maths:
``techniques/grass/model.py``; shader: ``gpu_shaders/grass/btf.glsl``.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.properties import Prop
from ...gpu import bake_cache, shaders
from ...gpu.frame_context import FrameContext
from ...gpu.targets import texture_from_array
from ..protocol import Technique
from . import bake as grass_btf
from . import model as grass_data

# The GLSL interface of this technique's passes (one file each in gpu_shaders/), joined to the
# shader table by the registry.
SHADER_SPECS = {
    "grass_btf": shaders.ShaderSpec(
        source="grass/btf.glsl",
        libraries=shaders.SHADOW_LIBS,
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC2", "v_uv"),
                  ("smooth", "VEC3", "v_tangent")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light"),
                        (4, "GrassData", "grass")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "btf_basis"), (2, "FLOAT_2D", "btf_coeffs"),
                  (3, "FLOAT_2D", "btf_depth"), (4, "FLOAT_2D", "btf_tables")),
        push_constants=(("INT", "mode"),),
        fragment_out=((0, "VEC4", "out_color"),),
        depth_write="ANY",
    ),
}


@dataclasses.dataclass
class Resources:
    btf: object  # CompressedBTF
    basis: object
    coeffs: object
    depth: object
    tables: object
    groups: tuple


@dataclasses.dataclass
class Active:
    index: int
    mesh: object
    resources: Resources


def build(loaded) -> Resources:

    arrays, meta = loaded
    cb = grass_btf.from_arrays(arrays, meta)
    return Resources(
        btf=cb,
        basis=texture_from_array(grass_data.packed_basis(cb)),
        coeffs=texture_from_array(grass_data.packed_coeffs(cb)),
        depth=texture_from_array(grass_data.packed_depth(cb)[..., None], "R32F"),
        tables=texture_from_array(grass_data.packed_tables(grass_data.Tables.of(cb))),
        groups=grass_data.groups(cb),
    )


def prepare(frame) -> list[Active]:
    """The frame's grass-covered meshes with the GPU data of their BTF."""
    active = []
    for k, mesh in enumerate(frame.meshes):
        layer = mesh.extras.get(TECHNIQUE.id)
        if layer is None:
            continue
        res = bake_cache.checked(frame, mesh.name, "grass BTF", layer.bake, build)
        if res is not None:
            active.append(Active(k, mesh, res))
    return active


def grass_block(layer, res: Resources) -> bytes:
    cb = res.btf
    g = res.groups
    data = np.array([
        layer.tile, cb.height, cb.resolution, grass_data.TABLE_RES,
        len(cb.views), len(cb.lights), 0.0, layer.lod,
        g[0], g[1], g[2], min(max(int(layer.min_groups), 1), g[0]),
    ], np.float32)
    return data.tobytes()


def _batch(pipeline, mesh):
    key = ("grass", mesh.key)
    batch = pipeline.targets.get(key)
    if batch is None:
        from gpu_extras.batch import batch_for_shader

        batch = pipeline.targets[key] = batch_for_shader(
            shaders.get("grass_btf"), "TRIS",
            {"pos": np.ascontiguousarray(mesh.positions, np.float32),
             "nor": grass_data.smooth_corner_normals(mesh.positions)})
    return batch


def draw(actives: list[Active], pipeline, frame_ubo, objects, light_ubo, shadow_atlas, mode: int) -> None:
    """Draw every grass layer into the bound target: mode 0 writes colour and depth, mode 1 adds one
    emitter's light where the depth of mode 0 is matched (the caller sets blending and depth writes)."""
    import gpu

    shader = shaders.bind_lit("grass_btf", frame_ubo, light_ubo, shadow_atlas, mode)
    blocks = []
    for a in actives:
        r = a.resources
        ubo = gpu.types.GPUUniformBuf(grass_block(a.mesh.extras[TECHNIQUE.id], r))
        blocks.append(ubo)  # referenced until drawn
        shader.uniform_block("object", objects[a.index])
        shader.uniform_block("grass", ubo)
        shader.uniform_sampler("btf_basis", r.basis)
        shader.uniform_sampler("btf_coeffs", r.coeffs)
        shader.uniform_sampler("btf_depth", r.depth)
        shader.uniform_sampler("btf_tables", r.tables)
        shader.draw(_batch(pipeline, a.mesh))


class Grass(Technique):
    """Shah ch. 4: grass fields drawn right after the base in the world pass and each emitter's."""

    owns_surface = True  # the field is the ground's surface

    object_props = (
        Prop("grass", "BoolProperty", {
            "name": "Grass field",
            "description": ("Grow a grass field on this mesh, drawn from baked views of its blades: its cost follows "
                            "the pixels it covers, not the blades. Add it with Add Grass Field, then Bake Grass BTF"),
            "default": False,
        }),
        Prop("grass_tile", "FloatProperty", {
            "name": "Tile",
            "description": "Side of the square patch of grass the BTF repeats",
            "subtype": "DISTANCE",
            "unit": "LENGTH",
            "min": 0.001,
            "soft_max": 10.0,
            "default": 0.1,
        }),
        Prop("grass_blade_height", "FloatProperty", {
            "name": "Blade height",
            "description": "Height of the tallest blades (5-60 % of the tile)",
            "subtype": "DISTANCE",
            "unit": "LENGTH",
            "min": 0.0001,
            "soft_max": 1.0,
            "default": 0.045,
        }),
        Prop("grass_blades", "IntProperty", {
            "name": "Blades per tile",
            "description": "Blades in one tile of the patch",
            "min": 1,
            "max": 5000,
            "default": 500,
        }),
        Prop("grass_seed", "IntProperty", {
            "name": "Seed",
            "description": "Random layout of the blades",
            "min": 0,
            "default": 7,
        }),
        Prop("grass_resolution", "EnumProperty", {
            "name": "BTF texels",
            "description": "Texels per side of each of the 1,701 BTF images",
            "items": (
                ("64", "64", "Fast bake, soft blades"),
                ("128", "128", "Balanced: the bake and sharpness most fields need"),
                ("256", "256", "Sharp, 4x the bake"),
            ),
            "default": "128",
        }),
        Prop("grass_target_error", "FloatProperty", {
            "name": "Target error",
            "description": ("Relative reconstruction error of the compressed BTF; sets how many eigen-textures are"
                            " kept (lower: sharper, more memory)"),
            "min": 0.01,
            "max": 0.9,
            "default": 0.5,
            "precision": 2,
        }),
        Prop("grass_lod", "FloatProperty", {
            "name": "Detail falloff",
            "description": ("BTF texels per pixel beyond which fewer eigen-textures are summed (far grass is "
                            "cheaper); 0 keeps all of them everywhere"),
            "min": 0.0,
            "soft_max": 8.0,
            "default": 1.0,
        }),
    )
    shader_specs = SHADER_SPECS
    id, label = "GRASS", "Grass"
    description = "Grass fields from a compressed BTF with silhouettes (Shah 2007, ch. 4)"

    def object_extras(self, reader) -> grass_data.GrassLayer | None:
        """The grass field growing on the object, where it has one with a current BTF (else a line says why)."""
        if not reader.values(("grass",))["grass"]:  # most objects: one read
            return None
        s = reader.values(("grass_lod", *grass_btf.SETTINGS))
        digest, why = grass_btf.settings_digest(s)
        handle = None
        if digest is not None:
            status, handle = reader.stored_bake(grass_btf.BAKE_KEY, digest)
            why = f"grass BTF is {status.lower()}"
        if handle is None:
            reader.warn(f"'{reader.name}': {why}; no grass drawn. Press Bake Grass BTF")
            return None
        return grass_data.GrassLayer(handle, float(s["grass_tile"]), float(s["grass_lod"]))
    object_tiers = {"DRAFT": {"grass_resolution": "64"}, "STANDARD": {"grass_resolution": "128"},
                    "HIGH": {"grass_resolution": "256"}}

    def prepare(self, ctx: FrameContext):
        return prepare(ctx.frame) or None

    def world(self, ctx: FrameContext, state, light_ubo) -> None:
        draw(state, ctx.resources, ctx.frame_ubo, ctx.objects, light_ubo, ctx.shadow_atlas, mode=0)

    def emitter_surface(self, ctx: FrameContext, state, light_ubo) -> None:
        draw(state, ctx.resources, ctx.frame_ubo, ctx.objects, light_ubo, ctx.shadow_atlas, mode=1)


TECHNIQUE = Grass()

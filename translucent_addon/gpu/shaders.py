"""GPU shaders, built only through ``gpu.types.GPUShaderCreateInfo``.

Each pass has one GLSL file in ``gpu_shaders/`` holding both stages behind
``GPU_VERTEX_SHADER`` / ``GPU_FRAGMENT_SHADER`` (Blender defines these per
stage). Its interface is described once here, as plain data, so that another
host (a moderngl bake context) can generate its own declarations from the same
description. Shaders are built on first use inside a GPU context, never at
import time, and freed on unregister.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

SHADER_DIR = Path(__file__).resolve().parents[2] / "gpu_shaders"
STRUCTS_FILE = "translucent_structs.glsl"


@dataclasses.dataclass(frozen=True)
class ShaderSpec:
    """Interface of one pass: inputs, varyings, uniform blocks, samplers, outputs."""

    source: str
    libraries: tuple = ("translucent_common.glsl",)  # prepended to the source, in order
    vertex_in: tuple = ()  # (type, name)
    varyings: tuple = ()  # ("smooth" | "flat", type, name)
    uniform_blocks: tuple = ()  # (slot, struct, name)
    samplers: tuple = ()  # (slot, type, name)
    push_constants: tuple = ()  # (type, name)
    fragment_out: tuple = ()  # (slot, type, name)
    depth_write: str = "UNCHANGED"  # "ANY": the fragment stage writes gl_FragDepth


_LIGHT_LIBS = ("translucent_common.glsl", "translucent_light.glsl")
_SHADOW_LIBS = _LIGHT_LIBS + ("translucent_shadow.glsl",)
_SURFACE_IN = (("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "col"), ("VEC4", "paint"), ("VEC3", "tint"))

SPECS = {
    "shadow_distance": ShaderSpec(
        source="shadow_distance.glsl",
        vertex_in=(("VEC3", "pos"),),
        varyings=(("smooth", "VEC3", "v_world"),),
        uniform_blocks=((2, "LightData", "light"), (1, "ObjectData", "object")),
        push_constants=(("INT", "face"),),
        fragment_out=((0, "FLOAT", "out_distance"),),
    ),
    "base_lighting": ShaderSpec(
        source="base_lighting.glsl",
        libraries=_SHADOW_LIBS + ("translucent_world_sh.glsl",),
        vertex_in=_SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_color"),
                  ("smooth", "VEC4", "v_paint"), ("smooth", "VEC3", "v_tint")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light"),
                        (3, "MaterialsData", "materials")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "near_lut")),
        push_constants=(("INT", "mode"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "is_world_samples": ShaderSpec(
        source="is_world_samples.glsl",
        libraries=("translucent_common.glsl", "translucent_world_sh.glsl"),
        vertex_in=_SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC4", "v_paint"),
                  ("smooth", "VEC3", "v_tint")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (3, "MaterialsData", "materials")),
        samplers=((0, "FLOAT_2D", "previous_pos_id"),),
        push_constants=(("MAT4", "view_proj"), ("INT", "layer"), ("FLOAT", "depth_epsilon"), ("FLOAT", "texel_area")),
        fragment_out=((0, "VEC4", "out_pos_id"), (1, "VEC4", "out_flux")),
    ),
    "is_gbuffer": ShaderSpec(
        source="is_gbuffer.glsl",
        vertex_in=(("VEC3", "pos"),),
        varyings=(("smooth", "VEC3", "v_world"),),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object")),
        fragment_out=((0, "VEC4", "out_pos_id"), (1, "VEC4", "out_normal")),
    ),
    "is_samples": ShaderSpec(
        source="is_samples.glsl",
        libraries=_LIGHT_LIBS,
        vertex_in=_SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC4", "v_paint"),
                  ("smooth", "VEC3", "v_tint")),
        uniform_blocks=((1, "ObjectData", "object"), (2, "LightData", "light"), (3, "MaterialsData", "materials")),
        push_constants=(("INT", "face"),),
        fragment_out=((0, "VEC4", "out_pos_id"), (1, "VEC4", "out_flux")),
    ),
    "is_splat": ShaderSpec(
        source="is_splat.glsl",
        vertex_in=(("VEC2", "corner"),),
        varyings=(("flat", "VEC3", "v_xi"), ("flat", "VEC4", "v_flux"), ("flat", "FLOAT", "v_slot")),
        uniform_blocks=((0, "FrameData", "frame"), (3, "MaterialsData", "materials")),
        samplers=((0, "FLOAT_2D", "sample_pos_id"), (1, "FLOAT_2D", "sample_flux"), (2, "FLOAT_2D", "gbuffer"),
                  (3, "FLOAT_2D", "far_lut"), (4, "FLOAT_2D", "gbuffer_normal")),
        push_constants=(("INT", "samples_per_row"), ("INT", "world_pass"), ("INT", "tail_pass"),
                        ("FLOAT", "tail_reach"), ("FLOAT", "tail_start"), ("INT", "tail_block")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "is_temporal": ShaderSpec(
        source="is_temporal.glsl",
        vertex_in=(("VEC2", "corner"),),
        uniform_blocks=((0, "TemporalData", "temporal"),),
        samplers=((0, "FLOAT_2D", "scatter"), (1, "FLOAT_2D", "gbuffer"), (2, "FLOAT_2D", "previous_accum"),
                  (3, "FLOAT_2D", "previous_gbuffer")),
        push_constants=(("FLOAT", "blend"),),
        fragment_out=((0, "VEC4", "out_accum"),),
    ),
    "is_composite": ShaderSpec(
        source="is_composite.glsl",
        vertex_in=_SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC4", "v_paint")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (3, "MaterialsData", "materials")),
        samplers=((0, "FLOAT_2D", "scatter"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "ts_illumination": ShaderSpec(
        source="ts_illumination.glsl",
        libraries=_SHADOW_LIBS + ("translucent_world_sh.glsl",),
        vertex_in=(("VEC2", "texel"), ("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "facet"), ("FLOAT", "sky")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_facet"),
                  ("smooth", "FLOAT", "v_sky")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "cosine_table")),
        push_constants=(("INT", "mode"), ("FLOAT", "eta"), ("VEC3", "world_kernel"), ("VEC2", "atlas_size")),
        fragment_out=((0, "VEC4", "out_irradiance"),),
    ),
    "ts_gather": ShaderSpec(
        source="ts_gather.glsl",
        vertex_in=(("VEC2", "texel"), ("FLOAT", "target"), ("FLOAT", "dual"), ("VEC3", "blend")),
        varyings=(("flat", "VEC3", "v_eg"), ("flat", "VEC3", "v_bd")),
        samplers=((0, "FLOAT_2D", "irradiance"),),
        push_constants=(("INT", "vertex_width"), ("VEC2", "vertex_size")),
        fragment_out=((0, "VEC4", "out_eg"), (1, "VEC4", "out_bd")),
    ),
    "ts_product": ShaderSpec(
        source="ts_product.glsl",
        vertex_in=(("VEC2", "corner"),),
        samplers=((0, "FLOAT_2D", "F_indptr"), (1, "FLOAT_2D", "F_indices"), (2, "FLOAT_2D", "F_data"),
                  (3, "FLOAT_2D", "E_vertex"), (4, "FLOAT_2D", "B_direct"), (5, "FLOAT_2D", "T_p_vertex")),
        push_constants=(("INT", "vertex_width"), ("INT", "vertex_count"), ("INT", "row_split")),
        fragment_out=((0, "VEC4", "out_vertex"),),
    ),
    "ts_filter": ShaderSpec(
        source="ts_filter.glsl",
        vertex_in=(("VEC2", "texel"), ("VEC2", "source"), ("FLOAT", "row"), ("VEC3", "bary"), ("VEC3", "verts")),
        varyings=(("flat", "VEC2", "v_source"), ("flat", "FLOAT", "v_row"), ("flat", "VEC3", "v_bary"),
                  ("flat", "VEC3", "v_verts")),
        samplers=((0, "FLOAT_2D", "irradiance"), (1, "FLOAT_2D", "kernels"), (2, "FLOAT_2D", "B_vertex")),
        push_constants=(("INT", "vertex_width"), ("INT", "local_half"), ("VEC2", "atlas_size")),
        fragment_out=((0, "VEC4", "out_local"), (1, "VEC4", "out_global")),
    ),
    "ts_display": ShaderSpec(
        source="ts_display.glsl",
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "col"), ("VEC2", "uv")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_color"),
                  ("smooth", "VEC2", "v_uv")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object")),
        samplers=((0, "FLOAT_2D", "local_map"), (1, "FLOAT_2D", "global_map")),
        push_constants=(("FLOAT", "eta"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "qg_relax": ShaderSpec(
        source="qg_relax.glsl",
        libraries=("qg_common.glsl",),
        vertex_in=(("VEC2", "corner"),),
        samplers=((0, "FLOAT_2D", "phi"), (1, "FLOAT_2D", "incident"), (2, "FLOAT_2D", "links_map"),
                  (3, "FLOAT_2D", "weights_map"), (4, "FLOAT_2D", "node_kappa"), (5, "FLOAT_2D", "node_mu"),
                  (6, "FLOAT_2D", "q_factor")),
        push_constants=(("INT", "blocks_per_row"), ("INT", "n_surface"), ("INT", "inner_start"),
                        ("INT", "inner_end"), ("FLOAT", "A")),
        fragment_out=((0, "VEC4", "out_phi"),),
    ),
    "qg_upsample": ShaderSpec(
        source="qg_upsample.glsl",
        libraries=("qg_common.glsl",),
        vertex_in=(("VEC2", "corner"),),
        samplers=((0, "FLOAT_2D", "coarse_phi"), (1, "FLOAT_2D", "up_index0"), (2, "FLOAT_2D", "up_index1"),
                  (3, "FLOAT_2D", "up_weight0"), (4, "FLOAT_2D", "up_weight1")),
        push_constants=(("INT", "coarse_blocks_per_row"),),
        fragment_out=((0, "VEC4", "out_phi"),),
    ),
    "qg_display": ShaderSpec(
        source="qg_display.glsl",
        libraries=("translucent_common.glsl", "qg_common.glsl"),
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC4", "links"), ("VEC4", "link_weights"), ("FLOAT", "mask")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_radiosity"),
                  ("smooth", "VEC3", "v_world_local"), ("smooth", "FLOAT", "v_mask"), ("smooth", "VEC3", "v_factor")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object")),
        samplers=((0, "FLOAT_2D", "phi"), (1, "FLOAT_2D", "q_factor"), (2, "FLOAT_2D", "single"),
                  (3, "FLOAT_2D", "loss"), (4, "FLOAT_2D", "loss_world"), (5, "FLOAT_2D", "world_law"),
                  (6, "FLOAT_2D", "loss_scale")),
        push_constants=(("INT", "blocks_per_row"), ("FLOAT", "eta"), ("FLOAT", "F_dr"), ("INT", "display_output")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "qg_single": ShaderSpec(
        source="qg_single.glsl",
        libraries=_SHADOW_LIBS,
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "corner")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_corner")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "depths"), (2, "FLOAT_2D", "h_table"),
                  (3, "FLOAT_2D", "terminator_table")),
        push_constants=(("INT", "mode"), ("FLOAT", "eta"), ("FLOAT", "g"), ("VEC4", "sigma_a"), ("VEC4", "sigma_s"),
                        ("VEC4", "terminator_rho"), ("INT", "segments"), ("FLOAT", "tau_max"), ("INT", "terms")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "env_background": ShaderSpec(
        source="env_background.glsl",
        libraries=("translucent_common.glsl", "cube_atlas.glsl"),
        vertex_in=(("VEC2", "corner"),),
        varyings=(("smooth", "VEC2", "v_ndc"),),
        uniform_blocks=((0, "FrameData", "frame"),),
        samplers=((0, "FLOAT_2D", "env_atlas"),),
        push_constants=(("INT", "env_res"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "gc_refract": ShaderSpec(
        source="gc_refract.glsl",
        libraries=("translucent_common.glsl", "cube_atlas.glsl", "gc_common.glsl"),
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("FLOAT", "start_cube")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("flat", "INT", "v_cube")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "GeocubeData", "gc")),
        samplers=((0, "FLOAT_2D", "gc_cones"), (1, "FLOAT_2D", "gc_normals"), (2, "FLOAT_2D", "gc_centres"),
                  (3, "FLOAT_2D", "env_atlas"), (4, "FLOAT_2D", "transfer_table")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "grass_btf": ShaderSpec(
        source="grass_btf.glsl",
        libraries=_SHADOW_LIBS,
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
    "relief": ShaderSpec(
        source="relief.glsl",
        libraries=_SHADOW_LIBS + ("interval_search.glsl", "translucent_world_sh.glsl"),
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "col"), ("VEC2", "uv"), ("VEC3", "tangent_u"),
                   ("VEC3", "tangent_v")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_tangent_u"),
                  ("smooth", "VEC3", "v_tangent_v"), ("smooth", "VEC2", "v_uv"), ("smooth", "VEC3", "v_color")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light"),
                        (5, "ReliefData", "relief")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "height_map")),
        push_constants=(("INT", "mode"),),
        fragment_out=((0, "VEC4", "out_color"),),
        depth_write="ANY",
    ),
    "caustic_receiver": ShaderSpec(
        source="caustic_receiver.glsl",
        vertex_in=(("VEC3", "pos"),),
        varyings=(("smooth", "VEC3", "v_world"),),
        uniform_blocks=((2, "LightData", "light"), (1, "ObjectData", "object")),
        push_constants=(("INT", "face"),),
        fragment_out=((0, "VEC4", "out_position"),),
    ),
    "caustic_caster": ShaderSpec(
        source="caustic_caster.glsl",
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal")),
        uniform_blocks=((1, "ObjectData", "object"), (4, "CausticData", "caustic")),
        fragment_out=((0, "VEC4", "out_position"), (1, "VEC4", "out_normal")),
    ),
    "caustic_trace": ShaderSpec(
        source="caustic_trace.glsl",
        libraries=_SHADOW_LIBS + ("caustic_lookup.glsl",),
        vertex_in=(("VEC2", "corner"),),
        uniform_blocks=((2, "LightData", "light"), (4, "CausticData", "caustic")),
        samplers=((0, "FLOAT_2D", "front_position"), (1, "FLOAT_2D", "front_normal"),
                  (2, "FLOAT_2D", "back_position"), (3, "FLOAT_2D", "back_normal"),
                  (4, "FLOAT_2D", "receiver_atlas"), (5, "FLOAT_2D", "shadow_atlas")),
        fragment_out=((0, "VEC4", "out_landing"), (1, "VEC4", "out_flux")),
    ),
    "caustic_splat": ShaderSpec(
        source="caustic_splat.glsl",
        libraries=_LIGHT_LIBS + ("caustic_lookup.glsl",),
        vertex_in=(("VEC2", "corner"),),
        varyings=(("flat", "VEC3", "v_flux"), ("flat", "VEC2", "v_centre"), ("flat", "FLOAT", "v_sigma"),
                  ("flat", "VEC2", "v_tile")),
        uniform_blocks=((2, "LightData", "light"), (4, "CausticData", "caustic")),
        samplers=((0, "FLOAT_2D", "trace_landing"), (1, "FLOAT_2D", "trace_flux")),
        fragment_out=((0, "VEC4", "out_flux"),),
    ),
    "caustic_apply": ShaderSpec(
        source="caustic_apply.glsl",
        libraries=_LIGHT_LIBS + ("caustic_lookup.glsl",),
        vertex_in=_SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_color")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light"),
                        (4, "CausticData", "caustic")),
        samplers=((0, "FLOAT_2D", "caustic_atlas"), (1, "FLOAT_2D", "receiver_atlas")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
}

_cache: dict = {}


def read_source(name: str) -> str:
    return (SHADER_DIR / name).read_text()


def create_info(name: str, spec: ShaderSpec):
    """The GPUShaderCreateInfo for a spec (needs Blender's ``gpu`` module)."""
    import gpu

    info = gpu.types.GPUShaderCreateInfo()
    if spec.uniform_blocks:
        info.typedef_source(read_source(STRUCTS_FILE))
    for slot, struct, block in spec.uniform_blocks:
        info.uniform_buf(slot, struct, block)
    for slot, kind, sampler in spec.samplers:
        info.sampler(slot, kind, sampler)
    for kind, const in spec.push_constants:
        info.push_constant(kind, const)
    for slot, (kind, attr) in enumerate(spec.vertex_in):
        info.vertex_in(slot, kind, attr)
    if spec.varyings:
        iface = gpu.types.GPUStageInterfaceInfo(f"{name}_iface")
        for interp, kind, var in spec.varyings:
            getattr(iface, interp)(kind, var)
        info.vertex_out(iface)
    for slot, kind, out in spec.fragment_out:
        info.fragment_out(slot, kind, out)
    if spec.depth_write != "UNCHANGED":
        info.depth_write(spec.depth_write)
    source = "\n".join(read_source(lib) for lib in spec.libraries) + "\n" + read_source(spec.source)
    info.vertex_source(source)
    info.fragment_source(source)
    return info


def get(name: str):
    """The compiled shader for a pass, built on first use."""
    shader = _cache.get(name)
    if shader is None:
        import gpu

        shader = gpu.shader.create_from_info(create_info(name, SPECS[name]))
        _cache[name] = shader
    return shader


def bind_lit(name: str, frame_ubo, light_ubo, shadow_atlas, mode: int):
    """Bind a pass drawn in the world pass (mode 0) and each emitter's pass (mode 1) with what those
    passes share: the frame and light blocks, the shadow atlas and the mode. Returns the shader."""
    shader = get(name)
    shader.bind()
    shader.uniform_block("frame", frame_ubo)
    shader.uniform_block("light", light_ubo)
    shader.uniform_sampler("shadow_atlas", shadow_atlas)
    shader.uniform_int("mode", mode)
    return shader


def free_all() -> None:
    _cache.clear()

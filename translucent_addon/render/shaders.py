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
    vertex_in: tuple = ()  # (type, name)
    varyings: tuple = ()  # ("smooth" | "flat", type, name)
    uniform_blocks: tuple = ()  # (slot, struct, name)
    samplers: tuple = ()  # (slot, type, name)
    push_constants: tuple = ()  # (type, name)
    fragment_out: tuple = ()  # (slot, type, name)


SPECS = {
    "shadow_distance": ShaderSpec(
        source="shadow_distance.glsl",
        vertex_in=(("VEC3", "pos"),),
        varyings=(("smooth", "VEC3", "v_world"),),
        uniform_blocks=((0, "LightData", "light"), (1, "ObjectData", "object")),
        push_constants=(("INT", "face"),),
        fragment_out=((0, "FLOAT", "out_distance"),),
    ),
    "base_lighting": ShaderSpec(
        source="base_lighting.glsl",
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "col")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_color")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"),),
        push_constants=(("INT", "mode"),),
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
    source = read_source(spec.source)
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


def free_all() -> None:
    _cache.clear()

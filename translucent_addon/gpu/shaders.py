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

from . import resources

SHADER_DIR = Path(__file__).resolve().parents[2] / "gpu_shaders"
STRUCTS_FILE = "common/structs.glsl"


@dataclasses.dataclass(frozen=True)
class ShaderSpec:
    """Interface of one pass: inputs, varyings, uniform blocks, samplers, outputs."""

    source: str
    libraries: tuple = ("common/common.glsl",)  # prepended to the source, in order
    vertex_in: tuple = ()  # (type, name)
    varyings: tuple = ()  # ("smooth" | "flat", type, name)
    uniform_blocks: tuple = ()  # (slot, struct, name)
    samplers: tuple = ()  # (slot, type, name)
    push_constants: tuple = ()  # (type, name)
    fragment_out: tuple = ()  # (slot, type, name)
    depth_write: str = "UNCHANGED"  # "ANY": the fragment stage writes gl_FragDepth
    defines: tuple = ()  # names #defined before the source (one file, several passes)


LIGHT_LIBS = ("common/common.glsl", "common/light.glsl")
SHADOW_LIBS = LIGHT_LIBS + ("common/shadow.glsl",)
SURFACE_IN = (("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "col"), ("VEC4", "paint"), ("VEC3", "tint"),
              ("VEC3", "curv_d"), ("VEC3", "curv_o"))  # curv: the shape operator (pipeline.shape_attributes)
CURVATURE_OUT = (("smooth", "VEC3", "v_curv_d"), ("smooth", "VEC3", "v_curv_o"))


def _surface_spec(world: bool) -> ShaderSpec:
    """The surface layer (pipeline/surface_layer.glsl): the gloss and the light entering through a normal map, of
    the world and the factor on the light below and the Normal and Depth passes (``world``), or of one emitter."""
    outputs = ((0, "VEC4", "out_specular"), (1, "VEC4", "out_entry"))
    if world:
        outputs += ((2, "VEC4", "out_factor"), (3, "VEC4", "out_gbuffer"))
    return ShaderSpec(
        source="pipeline/surface_layer.glsl",
        libraries=SHADOW_LIBS + ("common/world_spherical_harmonics.glsl",),
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor"), ("VEC2", "uv"), ("VEC4", "tangent"), ("VEC4", "albedo"),
                   ("VEC4", "gloss")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC4", "v_tangent"),
                  ("smooth", "VEC2", "v_uv"), ("smooth", "VEC4", "v_albedo"), ("smooth", "VEC4", "v_gloss")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "specular_table"), (2, "FLOAT_2D", "energy_table"),
                  (3, "FLOAT_2D", "albedo_map"), (4, "FLOAT_2D", "normal_map")),
        push_constants=(("INT", "normal_mode"), ("INT", "albedo_mode"), ("FLOAT", "base_eta"), ("FLOAT", "spread"),
                        ("FLOAT", "pixels_y")),
        fragment_out=outputs,
        defines=("SURFACE_WORLD",) if world else (),
    )

PIPELINE_SPECS = {  # the pipeline's own passes; each technique joins its own (techniques.register)
    "surface_world": _surface_spec(world=True),
    "surface_light": _surface_spec(world=False),
    "surface_composite": ShaderSpec(
        source="pipeline/surface_composite.glsl",
        vertex_in=(("VEC2", "corner"),),
        samplers=((0, "FLOAT_2D", "layer"), (1, "FLOAT_2D", "entry_map"), (2, "FLOAT_2D", "gbuffer_map")),
        push_constants=(("FLOAT", "offset"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "shadow_distance": ShaderSpec(
        source="pipeline/shadow_distance.glsl",
        vertex_in=(("VEC3", "pos"),),
        varyings=(("smooth", "VEC3", "v_world"),),
        uniform_blocks=((2, "LightData", "light"), (1, "ObjectData", "object")),
        push_constants=(("INT", "face"),),
        fragment_out=((0, "FLOAT", "out_distance"),),
    ),
    "base_lighting": ShaderSpec(
        source="pipeline/base_lighting.glsl",
        libraries=SHADOW_LIBS + ("common/world_spherical_harmonics.glsl", "common/angular_law.glsl",
                                 "common/oblique_entry.glsl"),
        vertex_in=SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_color"),
                  ("smooth", "VEC4", "v_paint"), ("smooth", "VEC3", "v_tint")) + CURVATURE_OUT,
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light"),
                        (3, "MaterialsData", "materials")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "near_lut")),
        push_constants=(("INT", "mode"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
    "ts_illumination": ShaderSpec(
        source="common/illumination_map.glsl",
        libraries=SHADOW_LIBS + ("common/world_spherical_harmonics.glsl", "common/oblique_entry.glsl"),
        vertex_in=(("VEC2", "texel"), ("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "facet"), ("FLOAT", "sky"),
                   ("VEC3", "curv_d"), ("VEC3", "curv_o")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_facet"),
                  ("smooth", "FLOAT", "v_sky")) + CURVATURE_OUT,
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light")),
        samplers=((0, "FLOAT_2D", "shadow_atlas"), (1, "FLOAT_2D", "cosine_table")),
        push_constants=(("INT", "mode"), ("FLOAT", "eta"), ("VEC3", "world_kernel"), ("VEC2", "atlas_size"),
                        ("VEC3", "entry")),
        fragment_out=((0, "VEC4", "out_irradiance"),),
    ),
    "env_background": ShaderSpec(
        source="pipeline/environment_background.glsl",
        libraries=("common/common.glsl", "common/cube_atlas.glsl"),
        vertex_in=(("VEC2", "corner"),),
        varyings=(("smooth", "VEC2", "v_ndc"),),
        uniform_blocks=((0, "FrameData", "frame"),),
        samplers=((0, "FLOAT_2D", "env_atlas"),),
        push_constants=(("INT", "env_res"),),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
}

resources.current().specs.update(PIPELINE_SPECS)


def __getattr__(name: str):
    """``SPECS``: the shader table (pass name -> spec) of the current GPU resources."""
    if name == "SPECS":
        return resources.current().specs
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    for define in spec.defines:
        info.define(define)
    source = "\n".join(read_source(lib) for lib in spec.libraries) + "\n" + read_source(spec.source)
    info.vertex_source(source)
    info.fragment_source(source)
    return info


def get(name: str):
    """The compiled shader for a pass, built on first use."""
    held = resources.current()
    shader = held.programs.get(name)
    if shader is None:
        import gpu

        shader = held.programs[name] = gpu.shader.create_from_info(create_info(name, held.specs[name]))
    return shader


class PassShader:
    """A pass's compiled shader with its inputs set in a way every backend takes.

    Blender 5.3 on OpenGL writes a sampler's binding slot into the shader's first push constant when
    ``uniform_sampler`` is called (measured: docs/gpu_backends.md), so a push constant set before a sampler was
    silently replaced (TEXTURE_SPACE's ``vertex_width`` read 6, the slot of its seventh sampler). Every pass sets
    its inputs and draws through this object: push constants are remembered, and set again before a draw that
    follows a sampler binding, so the order of the calls does not matter on any backend.
    """

    __slots__ = ("name", "shader", "_constants", "_stale")

    def __init__(self, name: str):
        self.name = name
        self.shader = get(name)
        self._constants = {}  # name: (setter, value) of the push constants set so far
        self._stale = False  # a sampler was bound since the push constants were last set

    def bind(self) -> PassShader:
        self.shader.bind()
        return self

    def uniform_block(self, name: str, ubo) -> None:
        self.shader.uniform_block(name, ubo)

    def uniform_sampler(self, name: str, texture) -> None:
        self.shader.uniform_sampler(name, texture)
        self._stale = bool(self._constants)

    def uniform_int(self, name: str, value) -> None:
        self._constants[name] = ("uniform_int", value)
        self.shader.uniform_int(name, value)

    def uniform_float(self, name: str, value) -> None:
        self._constants[name] = ("uniform_float", value)
        self.shader.uniform_float(name, value)

    def _restore_constants(self) -> None:
        if self._stale:
            for const, (setter, value) in self._constants.items():
                getattr(self.shader, setter)(const, value)
            self._stale = False

    def draw(self, batch) -> None:
        self._restore_constants()
        batch.draw(self.shader)

    def draw_instanced(self, batch, instance_count: int) -> None:
        self._restore_constants()
        batch.draw_instanced(self.shader, instance_start=0, instance_count=instance_count)


def pass_shader(name: str) -> PassShader:
    """The shader of a pass, to bind, set and draw with (``PassShader``); built on first use."""
    return PassShader(name)


def bind_lit(name: str, frame_ubo, light_ubo, shadow_atlas, mode: int) -> PassShader:
    """Bind a pass drawn in the world pass (mode 0) and each emitter's pass (mode 1) with what those
    passes share: the frame and light blocks, the shadow atlas and the mode. Returns the ``PassShader``."""
    shader = pass_shader(name).bind()
    shader.uniform_block("frame", frame_ubo)
    shader.uniform_block("light", light_ubo)
    shader.uniform_sampler("shadow_atlas", shadow_atlas)
    shader.uniform_int("mode", mode)
    return shader


def add_specs(specs: dict) -> None:
    """Join a technique's shader specs to the table (``techniques.register``); a name taken by another spec
    is refused."""
    table = resources.current().specs
    for name, spec in specs.items():
        if name in table and table[name] is not spec:
            raise ValueError(f"a shader named {name!r} is already registered")
        table[name] = spec


def remove_specs(names) -> None:
    """Drop specs and their compiled shaders (``techniques.unregister``)."""
    held = resources.current()
    for name in names:
        held.specs.pop(name, None)
        held.programs.pop(name, None)


def free_all() -> None:
    resources.current().programs.clear()

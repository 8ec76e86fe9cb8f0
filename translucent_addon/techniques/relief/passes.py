"""Height fields (Shah ch. 3): the GPU pass drawing meshes displaced per pixel by a height map.

Blender-facing (``gpu``). A mesh with a height field is left out of the base pass and drawn here in
the world pass (mode 0) and in each emitter's pass (mode 1), writing the depth of the displaced
surface, so it sorts with everything else. Shader: ``gpu_shaders/relief/height_field.glsl`` with the search
library ``relief/interval_search.glsl`` (NumPy twin: ``techniques/relief/model.py``).
"""
from __future__ import annotations

import hashlib

import numpy as np

from ...core.geometry.mesh_measures import uv_tangents
from ...core.properties import Prop
from ...gpu import resources, shaders
from ...gpu.frame_context import FrameContext
from ...gpu.targets import texture_from_array
from ..protocol import Technique
from . import model as relief_data

# The GLSL interface of this technique's passes (one file each in gpu_shaders/), joined to the
# shader table by the registry.
SHADER_SPECS = {
    "relief": shaders.ShaderSpec(
        source="relief/height_field.glsl",
        libraries=shaders.SHADOW_LIBS + ("relief/interval_search.glsl", "common/world_spherical_harmonics.glsl"),
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
}

def height_texture(surface):
    """The R32F texture of a height map, cached by its key (image name and content)."""
    textures = resources.current().cache("relief/heights")
    tex = textures.get(surface.key)
    if tex is None:
        if len(textures) > 16:
            textures.clear()
        tex = textures[surface.key] = texture_from_array(surface.height[..., None], "R32F")
    return tex


def clear_cache() -> None:
    resources.current().cache("relief/heights").clear()


def relief_block(surface, output: int) -> bytes:
    return np.array([surface.depth, surface.linear_steps, surface.iterations, float(output),
                     surface.mode, float(surface.shadows), 0.0, 0.0], np.float32).tobytes()


def _batch(pipeline, mesh):
    s = mesh.extras[TECHNIQUE.id]
    digest = hashlib.blake2b(s.uv.tobytes(), digest_size=8).hexdigest()
    key = ("relief", mesh.key, digest)
    batch = pipeline.targets.get(key)
    if batch is None:
        from gpu_extras.batch import batch_for_shader

        batch = pipeline.targets[key] = batch_for_shader(shaders.get("relief"), "TRIS", {
            "pos": np.ascontiguousarray(mesh.positions, np.float32),
            "nor": np.ascontiguousarray(mesh.normals, np.float32),
            "col": np.ascontiguousarray(mesh.colors, np.float32),
            "uv": np.ascontiguousarray(s.uv, np.float32),
            "tangent_u": np.ascontiguousarray(s.tangent_u, np.float32),
            "tangent_v": np.ascontiguousarray(s.tangent_v, np.float32),
        })
    return batch


def indices(frame) -> list[int]:
    """Meshes of the frame drawn by this pass instead of the base pass."""
    return [k for k, m in enumerate(frame.meshes) if m.extras.get(TECHNIQUE.id) is not None]


def draw(frame, which: list[int], pipeline, frame_ubo, objects, light_ubo, shadow_atlas, mode: int,
         output: int = 0) -> None:
    """Draw the height-field meshes into the bound target (the caller sets blending and depth writes)."""
    import gpu

    shader = shaders.bind_lit("relief", frame_ubo, light_ubo, shadow_atlas, mode)
    output = int(output)
    keep = []
    for k in which:
        mesh = frame.meshes[k]
        surface = mesh.extras[TECHNIQUE.id]
        ubo = gpu.types.GPUUniformBuf(relief_block(surface, output))
        keep.append(ubo)  # referenced until drawn
        shader.uniform_block("object", objects[k])
        shader.uniform_block("relief", ubo)
        shader.uniform_sampler("height_map", height_texture(surface))
        shader.draw(_batch(pipeline, mesh))


class Relief(Technique):
    """Shah ch. 3: meshes with a height field drawn by their own pass instead of the base, in the world pass
    and each emitter's, writing the displaced depth."""

    owns_surface = True  # the displaced surface is drawn by its own pass

    object_props = (
        Prop("relief", "EnumProperty", {
            "name": "Height field",
            "description": ("Displace the surface per pixel by a height map over the object's UVs: bumps hide and "
                            "shadow each other without extra geometry"),
            "items": (
                ("OFF", "Off", "No height field"),
                ("INTERVAL", "Interval mapping", "Even steps along the view ray, then refined between the last two: "
                                                 "sharper relief edges"),
                ("RELIEF", "Relief mapping", "Linear search, then binary search (Policarpo 2005), for comparison"),
            ),
            "default": "OFF",
        }),
        Prop("relief_image", "ImagePointer", {
            "name": "Height map",
            "description": "Image whose brightness is the height (white: the surface, black: the deepest point)",
        }),
        Prop("relief_depth", "FloatProperty", {
            "name": "Depth",
            "description": "How deep the black of the height map lies under the surface",
            "subtype": "DISTANCE",
            "unit": "LENGTH",
            "min": 0.0,
            "soft_max": 0.2,
            "default": 0.02,
        }),
        Prop("relief_linear_steps", "IntProperty", {
            "name": "Linear steps",
            "description": "Even steps along the view ray to find where it first enters the relief: more catches "
                           "thinner bumps, slower",
            "min": 2,
            "max": 64,
            "default": 8,
        }),
        Prop("relief_iterations", "IntProperty", {
            "name": "Refinements",
            "description": "Refinement steps after the even ones, at most: more gives smoother relief edges, slower",
            "min": 1,
            "max": 32,
            "default": 10,
        }),
        Prop("relief_shadows", "BoolProperty", {
            "name": "Self-shadowing",
            "description": "The height field shadows itself (a search toward each light)",
            "default": True,
        }),
    )
    scene_props = (
        Prop("relief_output", "IntProperty", {
            "name": "Height-field output",
            "description": ("Height-field pass output (tests, debugging): 0 colour, 1 hit uv, depth and refinement"
                            " count"),
            "min": 0,
            "max": 1,
            "default": 0,
            "options": {"HIDDEN"},
        }),
    )
    shader_specs = SHADER_SPECS
    id, label = "RELIEF", "Height field"
    description = "Per-pixel height fields by interval mapping (Shah 2007, ch. 3)"
    scene_properties = ("relief_output",)
    surface_properties = ("relief", "relief_image", "relief_depth", "relief_linear_steps", "relief_iterations",
                          "relief_shadows")

    def object_extras(self, reader) -> relief_data.ReliefSurface | None:
        """The height field displacing the object (Shah ch. 3), or None (with a line where it cannot be drawn)."""
        if reader.values(self.surface_properties[:1])["relief"] == "OFF":  # most objects: one read
            return None
        s = reader.values(self.surface_properties)
        if s["relief_image"] is None:
            reader.warn(f"'{reader.name}': height field has no height map; drawn flat")
            return None
        uv = reader.uv_corners()
        if uv is None:
            reader.warn(f"'{reader.name}': a height field needs a UV map; drawn flat")
            return None
        try:
            (height, digest), image_name = reader.image_data(s["relief_image"], relief_data.heights_of)
        except ValueError as err:
            reader.warn(f"'{reader.name}': {err}; drawn flat")
            return None
        du, dv = uv_tangents(reader.positions, uv)
        return relief_data.ReliefSurface(f"{image_name}:{digest}", height, float(s["relief_depth"]),
                                         0 if s["relief"] == "INTERVAL" else 1, int(s["relief_linear_steps"]),
                                         int(s["relief_iterations"]), bool(s["relief_shadows"]), uv, du, dv)

    def settings(self, values: dict) -> int:
        return int(values["relief_output"])

    def prepare(self, ctx: FrameContext):
        return indices(ctx.frame) or None

    def replaces_base(self, state) -> set[int]:
        return set(state)

    def world(self, ctx: FrameContext, state, light_ubo) -> None:
        draw(ctx.frame, state, ctx.resources, ctx.frame_ubo, ctx.objects, light_ubo, ctx.shadow_atlas, mode=0,
             output=ctx.frame.settings.of(self.id, 0))

    def emitter_surface(self, ctx: FrameContext, state, light_ubo) -> None:
        draw(ctx.frame, state, ctx.resources, ctx.frame_ubo, ctx.objects, light_ubo, ctx.shadow_atlas, mode=1,
             output=ctx.frame.settings.of(self.id, 0))

    def clear_caches(self) -> None:
        clear_cache()


TECHNIQUE = Relief()

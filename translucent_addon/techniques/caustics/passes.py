"""Caustics mapping (Shah ch. 5) in the pipeline: GPU passes per emitter, after its lighting pass.

Per emitter with caustics on (``Emitter.caustics``) and for every caster in the frame:

1. receiver positions from the light into a 3 x 2 atlas (cube faces for point lights, the
   orthographic map of the shadow pass for directional ones): ``caustic_receiver``;
2. the caster's positions and normals on its vertex grid, a projection from the light fitted to
   its bounding sphere (``model.caster_grid``), nearest and farthest surfaces:
   ``caustic_caster``;
3. per grid vertex: refraction through one or two surfaces (or a mirror), the intersection
   estimate against the back faces and the receivers, flux with Fresnel and Beer (Eq. 5.7):
   ``caustic_trace``;
4. Gaussian splats of that flux into the caustic atlas: ``caustic_splat``;
5. the receivers drawn by the base pass add rho / pi times the caustic irradiance:
   ``caustic_apply``.

Casters cast ordinary shadows in the shadow pass (glass is opaque to the shadow map, as to
Cycles' shadow rays); the light they pass on arrives as the caustic. Blender-facing (``gpu``).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.frame import FrameInputs, MeshInstance
from ...core.geometry.mesh_checks import check_mesh
from ...core.properties import Prop
from ...gpu import blocks, resources, shaders
from ...gpu.draw_state import draw_pass
from ...gpu.frame_context import FrameContext
from ...gpu.targets import cached_target, clear_target, read_pixels, screen_quad
from ..protocol import Technique
from .model import Caster, CausticError, CausticSettings, caster_grid

# The GLSL interface of this technique's passes (one file each in gpu_shaders/), joined to the
# shader table by the registry.
ID = "CAUSTICS"

SHADER_SPECS = {
    "caustic_receiver": shaders.ShaderSpec(
        source="caustics/receiver.glsl",
        vertex_in=(("VEC3", "pos"),),
        varyings=(("smooth", "VEC3", "v_world"),),
        uniform_blocks=((2, "LightData", "light"), (1, "ObjectData", "object")),
        push_constants=(("INT", "face"),),
        fragment_out=((0, "VEC4", "out_position"),),
    ),
    "caustic_caster": shaders.ShaderSpec(
        source="caustics/caster.glsl",
        vertex_in=(("VEC3", "pos"), ("VEC3", "nor")),
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal")),
        uniform_blocks=((1, "ObjectData", "object"), (4, "CausticData", "caustic")),
        fragment_out=((0, "VEC4", "out_position"), (1, "VEC4", "out_normal")),
    ),
    "caustic_trace": shaders.ShaderSpec(
        source="caustics/trace.glsl",
        libraries=shaders.SHADOW_LIBS + ("caustics/atlas_lookup.glsl",),
        vertex_in=(("VEC2", "corner"),),
        uniform_blocks=((2, "LightData", "light"), (4, "CausticData", "caustic")),
        samplers=((0, "FLOAT_2D", "front_position"), (1, "FLOAT_2D", "front_normal"),
                  (2, "FLOAT_2D", "back_position"), (3, "FLOAT_2D", "back_normal"),
                  (4, "FLOAT_2D", "receiver_atlas"), (5, "FLOAT_2D", "shadow_atlas")),
        fragment_out=((0, "VEC4", "out_landing"), (1, "VEC4", "out_flux")),
    ),
    "caustic_splat": shaders.ShaderSpec(
        source="caustics/splat.glsl",
        libraries=shaders.LIGHT_LIBS + ("caustics/atlas_lookup.glsl",),
        vertex_in=(("VEC2", "corner"),),
        varyings=(("flat", "VEC3", "v_flux"), ("flat", "VEC2", "v_centre"), ("flat", "FLOAT", "v_sigma"),
                  ("flat", "VEC2", "v_tile")),
        uniform_blocks=((2, "LightData", "light"), (4, "CausticData", "caustic")),
        samplers=((0, "FLOAT_2D", "trace_landing"), (1, "FLOAT_2D", "trace_flux")),
        fragment_out=((0, "VEC4", "out_flux"),),
    ),
    "caustic_apply": shaders.ShaderSpec(
        source="caustics/apply.glsl",
        libraries=shaders.LIGHT_LIBS + ("caustics/atlas_lookup.glsl",),
        vertex_in=shaders.SURFACE_IN,
        varyings=(("smooth", "VEC3", "v_world"), ("smooth", "VEC3", "v_normal"), ("smooth", "VEC3", "v_color")),
        uniform_blocks=((0, "FrameData", "frame"), (1, "ObjectData", "object"), (2, "LightData", "light"),
                        (4, "CausticData", "caustic")),
        samplers=((0, "FLOAT_2D", "caustic_atlas"), (1, "FLOAT_2D", "receiver_atlas")),
        fragment_out=((0, "VEC4", "out_color"),),
    ),
}


@dataclasses.dataclass
class Plan:
    """What the caustic passes draw this frame."""

    settings: CausticSettings
    casters: list  # (mesh index, MeshInstance, world centre, radius)
    receivers: list  # mesh indices drawn into the receiver atlas (every mesh that is not a caster)
    lit: list  # mesh indices that add the caustic (receivers drawn by the base pass)


def bounding_sphere(mesh: MeshInstance) -> tuple[np.ndarray, float]:
    p = mesh.world_positions()
    lo, hi = p.min(axis=0), p.max(axis=0)
    centre = 0.5 * (lo + hi)
    return centre, float(np.linalg.norm(p - centre, axis=1).max())


def is_closed(mesh: MeshInstance) -> bool:
    """Whether the mesh (corners welded by position) is a closed manifold; cached per geometry key."""
    known = resources.current().cache("caustics/closed")
    closed = known.get(mesh.key)
    if closed is None:
        vertices, triangles = np.unique(mesh.positions, axis=0, return_inverse=True)
        closed = known[mesh.key] = check_mesh(vertices, triangles.reshape(-1, 3)).closed_manifold
        if len(known) > 256:
            known.clear()
    return closed


def caster_of(mesh: MeshInstance) -> Caster | None:
    """The mesh's caustics caster (its ``extras``), or None: a receiver."""
    return mesh.extras.get(ID)


def prepare(frame: FrameInputs) -> Plan | None:
    casters = []
    for k, m in enumerate(frame.meshes):
        caster = caster_of(m)
        if caster is None:
            continue
        if caster.mode == "REFRACTIVE" and caster.surfaces == 2 and not is_closed(m):
            frame.warnings.append(f"'{m.name}': an open mesh has no back faces to refract out of; its caustics "
                                  "use one surface (set Surfaces to One, or close the mesh)")
            m = dataclasses.replace(m, extras={**m.extras, ID: dataclasses.replace(caster, surfaces=1)})
        casters.append((k, m, *bounding_sphere(m)))
    if not casters or not any(e.caustics for e in frame.emitters):
        return None
    receivers = [k for k, m in enumerate(frame.meshes) if caster_of(m) is None]
    lit = [k for k in receivers if frame.meshes[k].method == "OFF"]
    return Plan(frame.settings.of(ID) or CausticSettings(), casters, receivers, lit)


def _target(pipeline, name: str, size, depth: bool = False, attachments: int = 1):
    return cached_target(pipeline, name, size, depth, attachments)


def _batch(pipeline, shader_name: str, mesh: MeshInstance, with_normals: bool):
    key = (shader_name, mesh.key)
    batch = pipeline.targets.get(key)
    if batch is None:
        from gpu_extras.batch import batch_for_shader

        attrs = {"pos": np.ascontiguousarray(mesh.positions, np.float32)}
        if with_normals:
            attrs["nor"] = np.ascontiguousarray(mesh.normals, np.float32)
        batch = pipeline.targets[key] = batch_for_shader(shaders.get(shader_name), "TRIS", attrs)
    return batch


def _capture(pipeline, name: str, fb, size, slot: int = 0) -> None:
    if pipeline.capture is not None:

        pipeline.capture.setdefault(name, []).append(read_pixels(fb, size[0], size[1], slot))


def draw_emitter(plan: Plan, frame: FrameInputs, e, light_ubo, batches, objects, frame_ubo, fb, pipeline,
                 shadow_atlas) -> None:
    """The caustics of every caster under one emitter, added to the bound target ``fb``; ``shadow_atlas``
    (this emitter's, from the shadow pass) drops grid vertices that another object hides from the light."""
    N = int(plan.settings.texels)
    atlas_size = (3 * N, 2 * N)
    recv_tex = _draw_receivers(plan, frame, e, light_ubo, objects, pipeline, N, atlas_size)
    flux_fb, (flux_tex,), _ = _target(pipeline, "caustic_flux", atlas_size)
    with flux_fb.bind():
        clear_target(flux_fb, (0.0, 0.0, 0.0, 0.0), depth=None)
    keep_alive = _draw_casters(plan, frame, e, light_ubo, objects, pipeline, shadow_atlas, recv_tex, flux_fb,
                               atlas_size)
    _capture(pipeline, "caustic_flux", flux_fb, atlas_size)
    if not keep_alive or not plan.lit:
        return
    _apply_caustic(plan, light_ubo, batches, objects, frame_ubo, fb, keep_alive[0], flux_tex, recv_tex)


def _draw_receivers(plan: Plan, frame: FrameInputs, e, light_ubo, objects, pipeline, N: int, atlas_size):
    """Step 1: receiver positions from the light, an N x N tile per face; returns the atlas the trace reads."""
    import gpu

    # 1. Receiver positions from the light.
    recv_fb, (recv_tex,), _recv_depth = _target(pipeline, "caustic_receivers", atlas_size, depth=True)
    shader = shaders.pass_shader("caustic_receiver")
    n_faces = 6 if e.kind else 1
    with draw_pass(recv_fb, depth_test="LESS_EQUAL", depth_write=True):
        clear_target(recv_fb, (0.0, 0.0, 0.0, 0.0))
        shader.bind()
        shader.uniform_block("light", light_ubo)
        for face in range(n_faces):
            gpu.state.viewport_set((face % 3) * N, (face // 3) * N, N, N)
            shader.uniform_int("face", face)
            for k in plan.receivers:
                shader.uniform_block("object", objects[k])
                shader.draw(_batch(pipeline, "caustic_receiver", frame.meshes[k], False))
    _capture(pipeline, "caustic_receivers", recv_fb, atlas_size)
    return recv_tex


def _draw_casters(plan: Plan, frame: FrameInputs, e, light_ubo, objects, pipeline, shadow_atlas, recv_tex, flux_fb,
                  atlas_size) -> list:
    """Steps 2 to 4 per caster, splatted into ``flux_fb``; returns the caustic blocks, kept alive until drawn."""
    import gpu

    s = plan.settings
    G = int(s.grid)
    caster_shader = shaders.pass_shader("caustic_caster")
    trace_shader = shaders.pass_shader("caustic_trace")
    splat_shader = shaders.pass_shader("caustic_splat")
    keep_alive = []
    for k, mesh, centre, radius in plan.casters:
        try:
            grid = caster_grid(e, centre, radius, G)
        except CausticError as exc:
            frame.warnings.append(f"'{mesh.name}': {exc}")
            continue
        ubo = gpu.types.GPUUniformBuf(blocks.caustic_block(grid.view_proj, G, grid.half_extent, caster_of(mesh), s))
        keep_alive.append(ubo)
        maps = _draw_caster_maps(caster_shader, ubo, objects[k], mesh, G, pipeline)
        landing_tex, trace_flux_tex, trace_size = _draw_trace(trace_shader, light_ubo, ubo, maps, recv_tex,
                                                              shadow_atlas, mesh, G, pipeline)
        _draw_splats(splat_shader, light_ubo, ubo, landing_tex, trace_flux_tex, trace_size, flux_fb, atlas_size,
                     pipeline)
    return keep_alive


def _draw_caster_maps(caster_shader, ubo, object_ubo, mesh: MeshInstance, G: int, pipeline) -> list:
    """Step 2: the caster's front and back surfaces on its G x G grid; returns their (position, normal) textures."""
    import gpu

    # 2. The caster on its grid: nearest (front) and farthest (back) surfaces.
    maps = []
    for name, depth_clear, test in (("caustic_front", 1.0, "LESS_EQUAL"), ("caustic_back", 0.0, "GREATER_EQUAL")):
        grid_fb, textures, _depth = _target(pipeline, name, (G, G), depth=True, attachments=2)
        with draw_pass(grid_fb, depth_test=test, depth_write=True):
            clear_target(grid_fb, (0.0, 0.0, 0.0, 0.0), depth=depth_clear)
            gpu.state.viewport_set(0, 0, G, G)
            caster_shader.bind()
            caster_shader.uniform_block("caustic", ubo)
            caster_shader.uniform_block("object", object_ubo)
            caster_shader.draw(_batch(pipeline, "caustic_caster", mesh, True))
        maps.append(textures)
        _capture(pipeline, name + "_position", grid_fb, (G, G), 0)
        _capture(pipeline, name + "_normal", grid_fb, (G, G), 1)
    return maps


def _draw_trace(trace_shader, light_ubo, ubo, maps, recv_tex, shadow_atlas, mesh: MeshInstance, G: int, pipeline):
    """Step 3: refract (or mirror) and estimate each grid vertex's landing; returns (landing, flux, trace size)."""
    import gpu

    # 3. Refract and estimate the landing points.
    caster = caster_of(mesh)
    channels = 3 if (caster.dispersion > 0 and caster.mode != "REFLECTIVE") else 1
    trace_size = (G * channels, G)
    trace_fb, (landing_tex, trace_flux_tex), _ = _target(pipeline, "caustic_trace", trace_size, attachments=2)
    with draw_pass(trace_fb):
        gpu.state.viewport_set(0, 0, *trace_size)
        trace_shader.bind()
        trace_shader.uniform_block("light", light_ubo)
        trace_shader.uniform_block("caustic", ubo)
        trace_shader.uniform_sampler("front_position", maps[0][0])
        trace_shader.uniform_sampler("front_normal", maps[0][1])
        trace_shader.uniform_sampler("back_position", maps[1][0])
        trace_shader.uniform_sampler("back_normal", maps[1][1])
        trace_shader.uniform_sampler("receiver_atlas", recv_tex)
        trace_shader.uniform_sampler("shadow_atlas", shadow_atlas)
        trace_shader.draw(screen_quad(pipeline, "caustic_trace"))
    _capture(pipeline, "caustic_landing", trace_fb, trace_size, 0)
    _capture(pipeline, "caustic_trace_flux", trace_fb, trace_size, 1)
    return landing_tex, trace_flux_tex, trace_size


def _draw_splats(splat_shader, light_ubo, ubo, landing_tex, trace_flux_tex, trace_size, flux_fb, atlas_size,
                 pipeline) -> None:
    """Step 4: one Gaussian splat per traced vertex and channel, added into the caustic atlas ``flux_fb``."""
    import gpu

    # 4. Splat into the caustic atlas.
    with draw_pass(flux_fb, blend="ADDITIVE_PREMULT"):
        gpu.state.viewport_set(0, 0, *atlas_size)
        splat_shader.bind()
        splat_shader.uniform_block("light", light_ubo)
        splat_shader.uniform_block("caustic", ubo)
        splat_shader.uniform_sampler("trace_landing", landing_tex)
        splat_shader.uniform_sampler("trace_flux", trace_flux_tex)
        splat_shader.draw_instanced(screen_quad(pipeline, "caustic_splat"), trace_size[0] * trace_size[1])


def _apply_caustic(plan: Plan, light_ubo, batches, objects, frame_ubo, fb, caustic_ubo, flux_tex, recv_tex) -> None:
    """Step 5: the receivers drawn by the base pass add rho / pi times the caustic irradiance into ``fb``."""
    # 5. Receivers add the caustic.
    apply = shaders.pass_shader("caustic_apply")
    with draw_pass(fb, blend="ADDITIVE_PREMULT", depth_test="LESS_EQUAL"):
        apply.bind()
        apply.uniform_block("frame", frame_ubo)
        apply.uniform_block("light", light_ubo)
        apply.uniform_block("caustic", caustic_ubo)  # only its settings are read
        apply.uniform_sampler("caustic_atlas", flux_tex)
        apply.uniform_sampler("receiver_atlas", recv_tex)
        for k in plan.lit:
            apply.uniform_block("object", objects[k])
            apply.draw(batches[k][0])


class Caustics(Technique):
    """Shah ch. 5: after each emitter's lighting, the light its casters refract or mirror onto the
    receivers; its shadow maps cover the scene sphere, not a fitted spot cone."""

    object_props = (
        Prop("caustics_caster", "EnumProperty", {
            "name": "Caustics",
            "description": ("Throw caustics onto the other objects: every light with caustics on is bent or mirrored "
                            "by this object; it still casts its shadow"),
            "items": (
                ("NONE", "None", "Not a caustics caster (other casters' caustics land on it)"),
                ("REFRACTIVE", "Refractive", "Glass, water: light refracts through the surface"),
                ("REFLECTIVE", "Reflective", "Metal: light is mirrored off the surface"),
            ),
            "default": "NONE",
        }),
        Prop("caustics_ior", "FloatProperty", {
            "name": "Caustics IOR",
            "description": "Index of refraction of a refractive caster",
            "min": 1.0,
            "max": 3.0,
            "default": 1.5,
        }),
        Prop("caustics_surfaces", "EnumProperty", {
            "name": "Surfaces",
            "description": ("Refraction at one surface (a water surface over the receivers) or at two (a solid: in"
                            " and out, through the back faces)"),
            "items": (
                ("ONE", "One", "One refraction: the light stays in the medium down to the receiver"),
                ("TWO", "Two", "In through the front and out through the back faces (Wyman 2005)"),
            ),
            "default": "TWO",
        }),
        Prop("caustics_color", "FloatVectorProperty", {
            "name": "Caustics colour",
            "description": ("Refractive: the colour light takes after travelling Colour distance through the object; "
                            "reflective: the mirror's colour"),
            "subtype": "COLOR",
            "size": 3,
            "min": 0.0,
            "max": 1.0,
            "default": (1.0, 1.0, 1.0),
        }),
        Prop("caustics_distance", "FloatProperty", {
            "name": "Colour distance",
            "description": "Distance through the medium at which light has the caustics colour",
            "subtype": "DISTANCE",
            "unit": "LENGTH",
            "min": 1e-6,
            "soft_max": 1.0,
            "default": 0.05,
        }),
        Prop("caustics_dispersion", "FloatProperty", {
            "name": "Dispersion",
            "description": ("Spread of the index of refraction over the colour channels, splitting caustics into "
                            "colours (red bends least, blue most); 0 uses one index"),
            "min": 0.0,
            "max": 0.2,
            "default": 0.0,
            "precision": 3,
        }),
    )
    light_props = (
        Prop("caustics", "BoolProperty", {
            "name": "Caustics",
            "description": "Caustics casters refract or mirror this light (Translucent)",
            "default": True,
        }),
    )
    scene_props = (
        Prop("caustics_grid", "IntProperty", {
            "name": "Caustics grid",
            "description": ("Rays per side traced from each light through each caster: more fills caustics without "
                            "gaps, slower (64 can leave gaps)"),
            "min": 8,
            "max": 1024,
            "default": 128,
        }),
        Prop("caustics_iterations", "IntProperty", {
            "name": "Iterations",
            # Shah 5.3.4: one for a flat floor, about five on rugged receivers; light leaving a ball near its
            # rim needs 4 with Secant.
            "description": ("Look-ups of the intersection estimate through the caster's back faces and onto the "
                            "receivers: more for rugged receivers"),
            "min": 1,
            "max": 16,
            "default": 4,
        }),
        Prop("caustics_guard", "BoolProperty", {
            "name": "Oscillation guard",
            "description": "Once two guesses of where a caustic ray lands lie on either side of the surface, halve "
                           "between them: fewer stray spots",
            "default": True,
        }),
        Prop("caustics_estimator", "EnumProperty", {
            "name": "Estimator",
            "description": "How each caustic ray's landing point is found",
            "items": (
                ("SECANT", "Secant", "Refine through the last two guesses: fewer look-ups where rays meet the surface "
                                     "at a glancing angle"),
                ("SHAH", "Fixed step", "The same fixed step every time: simpler, slower at glancing angles"),
            ),
            "default": "SECANT",
        }),
        Prop("caustics_map", "IntProperty", {
            "name": "Caustic map",
            "description": "Texels per face of the caustic and receiver maps",
            "min": 64,
            "max": 4096,
            "default": 1024,
        }),
        Prop("caustics_splat", "FloatProperty", {
            "name": "Splat width",
            "description": "Gaussian splat sigma in caustic-map texels (the smallest one with adaptive splats)",
            "min": 0.5,
            "max": 16.0,
            "default": 1.0,
        }),
        Prop("caustics_adaptive", "BoolProperty", {
            "name": "Adaptive splats",
            "description": ("Widen each splat to the spacing of its neighbours' landing points: no gaps at coarse "
                            "grids, sharp where light converges"),
            "default": True,
        }),
    )
    shader_specs = SHADER_SPECS
    id, label = ID, "Caustics"
    scene_properties = ("caustics_grid", "caustics_iterations", "caustics_guard", "caustics_estimator",
                        "caustics_map", "caustics_splat", "caustics_adaptive")
    caster_properties = ("caustics_caster", "caustics_ior", "caustics_surfaces", "caustics_color",
                         "caustics_distance", "caustics_dispersion")

    def settings(self, values: dict) -> CausticSettings:
        return CausticSettings(grid=int(values["caustics_grid"]), iterations=int(values["caustics_iterations"]),
                               guard=bool(values["caustics_guard"]), secant=values["caustics_estimator"] == "SECANT",
                               texels=int(values["caustics_map"]), splat_sigma=float(values["caustics_splat"]),
                               adaptive=bool(values["caustics_adaptive"]))

    def object_extras(self, reader) -> Caster | None:
        """The object as a caustics caster, from its settings (``Object.translucent``), or None."""
        if reader.values(self.caster_properties[:1])["caustics_caster"] == "NONE":  # most objects: one read
            return None
        s = reader.values(self.caster_properties)
        color = np.clip(np.asarray(s["caustics_color"], np.float64), 1e-6, 1.0)
        if s["caustics_caster"] == "REFLECTIVE":
            return Caster("REFLECTIVE", float(s["caustics_ior"]), 0, (0.0, 0.0, 0.0), 0.0, tuple(color))
        # Absorption K_a per scene unit from the colour reached after caustics_distance (scene units, Eq. 5.7).
        sigma_a = -np.log(color) / float(s["caustics_distance"])
        return Caster("REFRACTIVE", float(s["caustics_ior"]), 1 if s["caustics_surfaces"] == "ONE" else 2,
                      tuple(float(x) for x in sigma_a), float(s["caustics_dispersion"]))
    description = "Refractive and reflective caustics by caustic mapping (Shah 2007, ch. 5)"
    emitter_timing = "caustics"
    scene_tiers = {"DRAFT": {"caustics_grid": 64, "caustics_map": 512},
                   "STANDARD": {"caustics_grid": 128, "caustics_map": 1024},
                   "HIGH": {"caustics_grid": 256, "caustics_map": 2048}}
    scene_panel = (("caustics_grid", "caustics_estimator", "caustics_iterations", "caustics_guard", "caustics_map",
                    "caustics_splat", "caustics_adaptive"),)

    def prepare(self, ctx: FrameContext):
        return prepare(ctx.frame)

    def unfitted_shadow(self, state, emitter) -> bool:
        return bool(emitter.caustics)

    def clear_caches(self) -> None:
        resources.current().cache("caustics/closed").clear()

    def emitter(self, ctx: FrameContext, state, emitter, light_ubo) -> None:
        if emitter.caustics:
            draw_emitter(state, ctx.frame, emitter, light_ubo, ctx.batches, ctx.objects, ctx.frame_ubo, ctx.target,
                         ctx.resources, ctx.shadow_atlas)


TECHNIQUE = Caustics()

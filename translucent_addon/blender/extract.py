"""Blender scene -> FrameInputs: the one bpy-facing step of rendering.

Bulk ``foreach_get`` into NumPy, no per-vertex Python loops. Meshes come from
the evaluated depsgraph (modifiers applied), instances included.
"""
from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable

import numpy as np

from .. import techniques
from ..core.frame import (
    NEUTRAL_PAINT,
    BakeHandle,
    CameraView,
    Environment,
    FrameInputs,
    Lost,
    Medium,
    MeshInstance,
)
from ..core.geometry.orientation import outward_normals, turned
from ..core.lights import emitters_from_light, unnormalized_power
from ..core.physics.lut import BLUR_MIN, layer_problem
from ..core.physics.microfacet import f0_of
from ..core.physics.presets import CoefficientError, validate_coefficients
from ..core.surface import Surface, surface_of
from ..techniques import registry as bake_registry
from ..techniques.grass import bake as grass_btf
from . import bake_files, material_surface, medium_source, mesh_read
from .bake_inputs import bake_status, homogeneous_profile, technique_values
from .images import image_data, image_stamp
from .mesh_read import BLUR_GROUP, GLOW_GROUP, MASK_GROUP, PAINT_GROUPS
from .props import bounded
from .session import Session
from .session import current as current_session

TINT_ATTRIBUTE = "translucent_tint"  # Vertex Paint (colour attribute): RGB irradiance modulation

DEFAULT_COLOR = (0.8, 0.8, 0.8)  # Blender's default surface colour


def material_base_color(mat) -> tuple[float, float, float]:
    """Linear base colour: the Principled/Diffuse node feeding the output, else the viewport colour."""
    if mat is None:
        return DEFAULT_COLOR
    node = material_surface.surface_node(mat)
    if node is not None:
        for name in ("Base Color", "Color"):
            sock = node.inputs.get(name)
            if sock is not None and not sock.is_linked and hasattr(sock, "default_value"):
                return tuple(float(c) for c in sock.default_value[:3])
    return tuple(float(c) for c in mat.diffuse_color[:3])


def world_color(scene, env: Environment | None = None) -> np.ndarray:
    """The world's uniform radiance; for an environment image (``world_environment``), its average over
    the sphere."""
    world = scene.world
    if world is None:
        return np.zeros(3)
    if env is not None:
        return env.mean
    tree = getattr(world, "node_tree", None)
    if tree is not None:
        bg = next((n for n in tree.nodes if n.type == "BACKGROUND"), None)
        if bg is not None and not bg.inputs["Color"].is_linked:
            return np.array(bg.inputs["Color"].default_value[:3]) * float(bg.inputs["Strength"].default_value)
    return np.array(world.color[:3], dtype=np.float64)


def world_environment(scene, session: Session | None = None) -> Environment | None:
    """The world's Environment Texture (equirectangular) feeding its Background, as linear radiance
    times the strength; None for any other world. Read once per image and strength (every frame while the image
    is dirty: painted, or set from a script), kept on ``session`` (None: the extension's)."""
    session = session or current_session()
    world = scene.world
    tree = getattr(world, "node_tree", None) if world is not None else None
    if tree is None:
        return None
    bg = next((n for n in tree.nodes if n.type == "BACKGROUND"), None)
    if bg is None or not bg.inputs["Color"].is_linked:
        return None
    node = bg.inputs["Color"].links[0].from_node
    if node.type != "TEX_ENVIRONMENT" or node.image is None or node.projection != "EQUIRECTANGULAR":
        return None
    img = node.image
    w, h = img.size
    if w == 0 or h == 0:
        return None
    strength = float(bg.inputs["Strength"].default_value)
    key = (image_stamp(img), strength, img.colorspace_settings.name)
    env = session.environment.get(key)
    if env is None or img.is_dirty:  # an image painted or set from a script is read again every frame
        px = np.empty(w * h * img.channels, np.float32)
        img.pixels.foreach_get(px)
        rgb = px.reshape(h, w, img.channels)[..., :3].copy()
        if not img.is_float and img.colorspace_settings.name == "sRGB":
            rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4).astype(np.float32)
        rgb *= strength
        # The GPU textures and the SH projection are cached on the key: it names the pixels, not the image.
        digest = hashlib.blake2b(rgb.tobytes(), digest_size=12).hexdigest()
        if env is None or env.key != digest:
            env = Environment(key=digest, image=rgb, mean=equirect_mean(rgb))
        session.environment.clear()
        session.environment[key] = env
    return env


def equirect_mean(image: np.ndarray) -> np.ndarray:
    """Solid-angle-weighted mean of an equirectangular image (rows weighted by cos latitude)."""
    h = image.shape[0]
    lat = (np.arange(h) + 0.5) / h * np.pi - np.pi / 2
    w = np.cos(lat)[:, None, None]
    return (image * w).sum(axis=(0, 1)) / (w.sum() * image.shape[1])


def vertex_group_weights(ob, mesh, names) -> dict[str, np.ndarray]:
    """Weights (V,) of the named vertex groups that exist on the object.

    Blender has no bulk access to deform weights, so this loops over vertices once, and only for
    objects that have one of the groups.
    """
    index = {vg.index: vg.name for vg in ob.vertex_groups if vg.name in names}
    if not index:
        return {}
    weights = {name: np.zeros(len(mesh.vertices), np.float32) for name in index.values()}
    for v in mesh.vertices:
        for g in v.groups:
            name = index.get(g.group)
            if name is not None:
                weights[name][v.index] = g.weight
    return weights


def paint_sources(ob, mesh) -> tuple[dict[str, np.ndarray], tuple[np.ndarray, str] | None]:
    """What the painted layers hold: the weights of the paint groups present and the tint attribute's colours
    (RGBA per element, its domain), or None."""
    weights = vertex_group_weights(ob, mesh, PAINT_GROUPS)
    tint_attr = mesh.color_attributes.get(TINT_ATTRIBUTE)
    tint = None
    if tint_attr is not None:
        rgba = np.empty(len(tint_attr.data) * 4, np.float32)
        tint_attr.data.foreach_get("color", rgba)
        tint = (rgba.reshape(-1, 4), tint_attr.domain)
    return weights, tint


def paint_arrays(weights, tint_source, tri_loops, loop_vert):
    """(paint (3T, 4), tint (3T, 3)) per corner from the painted layers (``paint_sources``), or (None, None)
    when unpainted."""
    if not weights and tint_source is None:
        return None, None
    corner_vert = loop_vert[tri_loops]
    n = len(tri_loops)
    paint = np.ones((n, 4), np.float32)
    paint[:, 3] = 0.0
    if MASK_GROUP in weights:
        paint[:, 0] = weights[MASK_GROUP][corner_vert]
    if BLUR_GROUP in weights:
        paint[:, 1] = 1.0 / (1.0 + (1.0 / BLUR_MIN - 1.0) * weights[BLUR_GROUP][corner_vert])
    if GLOW_GROUP in weights:
        paint[:, 2] = 1.0 + 3.0 * weights[GLOW_GROUP][corner_vert]
    tint = np.ones((n, 3), np.float32)
    if tint_source is not None:
        rgba, domain = tint_source
        tint = rgba[corner_vert if domain == "POINT" else tri_loops, :3]
    return paint, tint


def grass_status(ob) -> tuple[str, str | None]:
    """('OK' | 'STALE' | 'MISSING' | 'INVALID', hash or the settings' error) of an object's grass BTF."""
    digest, why = grass_btf.settings_digest(technique_values(ob.translucent, grass_btf.SETTINGS))
    if digest is None:
        return "INVALID", why
    return bake_files.status(ob, grass_btf.BAKE_KEY, digest), digest


class ObjectReader:
    """What a technique's ``object_extras`` may read of one drawn object (``Technique.object_extras``): its
    settings, its drawn corners, its UVs (its mesh opened only when asked), images and stored bakes; the lines
    it writes join the frame's warnings."""

    def __init__(self, ob, drawn: DrawnMesh, mesh, frame_warnings: list, session: Session):
        self._ob, self._drawn, self._mesh, self._warnings, self._session = ob, drawn, mesh, frame_warnings, session
        self.name = ob.original.name
        self.positions = drawn.positions

    def values(self, names) -> dict:
        """The object's Object.translucent values (integers within their ranges)."""
        return technique_values(self._ob.original.translucent, names)

    def warn(self, text: str) -> None:
        self._warnings.append(text)

    def uv_corners(self) -> np.ndarray | None:
        """(3T, 2) the active UV map at each drawn corner, or None when the mesh has none."""
        if self._mesh is not None:
            return _uv_corners(self._mesh, self._drawn.tri_loops)
        mesh = self._ob.to_mesh()
        try:
            return _uv_corners(mesh, self._drawn.tri_loops)
        finally:
            self._ob.to_mesh_clear()

    def image_data(self, image, derive):
        """``extract.image_data`` on this frame's session."""
        return image_data(image, derive, self._session)

    def stored_bake(self, key: str, digest: str) -> tuple[str, BakeHandle | None]:
        """(status, handle) of the object's stored bake under ``key`` for inputs ``digest``: a handle (loading
        (arrays, meta)) only when it is current ('OK')."""
        original = self._ob.original
        status = bake_files.status(original, key, digest)
        if status != "OK":
            return status, None

        def load(o=original):
            record = bake_files.read(o, key)
            return record.arrays, record.meta

        return status, BakeHandle(bake_files.source_key(original, key), load, owner=f"{self.name}/{key.lower()}")


def _uv_maps(mesh, tri_loops: np.ndarray, names) -> dict:
    """name -> (3T, 2) the UV map at each drawn corner, for the names asked ("": the active render map); a name
    the mesh lacks is absent."""
    out = {}
    for name in names:
        layer = material_surface.render_uv_layer(mesh) if name == "" else mesh.uv_layers.get(name)
        if layer is None:
            continue
        uv = np.empty(len(mesh.loops) * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        out[name] = uv.reshape(-1, 2)[tri_loops]
    return out


def surface_for(ob, drawn: DrawnMesh, mesh, medium: Medium | None, frame_warnings, session: Session,
                source: str = "PRINCIPLED") -> Surface:
    """The object's ``Surface`` (colour textures, gloss, normal maps of its slots), made again only when its
    mesh, its materials' values or images or its medium's reference colour changed. ``source``: where the medium
    comes from (``medium_source.ObjectMedium.source``)."""
    original = ob.original
    slots = material_surface.slot_surfaces(ob, lambda image: material_surface.read_image(image, session))
    own_boundary = medium is not None and source != "PRINCIPLED"
    if own_boundary:
        # Coefficients set on the object or the material, not a Principled BSDF's: the medium's own smooth boundary
        # (as Compare's Cycles twin draws it), whatever gloss the material's nodes ask.
        specular = f0_of(float(medium.eta)) > 0.0
        slots = [dataclasses.replace(s, roughness=0.0, ior=float(medium.eta), ior_level=0.5, specular=specular)
                 for s in slots]
    medium_slot = next((k for k, s in enumerate(ob.material_slots) if s.material is not None), 0)
    reference = tuple(map(float, drawn.palette[min(medium_slot, len(drawn.palette) - 1)]))
    eta = None if medium is None else float(medium.eta)
    made_of = (drawn.key, tuple(slots), eta, reference if eta is not None else None)
    cache_key = drawn.key.split("#")[0]  # the object's, or the mesh's that its linked duplicates share
    known = session.surfaces.get(cache_key)
    if known is not None and known[0] == made_of:
        surface = known[1]
    else:
        names = {ref.uv_map for s in slots for ref in (s.color_map, s.normal_map) if ref is not None}
        opened = mesh is None and bool(names)
        if opened:
            mesh = ob.to_mesh()
        try:
            uv_maps = _uv_maps(mesh, drawn.tri_loops, names) if names else {}
        finally:
            if opened:
                ob.to_mesh_clear()
        read = drawn.read
        surface = surface_of(slots, drawn.palette, read.material_index, uv_maps, drawn.positions, drawn.normals,
                             read.corner_vert[drawn.tri_loops], eta=eta, reference=reference,
                             key=f"{drawn.key}/{hash(made_of) & 0xFFFFFFFF:08x}")
        if own_boundary:  # the medium's reflection belongs to its subsurface look: where painted opaque, none
            surface.gloss[:, 3] *= drawn.paint[:, 0]
        session.surfaces[cache_key] = (made_of, surface)
    for note in surface.notes:
        frame_warnings.append(f"'{original.name}': {note}")
    return surface


def _uv_corners(mesh, tri_loops: np.ndarray) -> np.ndarray | None:
    if mesh is None or mesh.uv_layers.active is None:
        return None
    uv_loops = np.empty(len(mesh.loops) * 2, np.float32)
    mesh.uv_layers.active.data.foreach_get("uv", uv_loops)
    return uv_loops.reshape(-1, 2)[tri_loops]


def object_extras(ob, drawn: DrawnMesh, mesh, frame_warnings, session: Session) -> dict:
    """What each registered technique draws of the object whatever its method (``Technique.object_extras``)."""
    reader = ObjectReader(ob, drawn, mesh, frame_warnings, session)
    extras = {}
    for technique in techniques.REGISTRY:
        data = technique.object_extras(reader)
        if data is not None:
            extras[technique.id] = data
    return extras


def turn_outward(flip: np.ndarray, positions: np.ndarray, normals: np.ndarray, tri_loops: np.ndarray):
    """Corner arrays with the flipped triangles turned (corners 0, 2, 1) and their normals to the new outside
    (negated where they point against the turned facet; custom normals that already point out are kept)."""
    corners = turned(flip, positions.reshape(-1, 3, 3))
    normals = outward_normals(corners, turned(flip, normals.reshape(-1, 3, 3)), flip)
    return (corners.reshape(-1, 3), normals.reshape(-1, 3).astype(np.float32),
            turned(flip, tri_loops.reshape(-1, 3)).ravel())


@dataclasses.dataclass(eq=False)
class DrawnMesh:
    """An object's corner arrays as every frame draws them (turned outward, coloured, painted), kept while what
    they are made of is unchanged: a frame that finds it again uploads nothing (its ``key`` is unchanged)."""

    read: mesh_read.MeshRead
    palette: np.ndarray  # (slots, 3) the materials' base colours
    weights: dict  # the paint groups' weights (``paint_sources``)
    tint_source: tuple | None
    positions: np.ndarray
    normals: np.ndarray
    colors: np.ndarray
    paint: np.ndarray | None
    tint: np.ndarray | None
    tri_loops: np.ndarray  # (3T,) corners in the drawn (turned) order
    note: str | None  # the orientation's message
    key: str = ""

    def made_of(self, read, palette, weights, tint_source) -> bool:
        """Whether this was drawn from exactly these inputs."""
        same = (self.read is read and np.array_equal(self.palette, palette) and self.weights.keys() == weights.keys()
                and all(np.array_equal(self.weights[k], w) for k, w in weights.items()))
        if not same or (self.tint_source is None) != (tint_source is None):
            return False
        return tint_source is None or (self.tint_source[1] == tint_source[1]
                                       and np.array_equal(self.tint_source[0], tint_source[0]))


def _palette(ob) -> np.ndarray:
    """(slots, 3) float32 base colours of the object's material slots (an Image Texture's mean over the surface
    where one is on Base Color: the surface layer draws the texture over it)."""
    colours = []
    for slot in ob.material_slots:
        mean = material_surface.texture_base_color(ob.original, slot.material) if slot.material else None
        colours.append(mean if mean is not None else material_base_color(slot.material))
    return np.array(colours or [DEFAULT_COLOR], dtype=np.float32)


def _corner_colors(palette: np.ndarray, read: mesh_read.MeshRead) -> np.ndarray:
    """(3T, 3) each corner's base colour from its triangle's material slot."""
    return palette[np.clip(read.material_index, 0, len(palette) - 1)].repeat(3, axis=0)


def _drawn_key(cache_key, session: Session) -> str:
    """A new GPU-cache key for an object's arrays: object, depsgraph mode, the session's mark and a serial."""
    mode, name = cache_key
    return f"{name}:{mode}#{session.mark}.{next(session.drawn_serials)}"


def drawn_mesh(ob, mesh, read: mesh_read.MeshRead, cache_key, session: Session) -> DrawnMesh:
    """The object's ``DrawnMesh``: the cached one when made of the same read, materials and paint."""
    name = ob.original.name
    palette = _palette(ob)
    weights, tint_source = paint_sources(ob, mesh)
    old = session.drawn.get(cache_key)
    if old is not None and old.made_of(read, palette, weights, tint_source):
        return old
    positions, normals = read.corner_arrays()
    tri_loops = read.tri_loops.ravel()
    orientation = read.orientation
    note = orientation.message(name)
    if note:
        positions, normals, tri_loops = turn_outward(orientation.flip, positions, normals, tri_loops)
    colors = _corner_colors(palette, read)
    paint, tint = paint_arrays(weights, tint_source, tri_loops, read.corner_vert)  # in the turned order
    if paint is None:  # made here once, not by every frame's MeshInstance
        paint = np.tile(np.asarray(NEUTRAL_PAINT, np.float32), (len(tri_loops), 1))
        tint = np.ones((len(tri_loops), 3), np.float32)
    drawn = DrawnMesh(read, palette, weights, tint_source, positions, normals, colors, paint, tint, tri_loops, note,
                      key=_drawn_key(cache_key, session))
    session.drawn[cache_key] = drawn
    return drawn


def recoloured(ob, drawn: DrawnMesh, cache_key, session: Session) -> DrawnMesh:
    """A trusted object's ``DrawnMesh`` with its materials' colours read again (a material edit updates the
    material, not the object)."""
    palette = _palette(ob)
    if np.array_equal(palette, drawn.palette):
        return drawn
    new = dataclasses.replace(drawn, palette=palette, colors=_corner_colors(palette, drawn.read),
                              key=_drawn_key(cache_key, session))
    session.drawn[cache_key] = new
    return new


def medium_of(original, method: str, frame_warnings, scene=None, resolved=None) -> tuple[str, Medium | None]:
    """(method, Medium) of an object: its medium as ``medium_source.resolve`` finds it (its material's or its
    own, measured in ``scene``'s units; ``resolved``: what the caller has resolved already); a medium its file
    holds out of range (eta 0.5, NaN) is never drawn: ('OFF', None) and the frame says why."""
    if method == "OFF":
        return method, None
    s = original.translucent
    name = original.name
    m = resolved if resolved is not None else medium_source.resolve(original, scene)
    for note in m.notes:
        frame_warnings.append(f"'{name}': material '{m.material}': {note}")
    try:
        validate_coefficients(m.sigma_a, m.sigma_s_prime, m.eta, m.g, name=f"'{name}'")
        if not 0.0 < m.mm_per_unit < float("inf"):
            raise CoefficientError(f"'{name}': scattering scale {s.scattering_scale}, must be a positive number")
    except CoefficientError as err:
        frame_warnings.append(Lost(f"{err}; drawn with its base colour"))
        return "OFF", None
    layer = {}
    technique = techniques.get(method)
    if m.profile == "MULTIPOLE" and technique is not None and technique.draws_layers:
        thickness_mm = m.layer_thickness * m.mm_per_unit
        problem = layer_problem(m.sigma_a, m.sigma_s_prime, thickness_mm)
        if problem:  # every pass then draws the top layer alone, the entry shift of the base pass included
            frame_warnings.append(f"'{name}': {problem}; drawn as the top layer alone, without its base")
        else:
            layer = dict(layer_thickness_mm=thickness_mm, base_sigma_a=m.base_sigma_a,
                         base_sigma_s_prime=m.base_sigma_s_prime)
    extras = None
    if technique is not None and technique.medium_properties:  # what the method adds to the medium
        extras = technique.medium_extras(technique_values(s, technique.medium_properties), m.mm_per_unit)
    return method, Medium(m.sigma_a, m.sigma_s_prime, m.eta, m.mm_per_unit, m.g,
                          profile=homogeneous_profile(m.profile), extras=extras, **layer)


def bake_handle(ob, method: str, mode: str, frame_warnings, session: Session, read=None) -> BakeHandle | None:
    """The handle of the object's current bake, or None (and a warning) when it is missing or stale."""
    original = ob.original
    status = bake_status(ob, method, mode, read=read, session=session)
    if status != "OK":
        frame_warnings.append(
            f"'{original.name}': {method} bake is {status.lower()}; drawn with its base colour. Press Bake")
        return None
    return BakeHandle(bake_files.source_key(original, method),
                      lambda o=original, m=method: bake_files.read(o, m).arrays, owner=original.name)


def _object_parts(ob, mode: str, frame_warnings, session: Session, trusted: bool = False, scene=None,
                  generated: str | None = None) -> dict | None:
    """What every instance of an evaluated object shares in a frame (MeshInstance fields but the matrix), or
    None when it has no faces. ``trusted``: the caller knows the object's geometry and paint unchanged since
    its last frame (the viewport's depsgraph updates said so): its mesh is not read again. ``generated``: the
    name of geometry that geometry nodes made and no object holds (``GeometryInstances``), drawn with its
    instancer's method, else with the scene's method for generated geometry where its material has a medium."""
    original = ob.original
    name = generated or original.name
    cache_key = (mode, generated or mesh_read.geometry_source(ob))
    s = original.translucent
    drawn = session.drawn.get(cache_key) if trusted else None
    extras = None
    if drawn is not None:
        drawn = recoloured(ob, drawn, cache_key, session)
        extras = object_extras(ob, drawn, None, frame_warnings, session)  # a technique that asks opens the mesh
    else:
        mesh = ob.to_mesh()
        try:
            if mesh is None or len(mesh.polygons) == 0:
                return None
            read = session.reads.read(mesh, cache_key)
            if not read.finite:
                frame_warnings.append(Lost(f"'{name}': the mesh has vertices that are not numbers (NaN or inf); "
                                           f"not drawn"))
                return None
            drawn = drawn_mesh(ob, mesh, read, cache_key, session)
            extras = object_extras(ob, drawn, mesh, frame_warnings, session)
        finally:
            ob.to_mesh_clear()
    session.turned[name] = drawn.read.orientation.turned  # for the object panel, which must not read meshes
    if drawn.note:
        frame_warnings.append(drawn.note)
    # Read settings from the original: editing a property does not re-evaluate the object.
    method = s.method
    resolved = None
    if generated is not None:
        method, resolved = _generated_method(ob, method, scene)
    baked = method != "OFF" and bake_registry.needs_bake(method)
    # The bake's status from the mesh as read here.
    handle = bake_handle(ob, method, mode, frame_warnings, session, drawn.read) if baked else None
    if resolved is None and method != "OFF":
        resolved = medium_source.resolve(original, scene)  # read once per frame
    method, medium = medium_of(original, method, frame_warnings, scene, resolved)
    surface = surface_for(ob, drawn, None, medium, frame_warnings, session,  # opens the mesh when it must
                          resolved.source if resolved is not None else "PRINCIPLED")
    return dict(key=drawn.key, name=name, positions=drawn.positions, normals=drawn.normals, colors=drawn.colors,
                method=method, medium=medium, paint=drawn.paint, tint=drawn.tint, surface=surface,
                bake=handle if method != "OFF" else None, extras=extras,
                auto_target=float(s.target_error) if s.quality == "AUTO" else None,
                bound_points=drawn.read.bound_points())


GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


def _generated_method(ob, method: str, scene):
    """(method, resolved medium or None) of generated geometry (``GeometryInstances``): its instancer's method
    where it has one (medium from the geometry's own material), else the scene's method for generated geometry
    where the geometry's material holds a medium (a Principled BSDF with subsurface, or coefficients), else OFF."""
    resolved = medium_source.resolve(ob, scene)  # the evaluated geometry's materials, the instancer's settings
    if method == "OFF" and resolved.source != "OBJECT":
        method = scene.translucent.instance_method
    if method != "OFF" and bake_registry.needs_bake(method):
        return "OFF", None  # nothing holds a bake of generated geometry (the scene's method never bakes)
    return method, resolved


class GeometryInstances:
    """Instances of geometry rather than of an object: what geometry nodes' Instance on Points makes of an Object
    Info node without *As Instance* (Blender's default there), or of geometry made in the node tree. The depsgraph
    hands each as a temporary object standing for the modifier's object, whose method (OFF, mostly) is not the
    artist's: the method was set on the object the geometry came from.

    ``source`` finds that object: an object of the file with a method whose mesh the geometry was copied from (the
    copy keeps the mesh's name) and whose evaluated positions the geometry has. The instance is then drawn
    as an instance of it (its method, medium, bake and shared GPU data), as *As Instance* would. Geometry no such
    object holds is drawn as itself (``_object_parts(generated=...)``). One verdict per geometry per frame."""

    def __init__(self, depsgraph):
        self.depsgraph = depsgraph
        self._owners = None  # mesh name -> objects using that mesh, with a method
        self._verdicts: dict = {}  # geometry pointer -> evaluated source object, or None

    @staticmethod
    def of_geometry(inst, ob) -> bool:
        """Whether a depsgraph instance is of geometry, not of an object: the temporary object stands for its own
        instancer (an instance of an object, from a collection, particles or *As Instance*, is that object)."""
        if not inst.is_instance or ob.data is None:
            return False
        parent = inst.parent
        return parent is not None and ob.original == parent.original

    def source(self, ob):
        """The evaluated object whose geometry this instance draws, or None."""
        data = ob.data
        key = data.as_pointer()
        if key not in self._verdicts:
            self._verdicts[key] = self._find(data)
        return self._verdicts[key]

    def _find(self, data):
        import bpy

        if self._owners is None:
            self._owners = {}
            for other in bpy.data.objects:
                if other.type == "MESH" and other.data is not None and other.translucent.method != "OFF":
                    self._owners.setdefault(other.data.name, []).append(other)
        if not hasattr(data, "vertices"):
            return None
        positions = np.empty(len(data.vertices) * 3, np.float32)
        data.vertices.foreach_get("co", positions)
        for candidate in sorted(self._owners.get(data.name, ()), key=lambda o: o.name):
            evaluated = candidate.evaluated_get(self.depsgraph)
            mesh = evaluated.to_mesh()
            try:
                if mesh is None or len(mesh.vertices) * 3 != len(positions):
                    continue
                theirs = np.empty(len(positions), np.float32)
                mesh.vertices.foreach_get("co", theirs)
                if np.array_equal(theirs, positions):
                    return evaluated
            finally:
                evaluated.to_mesh_clear()
        return None


def collapsed(matrix_world: np.ndarray) -> bool:
    """Whether an instance's transform flattens it to no volume (a scale of 0 on some axis): its normals and
    the methods' object-space inverses are undefined, and it covers no pixel worth drawing."""
    linear = np.asarray(matrix_world, np.float64)[:3, :3]
    size = float(np.max(np.linalg.norm(linear, axis=0)))
    return not np.isfinite(linear).all() or size == 0.0 or abs(float(np.linalg.det(linear))) <= 1e-12 * size**3


def frame_inputs(depsgraph, camera: CameraView, *, only_translucent: bool = False,
                 trusted: Callable[[str], bool] | None = None, session: Session | None = None) -> FrameInputs:
    """Everything of the evaluated scene that the pipeline draws. ``trusted(name)``: whether an object's geometry
    is known unchanged since the last frame of this depsgraph (the viewport's updates); None: nothing is
    (F12, animation: every mesh is read and compared). What is read is kept on ``session`` (None: the
    extension's)."""
    session = session or current_session()
    scene = depsgraph.scene
    settings = scene.translucent
    meshes, emitters, warnings = [], [], []
    shared: dict = {}
    mode = depsgraph.mode
    session.reads.sweep()
    geometry = GeometryInstances(depsgraph)
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type in GEOMETRY_TYPES:
            generated = None
            if geometry.of_geometry(inst, ob):  # geometry nodes' instances of geometry
                source = geometry.source(ob)
                if source is not None:
                    ob = source  # drawn as an instance of the object the geometry came from
                else:
                    generated = f"{ob.original.name}: {ob.data.name}"
            if only_translucent and ob.original.translucent.method == "OFF" and generated is None:
                continue
            if collapsed(np.array(inst.matrix_world)):
                continue  # scaled to zero (a common way to hide in animation): drawn as if hidden
            # Instances of one object (or of one generated geometry: the depsgraph reuses its temporary objects'
            # pointers for different geometries, so those are told apart by their data) read it once.
            identity = (generated, ob.data.as_pointer()) if generated else (ob.original.name, ob.as_pointer())
            if identity not in shared:
                shared[identity] = _object_parts(ob, mode, warnings, session,
                                                 trusted is not None and not inst.is_instance
                                                 and trusted(ob.original.name), scene, generated)
            parts = shared[identity]
            if parts is not None:
                meshes.append(MeshInstance(model=np.array(inst.matrix_world, dtype=np.float64), **parts))
        elif ob.type == "LIGHT":
            light = ob.data
            if not np.isfinite(np.array(inst.matrix_world)).all() or not np.array(inst.matrix_world)[:3, :3].any():
                warnings.append(f"'{ob.original.name}': the light is scaled to nothing; not drawn")
                continue
            lit = emitters_from_light(
                ob.original.name,
                light.type,
                np.array(inst.matrix_world),
                light_color(light),
                light.energy * (2.0 ** getattr(light, "exposure", 0.0)) * light_normalization(light, inst.matrix_world),
                spot_size=getattr(light, "spot_size", 0.0),
                spot_blend=getattr(light, "spot_blend", 0.0),
                area_shape=getattr(light, "shape", "SQUARE"),
                size=getattr(light, "size", 0.0),
                size_y=getattr(light, "size_y", 0.0),
                area_samples=bounded(settings, "area_light_samples"),
            )
            if not light.translucent.caustics:
                lit = [dataclasses.replace(x, caustics=False) for x in lit]
            emitters += lit
    if not emitters and meshes:
        warnings.append("the scene has no lights: objects are lit by the world only")
    environment = world_environment(scene, session)
    return FrameInputs(
        meshes=meshes,
        emitters=emitters,
        camera=camera,
        world_color=world_color(scene, environment),
        environment=environment,
        film_transparent=scene.render.film_transparent,
        shadow_resolution=bounded(settings, "shadow_resolution"),
        warnings=warnings,
    )


def light_color(light) -> tuple:
    """The light's colour as Cycles and EEVEE take it: times its blackbody colour where Temperature is on
    (Blender 5.0 and later; the property is absent before)."""
    color = np.array(light.color, np.float64)
    if getattr(light, "use_temperature", False):
        color *= np.array(light.temperature_color, np.float64)
    return tuple(color)


def light_normalization(light, matrix_world) -> float:
    """1 for a light whose Normalize is on (the default, and the only way before Blender 4.x had the option);
    off, Cycles scales its power by its emitting area (``lights.unnormalized_power``)."""
    if getattr(light, "normalize", True):
        return 1.0
    return unnormalized_power(light.type, np.array(matrix_world), radius=getattr(light, "shadow_soft_size", 0.0),
                              angle=getattr(light, "angle", 0.0), area_shape=getattr(light, "shape", "SQUARE"),
                              size=getattr(light, "size", 0.0), size_y=getattr(light, "size_y", 0.0))


def output_size(render) -> tuple[int, int]:
    """The F12 image's pixels, as Blender sizes it: resolution x percentage // 100 (at least 1)."""
    pct = int(render.resolution_percentage)
    return max(1, render.resolution_x * pct // 100), max(1, render.resolution_y * pct // 100)


def render_camera(depsgraph, width: int, height: int) -> CameraView:
    """The scene camera as seen by F12 (pixel aspect included)."""
    scene = depsgraph.scene
    cam = scene.camera
    if cam is None:
        raise LookupError("the scene has no active camera: add one or set Scene > Camera")
    cam_eval = cam.evaluated_get(depsgraph)
    proj = cam_eval.calc_matrix_camera(
        depsgraph, x=width, y=height, scale_x=scene.render.pixel_aspect_x, scale_y=scene.render.pixel_aspect_y
    )
    view = cam_eval.matrix_world.normalized().inverted()  # Blender's cameras see without their object's scale
    return CameraView(np.array(view), np.array(proj), width, height)


def viewport_camera(region, region_data) -> CameraView:
    return CameraView(np.array(region_data.view_matrix), np.array(region_data.window_matrix),
                      region.width, region.height)

"""What each material slot's node tree gives the surface layer (bpy-facing, thin; ``core/surface.py`` is the rest).

From the Principled BSDF (or a Diffuse BSDF) feeding the active output: Base Color as a constant or an Image
Texture read through a UV map (the active render map, a UV Map node's, through a Mapping node on UVs), Roughness,
IOR, IOR Level, and a tangent-space Normal Map node's image and strength. Anything else linked to those inputs
(a procedural texture, a mix, a colour ramp) is drawn by the input's own value, said in the panel and the frame's
warnings (``SlotSurface.notes``).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..core.surface import ImageRef, SlotSurface, apply_mapping, mapping_affine, srgb_to_linear, surface_mean
from . import texture_bake
from .images import image_data, image_stamp
from .session import current

IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def surface_node(mat):
    """The node feeding the material's active output's Surface (None: no node tree, or nothing linked)."""
    tree = getattr(mat, "node_tree", None)
    if tree is None:
        return None
    out = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output), None)
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    return out.inputs["Surface"].links[0].from_node


def principled_bsdf(mat):
    """The material's Principled BSDF: the one feeding the active output's Surface, else the first in its
    tree (None: no node tree or no Principled BSDF)."""
    node = surface_node(mat)
    if node is not None and node.type == "BSDF_PRINCIPLED":
        return node
    tree = getattr(mat, "node_tree", None)
    return None if tree is None else next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)


def read_image(image, session=None) -> tuple:
    """((H, W, 4) linear RGBA, a key naming them) of an image, cached on the session while unchanged."""
    pixels, _ = image_data(image, decoder(image), session)
    return pixels, "|".join(map(str, image_stamp(image)))


def render_uv_layer(mesh):
    """The UV map an Image Texture without a vector reads: the one active for rendering (None: no UV map)."""
    return next((u for u in mesh.uv_layers if u.active_render), mesh.uv_layers.active)


def texture_base_color(ob, mat, session=None) -> tuple | None:
    """The mean of the Image Texture on a material's Principled Base Color over the object's own mesh (the
    original's faces through the texture's UV map), or None: no texture there, no mesh or no such UV map."""
    node = principled_bsdf(mat)
    if node is None or not node.inputs["Base Color"].is_linked or ob.type != "MESH":
        return None
    ref = _image_input(node.inputs["Base Color"], [], "Base Color", lambda image: read_image(image, session), mat)
    mesh = ob.data
    if ref is None or len(mesh.polygons) == 0:
        return None
    layer = mesh.uv_layers.get(ref.uv_map) if ref.uv_map else render_uv_layer(mesh)
    if layer is None:
        return None
    cache = (session or current()).images
    key = ("mean", ref.key, ref.uv_map, ref.mapping, mesh.name, mesh.session_uid, len(mesh.loops), len(mesh.vertices))
    if key in cache:
        return cache[key]
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int64)
    mesh.loop_triangles.foreach_get("loops", tris)
    verts = np.empty(len(mesh.loops), np.int64)
    mesh.loops.foreach_get("vertex_index", verts)
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    uv = np.empty(len(mesh.loops) * 2, np.float32)
    layer.data.foreach_get("uv", uv)
    corners = apply_mapping(uv.reshape(-1, 2)[tris], ref.mapping)
    mean = surface_mean(ref.pixels, corners, co.reshape(-1, 3)[verts[tris]], ref.mode)
    mean = tuple(float(x) for x in np.clip(mean, 0.0, 1.0))
    cache[key] = mean
    return mean


def rgba_as_stored(px: np.ndarray) -> np.ndarray:
    """(H, W, 4) float32 RGBA of an image's pixels as stored (Non-Color data, linear spaces, float images)."""
    h, w, c = px.shape
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :min(c, 4)] = px[..., :4]
    if c < 3:
        rgba[..., 1:3] = rgba[..., :1]
    return rgba


def rgba_from_srgb(px: np.ndarray) -> np.ndarray:
    """``rgba_as_stored`` with the colour decoded from sRGB (a byte image in an sRGB space)."""
    rgba = rgba_as_stored(px)
    rgba[..., :3] = srgb_to_linear(rgba[..., :3])
    return rgba


def decoder(image):
    """How an image's stored pixels become linear: ``rgba_from_srgb`` or ``rgba_as_stored``."""
    space = image.colorspace_settings.name
    return rgba_from_srgb if not image.is_float and "sRGB" in space and "Linear" not in space else rgba_as_stored


def _uv_source(socket, notes: list, what: str) -> tuple[str, tuple] | None:
    """(UV map name, 2D affine) of an Image Texture's Vector input, or None when it is not a UV (a note says so)."""
    if not socket.is_linked:
        return "", IDENTITY
    node = socket.links[0].from_node
    mapping = IDENTITY
    if node.type == "MAPPING":
        vector_type = getattr(node, "vector_type", "POINT")
        inputs = node.inputs
        location = tuple(inputs["Location"].default_value) if "Location" in inputs else (0.0, 0.0, 0.0)
        rotation = tuple(inputs["Rotation"].default_value) if "Rotation" in inputs else (0.0, 0.0, 0.0)
        scale = tuple(inputs["Scale"].default_value) if "Scale" in inputs else (1.0, 1.0, 1.0)
        if any(i.is_linked for i in inputs if i.name != "Vector") or abs(rotation[0]) + abs(rotation[1]) > 1e-6:
            notes.append(f"{what}: the Mapping node's linked inputs or x/y rotation are not drawn")
        mapping = mapping_affine(location, rotation[2], scale, vector_type)
        vector = inputs["Vector"]
        if not vector.is_linked:
            notes.append(f"{what}: a Mapping node without a vector reads the object's generated coordinates: "
                         f"drawn through the UV map")
            return "", mapping
        node = vector.links[0].from_node
        socket_name = vector.links[0].from_socket.name
    else:
        socket_name = socket.links[0].from_socket.name
    if node.type == "UVMAP":
        return node.uv_map, mapping
    if node.type == "TEX_COORD" and socket_name == "UV":
        return "", mapping
    notes.append(f"{what} reads {socket_name} coordinates, not a UV map: drawn through the UV map")
    return "", mapping


def _image_input(socket, notes: list, what: str, read, mat=None) -> ImageRef | None:
    """The ImageRef of an Image Texture linked to ``socket`` (directly), of the bake of another node graph there
    (``mat`` given: ``texture_bake``), or None (a note when something else is linked). ``read(image)``: ((H, W, 4)
    linear pixels, a key naming them)."""
    if not socket.is_linked:
        return None
    node = socket.links[0].from_node
    if node.type != "TEX_IMAGE" and mat is not None:  # a node graph: its bake through Cycles, when current
        image, why = texture_bake.baked_image(mat, socket)
        if image is None:
            notes.append(f"{what} is a node graph, its bake is {why}: press Bake Textures (its own value is drawn "
                         f"until then)")
            return None
        try:
            pixels, key = read(image)
        except ValueError as err:
            notes.append(f"{what}: {err}; drawn by its own value")
            return None
        return ImageRef(key, pixels)
    if node.type != "TEX_IMAGE" or node.image is None:
        notes.append(f"{what} is linked to a {node.bl_label} node: drawn by its own value (only Image Textures "
                     f"are read)")
        return None
    try:
        pixels, key = read(node.image)
    except ValueError as err:
        notes.append(f"{what}: {err}; drawn by its own value")
        return None
    uv = _uv_source(node.inputs["Vector"], notes, what)
    if uv is None:
        return None
    if node.interpolation not in ("Linear", "Closest"):
        notes.append(f"{what}: {node.interpolation} interpolation is drawn as Linear")
    if node.extension not in ("REPEAT", "EXTEND"):
        notes.append(f"{what}: {node.extension.title()} extension is drawn as Repeat")
    if node.projection != "FLAT":
        notes.append(f"{what}: {node.projection.title()} projection is drawn as Flat")
    return ImageRef(key, pixels, uv[0], uv[1], node.interpolation == "Closest", node.extension == "EXTEND")


def _constant(node, name: str, default: float, notes: list) -> float:
    sock = node.inputs.get(name)
    if sock is None:
        return default
    if sock.is_linked:
        notes.append(f"{name} is linked to other nodes: its own value {float(sock.default_value):g} is drawn")
    return float(sock.default_value)


def slot_surface(mat, read) -> SlotSurface:
    """One material's SlotSurface (``read(image)``: (its linear pixels, their key), cached by the caller)."""
    if mat is None:
        return SlotSurface(specular=False)
    notes: list = []
    node = principled_bsdf(mat)
    if node is None:
        surface = surface_node(mat)
        colour = tuple(float(c) for c in mat.diffuse_color[:3])
        color_map = None
        if surface is not None and "Color" in surface.inputs:
            sock = surface.inputs["Color"]
            colour = tuple(float(c) for c in sock.default_value[:3])
            color_map = _image_input(sock, notes, "Color", read)
        return SlotSurface(colour, color_map, specular=False, notes=tuple(notes))
    base = node.inputs["Base Color"]
    colour = tuple(float(c) for c in base.default_value[:3])
    color_map = _image_input(base, notes, "Base Color", read, mat)
    roughness = float(np.clip(_constant(node, "Roughness", 0.5, notes), 0.0, 1.0))
    ior = max(_constant(node, "IOR", 1.5, notes), 1.0)
    level = max(_constant(node, "Specular IOR Level", 0.5, notes), 0.0)
    normal_map, strength = None, 1.0
    normal = node.inputs.get("Normal")
    if normal is not None and normal.is_linked:
        source = normal.links[0].from_node
        if source.type == "NORMAL_MAP" and source.space == "TANGENT":
            strength = _constant(source, "Strength", 1.0, notes)
            normal_map = _image_input(source.inputs["Color"], notes, "the Normal Map's Color", read)
            if normal_map is not None and source.uv_map and normal_map.uv_map in ("", source.uv_map):
                normal_map = dataclasses.replace(normal_map, uv_map=source.uv_map)
        else:
            what = (f"a {source.bl_label} node" if source.type != "NORMAL_MAP"
                    else f"a {source.space.lower()} Normal Map")
            notes.append(f"Normal is linked to {what}: not drawn (tangent-space Normal Map nodes are)")
    if getattr(node, "distribution", "MULTI_GGX") not in ("GGX", "MULTI_GGX"):
        notes.append(f"the {node.distribution.title()} distribution is drawn as Multiscatter GGX")
    for name in ("Anisotropic", "Coat Weight", "Sheen Weight", "Transmission Weight", "Metallic"):
        sock = node.inputs.get(name)
        if sock is not None and (sock.is_linked or float(sock.default_value) > 0.0):
            notes.append(f"{name} is not drawn")
    return SlotSurface(colour, color_map, roughness, ior, level, normal_map, strength, True, tuple(notes))


def graphs_to_bake(ob) -> list:
    """(material, Base Color socket) of the object's slots whose Base Color is a node graph other than an Image
    Texture (``texture_bake`` bakes them)."""
    out = []
    for slot in ob.material_slots:
        node = principled_bsdf(slot.material) if slot.material is not None else None
        if node is not None and node.inputs["Base Color"].is_linked \
                and node.inputs["Base Color"].links[0].from_node.type != "TEX_IMAGE":
            out.append((slot.material, node.inputs["Base Color"]))
    return out


def bake_textures(ob, size: int = texture_bake.DEFAULT_SIZE, progress=print) -> list[str]:
    """Bake every node graph on the object's Base Colors whose bake is missing or stale; the images' names."""
    done = []
    for mat, sock in graphs_to_bake(ob):
        if texture_bake.baked_image(mat, sock)[0] is None:
            progress(f"'{ob.name}': baking '{mat.name}' {sock.name} through Cycles ({size} x {size})")
            done.append(texture_bake.bake_graph(ob, mat, sock, size).name)
    return done


def slot_surfaces(ob, read) -> list[SlotSurface]:
    """The SlotSurface of each of the object's material slots (one plain slot when it has none)."""
    return [slot_surface(slot.material, read) for slot in ob.material_slots] or [SlotSurface(specular=False)]

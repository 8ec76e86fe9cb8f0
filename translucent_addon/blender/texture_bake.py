"""Node graphs on Base Color (procedural textures, mixes, colour ramps) baked into UV images by Cycles' own bake.

The surface layer reads Image Textures on the GPU (``material_surface``); any other graph feeding a Principled BSDF's
Base Color is baked once through Cycles: the graph is wired for the duration into an Emission shader, whose
emission Cycles bakes (``bpy.ops.object.bake(type="EMIT")``) into a float image through the object's UV map.
The image is packed into the .blend (it travels with the file) and named after the material and the input; it
carries the graph's digest (``graph_digest``: every node's settings and links upstream of the input), so that an
edit to the graph makes it stale: the panel says so and the input's own value is drawn until it is baked again.
"""
from __future__ import annotations

import hashlib

import bpy

DIGEST_PROPERTY = "translucent_graph"  # on a baked image: the digest of the graph it holds
DEFAULT_SIZE = 1024


def baked_name(mat, input_name: str) -> str:
    return f"{mat.name} {input_name} (Translucent bake)"


def _value(v):
    if isinstance(v, (bool, int, float, str)):
        return v
    if hasattr(v, "__len__") and not isinstance(v, bpy.types.ID):
        try:
            return tuple(_value(x) for x in v)
        except TypeError:
            return None
    if isinstance(v, bpy.types.ID):
        return v.name
    return None


def _node_settings(node) -> tuple:
    """A node's own settings: its RNA properties of plain types (enums, numbers, flags, images by name), a colour
    ramp's stops and a curve's points."""
    out = [node.bl_idname]
    skip = {"name", "label", "location", "width", "height", "dimensions", "select", "show_options", "show_preview",
            "hide", "mute", "show_texture", "color", "use_custom_color", "parent", "width_hidden", "location_absolute"}
    for prop in node.bl_rna.properties:
        if prop.identifier in skip or prop.identifier.startswith("bl_") or prop.type in ("COLLECTION", "POINTER") \
                and prop.identifier not in ("image", "color_ramp", "node_tree"):
            continue
        value = getattr(node, prop.identifier, None)
        if prop.identifier == "color_ramp" and value is not None:
            out.append(("ramp", value.interpolation, value.color_mode,
                        tuple((e.position, tuple(e.color)) for e in value.elements)))
        elif prop.identifier == "node_tree" and value is not None:
            out.append(("group", value.name, tuple(_node_settings(n) for n in value.nodes)))
        else:
            out.append((prop.identifier, _value(value)))
    mapping = getattr(node, "mapping", None)
    if mapping is not None and hasattr(mapping, "curves"):
        out.append(("curves", tuple(tuple((p.location[0], p.location[1]) for p in c.points) for c in mapping.curves)))
    return tuple(out)


def graph_digest(socket) -> str:
    """The digest of everything upstream of an input socket: each node's settings, its unlinked inputs' values and
    its links, in a fixed order (depth first from the socket)."""
    parts: list = []
    seen: dict = {}

    def visit(node) -> int:
        if node.as_pointer() in seen:
            return seen[node.as_pointer()]
        seen[node.as_pointer()] = index = len(seen)
        entry = [_node_settings(node)]
        for sock in node.inputs:
            if sock.is_linked:
                link = sock.links[0]
                entry.append((sock.identifier, "link", visit(link.from_node), link.from_socket.identifier))
            elif hasattr(sock, "default_value"):
                entry.append((sock.identifier, _value(sock.default_value)))
        parts.append((index, tuple(entry)))
        return index

    if socket.is_linked:
        link = socket.links[0]
        parts.append(("out", link.from_socket.identifier, visit(link.from_node)))
    return hashlib.blake2b(repr(sorted(parts, key=repr)).encode(), digest_size=12).hexdigest()


def baked_image(mat, socket):
    """(the baked image of the graph on ``socket``, "") when there is one of this graph, else (None, "missing" or
    "stale")."""
    image = bpy.data.images.get(baked_name(mat, socket.name))
    if image is None:
        return None, "missing"
    return (image, "") if image.get(DIGEST_PROPERTY) == graph_digest(socket) else (None, "stale")


def bake_graph(ob, mat, socket, size: int = DEFAULT_SIZE, samples: int = 4):
    """Bake the graph on ``socket`` into its image through the object's UV map (Cycles, EMIT); returns the image.
    The material and the scene are as they were afterwards. RuntimeError: Cycles refused (no UV map, ...)."""
    scene = bpy.context.scene
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output)
    surface_link = out.inputs["Surface"].links[0] if out.inputs["Surface"].is_linked else None
    kept_surface = surface_link.from_socket if surface_link is not None else None
    source = socket.links[0].from_socket
    name = baked_name(mat, socket.name)
    image = bpy.data.images.get(name)
    if image is None or tuple(image.size) != (size, size):
        if image is not None:
            bpy.data.images.remove(image)
        image = bpy.data.images.new(name, size, size, float_buffer=True, alpha=False)
    emission = tree.nodes.new("ShaderNodeEmission")
    target = tree.nodes.new("ShaderNodeTexImage")
    target.image = image
    active = tree.nodes.active
    saved = (scene.render.engine, scene.cycles.samples, scene.cycles.use_denoising, scene.cycles.device,
             [o for o in bpy.context.view_layer.objects if o.select_get()], bpy.context.view_layer.objects.active)
    try:
        tree.links.new(source, emission.inputs["Color"])
        tree.links.new(emission.outputs["Emission"], out.inputs["Surface"])
        tree.nodes.active = target
        scene.render.engine = "CYCLES"
        scene.cycles.samples = samples
        scene.cycles.use_denoising = False
        scene.cycles.device = "CPU"
        for o in saved[4]:
            o.select_set(False)
        ob.select_set(True)
        bpy.context.view_layer.objects.active = ob
        bpy.ops.object.bake(type="EMIT", margin=8, use_clear=True, target="IMAGE_TEXTURES")
    finally:
        tree.nodes.remove(emission)
        tree.nodes.remove(target)
        if kept_surface is not None:
            tree.links.new(kept_surface, out.inputs["Surface"])
        tree.nodes.active = active
        scene.render.engine, scene.cycles.samples, scene.cycles.use_denoising, scene.cycles.device = saved[:4]
        ob.select_set(False)
        for o in saved[4]:
            o.select_set(True)
        bpy.context.view_layer.objects.active = saved[5]
    image.pack()
    image[DIGEST_PROPERTY] = graph_digest(socket)
    return image

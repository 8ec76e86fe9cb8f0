"""Blender object -> BakeInputs, and the bake status of an object (thin, bpy-facing)."""
from __future__ import annotations

import json

import numpy as np

from .. import techniques
from ..core import bake_store as store
from ..core.geometry.mesh_measures import stretch_of
from ..core.geometry.orientation import outward_normals, turned
from ..techniques.quality_auto import ObjectView
from ..techniques.registry import BakeInputError, BakeInputs, check_physical_size, needs_bake, refuse_size
from ..techniques.texture_space.proxy import surface_area
from . import bake_files, medium_source, mesh_read
from .bvh_tracer import BVHTracer
from .demo import mesh_from_arrays
from .props import bounded
from .session import Session
from .session import current as current_session


def technique_values(group, names) -> dict:
    """The named properties of a property group (``Object.translucent``) as a technique reads them (``bounded``)."""
    return {name: bounded(group, name) for name in names}


def gather(ob_eval, method: str | None = None, *, for_bake: bool = False, proxies: bool = True,
           mode: str = "VIEWPORT", read=None, session: Session | None = None) -> BakeInputs:
    """Inputs of a bake from an evaluated object (modifiers applied): the geometry and the medium, and the
    method's own part from the properties it names (``Technique.bake_parameters``).

    ``for_bake``: check what only a bake refuses and, with ``proxies``, make what only the bake itself needs
    (``make_proxies``), which the per-frame status check must not pay for. The Bake operator makes the proxies
    as its job's first steps instead, under its progress bar. The mesh as read is kept on ``session`` (None: the
    extension's).
    """
    session = session or current_session()
    original = ob_eval.original
    if ob_eval.type != "MESH":
        raise BakeInputError(f"'{original.name}' is a {ob_eval.type.lower()}, not a mesh")
    if for_bake and read is None:  # the size first: nothing is made of a mesh no bake takes
        read = _read(ob_eval, mode, session)
        refuse_size(original.name, len(read.tri_face))
    props = original.translucent
    method = method or props.method
    technique = techniques.get(method)
    vertices, triangles, corner_normals, read_triangles = mesh_arrays(
        ob_eval, corner_normals=technique is not None and technique.bake_corner_normals, mode=mode, read=read,
        session=session)
    medium = medium_source.resolve(original)
    inputs = BakeInputs(
        name=original.name,
        method=method,
        vertices=vertices,
        triangles=triangles,
        read_triangles=read_triangles,
        corner_normals=corner_normals,
        mm_per_unit=medium.mm_per_unit,
        sigma_a=medium.sigma_a,
        sigma_s_prime=medium.sigma_s_prime,
        eta=medium.eta,
        g=medium.g,
        profile=homogeneous_profile(medium.profile),
        stretch=stretch_of(np.array(ob_eval.matrix_world)[:3, :3]),
        params=technique.bake_parameters(technique_values(props, technique.bake_properties)) if technique else None,
        tracer_factory=BVHTracer,  # a bake that casts rays casts them through Blender's BVH
    )
    if for_bake and len(inputs.triangles):  # before Blender's decimation, xatlas or fTetWild see the geometry
        check_physical_size(inputs)
    if for_bake and technique is not None and technique.needs_screen_pixels(inputs.params):
        inputs.screen_pixels = screen_pixels(ob_eval)
    if for_bake and proxies:
        for _ in make_proxies(inputs):
            pass
    return inputs


def make_proxies(inputs: BakeInputs):
    """Generator of (fraction, text): the proxies the method's bake needs made by Blender
    (``Technique.make_proxies``, with Blender's ``decimated``), written into ``inputs.params``. Each is one call
    into Blender, a minute or two on a large mesh: the text says what comes before it runs."""
    technique = techniques.get(inputs.method)
    if technique is not None:
        yield from technique.make_proxies(inputs, decimated)


def homogeneous_profile(setting: str) -> str:
    """The radial profile of the Profile setting: the dipole when chosen, else exact transport (a layer over a
    base is IMAGE_SPACE's multipole; the other methods take the exact profile for it)."""
    return "DIPOLE" if setting == "DIPOLE" else "EXACT"


def _read(ob_eval, mode: str, session: Session) -> mesh_read.MeshRead:
    """The evaluated object's mesh through ``mesh_read`` (cached under its depsgraph mode and name)."""
    mesh = ob_eval.to_mesh()
    try:
        return session.reads.read(mesh, (mode, mesh_read.geometry_source(ob_eval)))
    finally:
        ob_eval.to_mesh_clear()


def mesh_arrays(ob_eval, *, corner_normals: bool = False, mode: str = "VIEWPORT", read=None,
                session: Session | None = None):
    """The evaluated mesh (modifiers applied) as (vertices (V, 3) float32, triangles (T, 3) int32 with inward
    parts turned, corner normals (T, 3, 3) or None, the triangles as read), in bulk; made again only when the
    mesh changed (``mesh_read``; ``mode``: the depsgraph's, which names its cache entry; ``read``: the mesh as
    the caller read it, not read again)."""
    session = session or current_session()
    key = (mode, mesh_read.geometry_source(ob_eval))
    if read is None:
        read = _read(ob_eval, mode, session)
    cached = session.bake_arrays.get((key, corner_normals))
    if cached is not None and cached[0] is read:
        return cached[1]
    vertices, triangles = read.vertices, read.triangles
    normals = read.corner_normals[read.tri_loops] if corner_normals else None
    # Inward-wound parts are baked turned outward, as the frame draws them (``extract.turn_outward``).
    flip = read.orientation.flip
    if flip.any():
        triangles = turned(flip, read.triangles)
        if normals is not None:
            normals = outward_normals(vertices[triangles], turned(flip, normals), flip)
    arrays = (vertices, triangles, normals, read.triangles)
    session.bake_arrays[(key, corner_normals)] = (read, arrays)
    return arrays


def object_view(ob_eval):
    """What AUTO quality needs of an object (``quality_auto.ObjectView``): its size in mm with its scale,
    its area, its material and its bounding-box diagonal on the camera's image."""
    medium = medium_source.resolve(ob_eval.original)
    vertices, triangles, _, _ = mesh_arrays(ob_eval)
    if not len(triangles):
        raise BakeInputError(f"'{ob_eval.original.name}' has no faces: nothing to choose resolutions for")
    v_mm = vertices.astype(np.float64) @ stretch_of(np.array(ob_eval.matrix_world)[:3, :3]).T * medium.mm_per_unit
    return ObjectView(diagonal_mm=float(np.linalg.norm(np.ptp(v_mm, axis=0))),
                      area_mm2=surface_area(v_mm, triangles), screen_pixels=screen_pixels(ob_eval),
                      sigma_a=medium.sigma_a, sigma_s_prime=medium.sigma_s_prime, eta=medium.eta,
                      triangles=len(triangles), profile=homogeneous_profile(medium.profile))


def screen_pixels(ob_eval) -> float | None:
    """The object's bounding-box diagonal on the scene camera's image, in pixels (None: no camera)."""
    import bpy
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector

    scene = bpy.context.scene
    cam = scene.camera
    if cam is None:
        return None
    r = scene.render
    size = np.array([r.resolution_x, r.resolution_y], float) * r.resolution_percentage / 100.0
    m = ob_eval.matrix_world
    pts = np.array([tuple(world_to_camera_view(scene, cam, m @ Vector(c)))[:2] for c in ob_eval.bound_box])
    pts = np.clip(pts, -0.5, 1.5) * size
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))


def decimated(vertices: np.ndarray, triangles: np.ndarray, target: int):
    """Blender's collapse decimation of a triangle mesh to about ``target`` triangles: (vertices, triangles).

    Runs on a temporary object linked to the current scene (a modifier needs a depsgraph) and
    removed afterwards.
    """
    import bpy

    me = mesh_from_arrays("translucent_proxy", vertices, triangles)
    ob = bpy.data.objects.new("translucent_proxy", me)
    scene = bpy.context.scene
    scene.collection.objects.link(ob)
    try:
        mod = ob.modifiers.new("decimate", "DECIMATE")
        mod.decimate_type = "COLLAPSE"
        mod.ratio = float(np.clip(target / max(len(triangles), 1), 1e-4, 1.0))
        mod.use_collapse_triangulate = True
        ob_eval = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
        mesh = ob_eval.to_mesh()
        mesh.calc_loop_triangles()
        v = np.empty(len(mesh.vertices) * 3, np.float32)
        mesh.vertices.foreach_get("co", v)
        t = np.empty(len(mesh.loop_triangles) * 3, np.int32)
        mesh.loop_triangles.foreach_get("vertices", t)
        ob_eval.to_mesh_clear()
    finally:
        bpy.data.objects.remove(ob)
        bpy.data.meshes.remove(me)
    # Collapsing leaves vertices that no triangle uses: drop them.
    t = t.reshape(-1, 3)
    used, t = np.unique(t, return_inverse=True)
    return v.reshape(-1, 3)[used], t.reshape(-1, 3).astype(np.int32)


def bake_status(ob_eval, method: str | None = None, mode: str = "VIEWPORT", read=None,
                session: Session | None = None) -> str:
    """'NONE' (method bakes nothing), 'MISSING', 'STALE' or 'OK' (``mode``: the depsgraph's)."""
    method = method or ob_eval.original.translucent.method
    if not needs_bake(method):
        return "NONE"
    holder = bake_files.owner(ob_eval.original, method)
    if store.stored_hash(holder, method) is None:
        return "MISSING"
    inputs = gather(ob_eval, method, mode=mode, read=read, session=session)
    return store.status(holder, method, inputs_hash(inputs, mode, session, mesh_read.geometry_source(ob_eval)))


def serves_others(ob, method: str, digest: str) -> bool:
    """Whether the mesh's bake of ``method`` is up to date for another object sharing the mesh (a linked duplicate
    without its own bake) while this object's new bake (``digest``) differs: then the new bake goes on the object,
    so that neither makes the other's stale."""
    mesh = ob.data
    if mesh is None or mesh.users < 2 or mesh.library is not None:
        return False
    stored = store.stored_hash(mesh, method)
    if stored is None or stored == digest:
        return False
    import bpy

    depsgraph = bpy.context.evaluated_depsgraph_get()
    for other in bpy.data.objects:
        if other == ob or other.data != mesh or bake_files.owner(other, method) != mesh:  # IDs compare by ==
            continue
        try:
            if bake_status(other.evaluated_get(depsgraph), method) == "OK":  # the mesh's bake is its
                return True
        except BakeInputError:
            continue
    return False


def inputs_hash(inputs: BakeInputs, mode: str = "VIEWPORT", session: Session | None = None,
                source: str | None = None) -> str:
    """``inputs.hash()``, hashed again only when the mesh or a parameter changed: a frame and a panel redraw ask
    for it every time. The geometry is compared by identity: ``mesh_arrays`` hands out the same arrays while the
    mesh is unchanged, and the memo holds them, so an equal identity is equal content. ``source``: what the mesh
    was read under (``mesh_read.geometry_source``: linked duplicates share one memo while their scales agree)."""
    geometry, params = inputs.hash_parts()
    key = (mode, source or inputs.name, inputs.method)
    text = json.dumps(params, sort_keys=True, default=float)
    hashes = (session or current_session()).bake_hashes
    cached = hashes.get(key)
    if (cached is not None and cached[1] == text and cached[0].keys() == geometry.keys()
            and all(cached[0][k] is a for k, a in geometry.items())):
        return cached[2]
    digest = store.inputs_hash(geometry, params)
    hashes[key] = (geometry, text, digest)
    return digest

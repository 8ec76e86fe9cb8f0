"""Reading Blender meshes in bulk, once per change (thin, bpy-facing): shared by ``extract`` (the frame's
meshes) and ``bake_inputs`` (a bake's geometry and its status), which import it and not each other's.

A frame re-reads every mesh it draws, so the read must cost next to nothing when nothing changed, and stay
sound when something did, in F12 and animation renders too (a fresh depsgraph each time, so no update flags
to trust). Each read takes only Blender's attribute arrays, which ``foreach_get`` copies as one block
(positions, corner vertices, corner normals, the loop triangles' faces: about 0.2 ms for the 69k-triangle
bunny, where the per-element ``vertices.foreach_get("co")`` and ``loop_triangles.foreach_get("loops")`` took
20-50 ms), compares them with what was read last time under the same key, and keeps the previous
``MeshRead`` (and everything derived from it) when they are equal. Only a change builds a new one.
"""
from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ..core.geometry.orientation import Orientation, components, orient_parts

KEEP_SWEEPS = 4  # a key not read in this many sweeps (frames) is forgotten

# Painted heterogeneity (Shah ch. 7) read from Blender's own paint layers: the object's vertex groups.
BLUR_GROUP = "translucent_blur"  # Weight Paint: distance multiplier M_d = 1 / (1 + 3 w) (up to 4x spread)
GLOW_GROUP = "translucent_glow"  # Weight Paint: irradiance modulation 1 + 3 w
MASK_GROUP = "translucent_mask"  # Weight Paint: 1 translucent, 0 opaque (all translucent when absent)
PAINT_GROUPS = (MASK_GROUP, BLUR_GROUP, GLOW_GROUP)


def geometry_source(ob) -> str:
    """What an evaluated object's mesh is read and cached under: its mesh's when nothing of the object itself
    changes what is drawn (no modifiers, materials linked to the mesh, no paint groups: the object's vertex
    groups), so that linked duplicates read, turn, colour, hash and upload it once; else the object's name."""
    original = ob.original
    data = getattr(original, "data", None)
    if (original.type != "MESH" or data is None or len(original.modifiers)
            or any(slot.link == "OBJECT" for slot in original.material_slots)
            or any(group.name in PAINT_GROUPS for group in original.vertex_groups)):
        return original.name
    return f"mesh {data.session_uid}"


@dataclasses.dataclass(eq=False)
class MeshRead:
    """One evaluated mesh as Blender holds it: object-space arrays, never modified once built."""

    vertices: np.ndarray  # (V, 3) float32
    corner_vert: np.ndarray  # (L,) int32: the vertex of each corner (face corner, "loop")
    corner_normals: np.ndarray  # (L, 3) float32: Blender's split normals
    tri_face: np.ndarray  # (T,) int32: the face each loop triangle belongs to
    tri_loops: np.ndarray  # (T, 3) int32: the corners of each loop triangle, as Blender triangulates
    face_material: np.ndarray  # (F,) int32: material slot per face
    loops_in_order: bool = False  # tri_loops is 0, 1, 2, ...: every face a triangle
    parts: tuple | None = None  # (count, label per triangle): connectivity, kept while the topology is
    uses: int = 0  # frames that drew this read (``bound_points``)

    @functools.cached_property
    def triangles(self) -> np.ndarray:
        """(T, 3) int32 vertex indices, as read (Blender's winding)."""
        return self.corner_vert[self.tri_loops]

    @functools.cached_property
    def orientation(self) -> Orientation:
        """Which closed parts wind inward (``orientation.orient_outward``); connectivity reused across
        deformation."""
        if self.parts is None:
            self.parts = components(self.triangles, len(self.vertices))
        return orient_parts(self.vertices, self.triangles, self.parts)

    @functools.cached_property
    def finite(self) -> bool:
        """Whether every position and normal is a number (a NaN vertex poisons every method's sums)."""
        return bool(np.isfinite(self.vertices).all() and np.isfinite(self.corner_normals).all())

    @functools.cached_property
    def material_index(self) -> np.ndarray:
        """(T,) int32 material slot per triangle."""
        return self.face_material[self.tri_face]

    @functools.cached_property
    def drawn_vertices(self) -> np.ndarray:
        """(N, 3) the vertices some triangle uses (loose ones left out): what bounds the drawn mesh."""
        used = np.zeros(len(self.vertices), bool)
        used[self.triangles.ravel()] = True
        return self.vertices if used.all() else self.vertices[used]

    @functools.cached_property
    def hull_vertices(self) -> np.ndarray:
        """The vertices on the convex hull of ``drawn_vertices``: the same extremes under any affine map (the
        frame's bounds), a few hundred points instead of every vertex. All of them where Qhull finds no hull
        (flat or tiny meshes)."""
        points = self.drawn_vertices
        if len(points) < 64:
            return points
        from scipy.spatial import ConvexHull, QhullError

        try:
            return points[ConvexHull(points).vertices]
        except (QhullError, ValueError):
            return points

    def bound_points(self) -> np.ndarray:
        """What bounds the drawn mesh: every used vertex the first frame a mesh is drawn (a deforming mesh is
        new every frame), the hull's vertices once it is drawn again unchanged."""
        self.uses += 1
        return self.drawn_vertices if self.uses == 1 else self.hull_vertices

    def corner_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(positions (3T, 3), normals (3T, 3)) float32 per triangle corner, as read."""
        if self.loops_in_order:  # all triangles: the corners are the loops themselves
            return np.take(self.vertices, self.corner_vert, axis=0), self.corner_normals
        loops = self.tri_loops.ravel()
        return np.take(self.vertices, np.take(self.corner_vert, loops), axis=0), np.take(self.corner_normals, loops,
                                                                                          axis=0)


def _attribute(mesh, name: str, prop: str, width: int, count: int, dtype) -> np.ndarray | None:
    attr = mesh.attributes.get(name)
    if attr is None or len(attr.data) != count:
        return None
    out = np.empty(count * width, dtype)
    attr.data.foreach_get(prop, out)
    return out.reshape(-1, width) if width > 1 else out


def _same(old: np.ndarray, new: np.ndarray) -> bool:
    return old.shape == new.shape and np.array_equal(old, new)


class Reads:
    """The meshes last read under each key (object, depsgraph mode), and when: one per ``session.Session``."""

    def __init__(self):
        self.cache: dict = {}  # key -> MeshRead
        self.seen: dict = {}  # key -> the sweep it was last read in (``sweep``)
        self.sweeps = 0

    def sweep(self) -> None:
        """Start a new frame's reads: keys not read for ``KEEP_SWEEPS`` frames are forgotten."""
        self.sweeps += 1
        for key in [k for k, s in self.seen.items() if s < self.sweeps - KEEP_SWEEPS]:
            self.cache.pop(key, None)
            self.seen.pop(key, None)

    def read(self, mesh, key) -> MeshRead:
        """The mesh's arrays: the cached ``MeshRead`` of ``key`` when Blender's arrays equal it, else a new one.

        ``key`` names the mesh across frames (object, depsgraph mode); equal content is what makes a cache hit,
        so a wrong key costs a re-read, never a stale frame."""
        vertices, corner_vert, corner_normals, tri_face, face_material = _arrays(mesh)
        self.seen[key] = self.sweeps
        old = self.cache.get(key)
        topology = old is not None and _same(old.corner_vert, corner_vert) and _same(old.tri_face, tri_face)
        moved = old is None or not _same(old.vertices, vertices)
        if (topology and not moved and _same(old.corner_normals, corner_normals)
                and _same(old.face_material, face_material)):
            return old
        n_loop = len(corner_vert)
        all_triangles = len(tri_face) * 3 == n_loop
        if topology and (all_triangles or not moved):
            tri_loops, parts = old.tri_loops, old.parts
        elif all_triangles:  # Blender's triangle of a triangle face is its corners in order
            tri_loops, parts = np.arange(n_loop, dtype=np.int32).reshape(-1, 3), None
        else:  # quads and n-gons: how Blender split them (it can depend on the positions)
            tri_loops = np.empty(len(tri_face) * 3, np.int32)
            mesh.loop_triangles.foreach_get("loops", tri_loops)
            tri_loops, parts = tri_loops.reshape(-1, 3), (old.parts if topology else None)
        new = MeshRead(vertices, corner_vert, corner_normals, tri_face, tri_loops, face_material, all_triangles,
                       parts=parts)
        self.cache[key] = new
        return new

    def clear(self) -> None:
        self.cache.clear()
        self.seen.clear()


def _arrays(mesh):
    """(vertices, corner vertices, corner normals, loop triangles' faces, face materials): Blender's attribute
    arrays, each one block copy."""
    n_vert, n_loop = len(mesh.vertices), len(mesh.loops)
    vertices = _attribute(mesh, "position", "vector", 3, n_vert, np.float32)
    if vertices is None:
        vertices = np.empty(n_vert * 3, np.float32)
        mesh.vertices.foreach_get("co", vertices)
        vertices = vertices.reshape(-1, 3)
    corner_vert = _attribute(mesh, ".corner_vert", "value", 1, n_loop, np.int32)
    if corner_vert is None:
        corner_vert = np.empty(n_loop, np.int32)
        mesh.loops.foreach_get("vertex_index", corner_vert)
    mesh.calc_loop_triangles()
    tri_face = np.empty(len(mesh.loop_triangles), np.int32)
    mesh.loop_triangle_polygons.foreach_get("value", tri_face)
    corner_normals = np.empty(n_loop * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", corner_normals)
    corner_normals = corner_normals.reshape(-1, 3)
    face_material = _attribute(mesh, "material_index", "value", 1, len(mesh.polygons), np.int32)
    if face_material is None:
        face_material = np.zeros(len(mesh.polygons), np.int32)
    return vertices, corner_vert, corner_normals, tri_face, face_material

"""Reading a Blender mesh's triangle corners in bulk (thin, bpy-facing): shared by ``extract`` (the frame's
meshes) and ``bake_inputs`` (a bake's corner normals), which import it and not each other's."""
from __future__ import annotations

import numpy as np


def mesh_corner_arrays(mesh):
    """Positions, normals per triangle corner (object space), material index per triangle, and the
    corner-to-loop and loop-to-vertex maps."""
    mesh.calc_loop_triangles()
    n_tri = len(mesh.loop_triangles)
    tri_loops = np.empty(n_tri * 3, np.int32)
    mesh.loop_triangles.foreach_get("loops", tri_loops)
    mat_index = np.empty(n_tri, np.int32)
    mesh.loop_triangles.foreach_get("material_index", mat_index)
    loop_vert = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", loop_vert)
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    corner_normals = np.empty(len(mesh.loops) * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", corner_normals)
    positions = co.reshape(-1, 3)[loop_vert[tri_loops]]
    normals = corner_normals.reshape(-1, 3)[tri_loops]
    return positions, normals, mat_index, tri_loops, loop_vert

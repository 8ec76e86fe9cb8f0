"""Blender object -> BakeInputs, and the bake status of an object (thin, bpy-facing)."""
from __future__ import annotations

import numpy as np

from . import store
from .registry import BakeInputError, BakeInputs, needs_bake


def gather(ob_eval, method: str | None = None) -> BakeInputs:
    """Inputs of a bake from an evaluated object (modifiers applied)."""
    original = ob_eval.original
    if ob_eval.type != "MESH":
        raise BakeInputError(f"'{original.name}' is a {ob_eval.type.lower()}, not a mesh")
    mesh = ob_eval.to_mesh()
    try:
        mesh.calc_loop_triangles()
        vertices = np.empty(len(mesh.vertices) * 3, np.float32)
        mesh.vertices.foreach_get("co", vertices)
        triangles = np.empty(len(mesh.loop_triangles) * 3, np.int32)
        mesh.loop_triangles.foreach_get("vertices", triangles)
    finally:
        ob_eval.to_mesh_clear()
    props = original.translucent
    return BakeInputs(
        name=original.name,
        method=method or props.method,
        vertices=vertices.reshape(-1, 3),
        triangles=triangles.reshape(-1, 3),
        mm_per_unit=float(props.mm_per_unit),
        sigma_a=tuple(props.sigma_a),
        sigma_s_prime=tuple(props.sigma_s_prime),
        eta=float(props.eta),
        g=float(props.g),
    )


def bake_status(ob_eval, method: str | None = None) -> str:
    """'NONE' (method bakes nothing), 'MISSING', 'STALE' or 'OK'."""
    method = method or ob_eval.original.translucent.method
    if not needs_bake(method):
        return "NONE"
    original = ob_eval.original
    if store.stored_hash(original, method) is None:
        return "MISSING"
    return store.status(original, method, gather(ob_eval, method).hash())

"""Tetrahedral meshes for QUADGRAPH (Wang et al. 2010, Sec. 4.1): fTetWild, face adjacency and the
splitting of tetrahedra with two or more boundary faces (Fig. 4).

Pure (NumPy; the fTetWild binding imported only when a mesh is tetrahedralised).
"""
from __future__ import annotations

import functools
import importlib
import os
import tempfile

import numpy as np

# Face k of a tetrahedron is the one opposite its vertex k, wound so that its normal points out
# of a positively oriented tetrahedron.
TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


# fTetWild's optimisation, stopped early: AMIPS energy 100 (its default 10) or 10 passes (its default 80).
OPTIMISE = {"stop_energy": 100.0, "num_opt_iter": 10}


class TetrahedraError(ValueError):
    """The tetrahedraliser could not mesh the surface; the message says why in one line."""


def tetrahedralize(vertices_mm: np.ndarray, triangles: np.ndarray, edge_fraction: float = 0.05,
                   binding: str | None = None):
    """fTetWild on a closed or nearly closed surface: (points (P, 3), tets (T, 4)).

    fTetWild comes through pytetwild 0.2.3 (Linux and Windows wheels) or through wildmeshing 0.4.1, its
    authors' own binding (the macOS wheels; pytetwild has none there). ``binding`` picks one (tests run
    both); by default the first this platform has. With the settings below they mesh the 5.8k-triangle
    cow at 100 mm alike: 8,504 and 8,730 tetrahedra in 5.9 s and 5.4 s, each enclosing 99.92 % of its
    volume, the smallest tetrahedron 2.0e-3 and 1.1e-3 of the median (2026-12-04). wildmeshing writes
    fTetWild's log to standard output (Blender's console); its ``set_log_level`` does not reach it.

    A light optimisation (OPTIMISE): the relaxation needs well-shaped tetrahedra. Without any,
    fTetWild keeps slivers of its background mesh (on the 5.8k-triangle cow, 5 % of the tetrahedra
    below 1e-5 of the median volume); the C2/C3 split turns them into clusters of four nodes linked
    10^11 times more strongly to each other than to anything else, whose common mode Jacobi barely
    moves (spectral radius 1 - 2e-6): over 8,000 steps to 1e-3 of the direct solution, against 224
    (marble) and 352 (skin) with this optimisation, which costs 8.8 s instead of 1.9 s there (the full
    one: 78 s, and no better for the relaxation). Tetrahedra stay no larger than ``edge_fraction`` of
    the bounding box diagonal inside, and about as fine as the surface's own triangles near it (so the
    density is set by the surface given, see ``quadgraph_bake``). One thread: with more, fTetWild's
    output changes more from run to run. Even with one it is not reproducible: three runs on the cow
    gave 20,171 to 20,854 tetrahedra without optimisation (measured 2026-12-01).
    """
    run = _binding(binding)
    v = np.ascontiguousarray(vertices_mm, np.float64)
    t = np.ascontiguousarray(triangles, np.int32)
    # fTetWild keeps what its winding number calls inside: a surface wound inward (flipped normals) gives
    # an empty volume. Orient it outward by the sign of its enclosed volume (divergence theorem).
    p = v[t]
    if np.einsum("ij,ij->", p[:, 0], np.cross(p[:, 1], p[:, 2])) < 0.0:
        t = np.ascontiguousarray(t[:, [0, 2, 1]])
    # fTetWild writes a ``__tracked_surface.stl`` into the working directory: run it in a temporary one
    # so nothing lands in the user's folder (or fails where that folder is read-only).
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="translucent_tet_") as scratch:
        os.chdir(scratch)
        try:
            points, tets = run(v, t, float(edge_fraction))
        finally:
            os.chdir(cwd)
    if len(tets) == 0:
        raise TetrahedraError("the tetrahedraliser found no volume inside the surface (is it closed?)")
    points, tets = compact(points, tets)
    return points, orient(points, tets)


BINDINGS = ("pytetwild", "wildmeshing")


def _binding(name: str | None):
    """The function that runs fTetWild through the named binding, or through the first one installed. A
    binding that is there but cannot load (wildmeshing's macOS wheels need macOS 14 on Apple silicon, 13
    on Intel) is named in the message with the loader's reason."""
    failed = []
    for candidate in (name,) if name else BINDINGS:
        try:
            module = importlib.import_module(candidate)
        except ImportError as err:
            if err.name != candidate:  # present, but its compiled part did not load
                failed.append(f"{candidate} did not load ({err})")
            continue
        return functools.partial(_RUNNERS[candidate], module)
    if failed:
        raise TetrahedraError("; ".join(failed) + ": QUADGRAPH cannot bake on this system")
    raise TetrahedraError(f"{name or 'no fTetWild binding (pytetwild, wildmeshing)'} is not installed for this "
                          "platform: QUADGRAPH cannot bake here")


def _run_pytetwild(pytetwild, v, t, edge_fraction):
    return pytetwild.tetrahedralize(v, t, edge_length_fac=edge_fraction, optimize=True, num_threads=1, quiet=True,
                                    **OPTIMISE)


def _run_wildmeshing(wildmeshing, v, t, edge_fraction):
    # pytetwild's settings in wildmeshing's names: stop_energy -> stop_quality, num_opt_iter -> max_its.
    mesher = wildmeshing.Tetrahedralizer(stop_quality=OPTIMISE["stop_energy"], max_its=OPTIMISE["num_opt_iter"],
                                         edge_length_r=edge_fraction, epsilon=1e-3, coarsen=False, max_threads=1)
    mesher.set_mesh(v, t)
    mesher.tetrahedralize()
    points, tets = mesher.get_tet_mesh()[:2]  # the third array: a tag per tetrahedron
    return np.asarray(points, np.float64), np.asarray(tets, np.int64)


_RUNNERS = {"pytetwild": _run_pytetwild, "wildmeshing": _run_wildmeshing}


def compact(points: np.ndarray, tets: np.ndarray):
    """Drop points no tetrahedron uses."""
    used, inverse = np.unique(np.asarray(tets, np.int64), return_inverse=True)
    return np.asarray(points, np.float64)[used], inverse.reshape(-1, 4)


def signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    p = points[tets]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6.0


def orient(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Tetrahedra with positive volume (two vertices swapped where negative)."""
    tets = np.array(tets, np.int64)
    flip = signed_volumes(points, tets) < 0
    tets[flip, 0], tets[flip, 1] = tets[flip, 1].copy(), tets[flip, 0].copy()
    return tets


def face_adjacency(tets: np.ndarray) -> np.ndarray:
    """(T, 4): the tetrahedron across face k of each tetrahedron, -1 on the boundary.

    A face shared by more than two tetrahedra (a non-manifold tetrahedralisation) raises.
    """
    T = len(tets)
    faces = np.sort(tets[:, TET_FACES].reshape(-1, 3), axis=1)
    _, inverse, counts = np.unique(faces, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    if counts.max(initial=0) > 2:
        raise TetrahedraError("a face is shared by more than two tetrahedra")
    order = np.argsort(inverse, kind="stable")
    sorted_ids = inverse[order]
    pair = np.flatnonzero(sorted_ids[1:] == sorted_ids[:-1])
    a, b = order[pair], order[pair + 1]
    neighbours = np.full(T * 4, -1, np.int64)
    neighbours[a] = b // 4
    neighbours[b] = a // 4
    return neighbours.reshape(T, 4)


def split_boundary_tetrahedra(points: np.ndarray, tets: np.ndarray):
    """Split every tetrahedron with two or more boundary faces at its centroid (Wang Fig. 4).

    Each of the four new tetrahedra keeps one face of the old one, so afterwards no tetrahedron has
    more than one face on the boundary: a C2 gives two C0 and two C1, a C3 one C0 and three C1.
    Returns (points, tets, number split).
    """
    adjacency = face_adjacency(tets)
    boundary_faces = (adjacency < 0).sum(axis=1)
    split = np.flatnonzero(boundary_faces >= 2)
    if len(split) == 0:
        return points, tets, 0
    centres = points[tets[split]].mean(axis=1)
    centre_ids = len(points) + np.arange(len(split))
    # New tetrahedron k of a split one: its face k (outward winding) and the centre, positive volume.
    face_vertices = tets[split][:, TET_FACES]  # (S, 4, 3)
    new = np.concatenate([face_vertices, np.broadcast_to(centre_ids[:, None, None], (len(split), 4, 1))], axis=2)
    # Outward winding of (a, b, c) seen from the centre behind it: (a, c, b, centre) is positive.
    new = new[:, :, [0, 2, 1, 3]].reshape(-1, 4)
    keep = np.ones(len(tets), bool)
    keep[split] = False
    return np.concatenate([points, centres]), np.concatenate([tets[keep], new]), int(len(split))

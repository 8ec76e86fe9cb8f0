"""The QUADGRAPH bake (Wang et al. 2010): tetrahedra, QuadGraph levels, level links, display mapping.

Pure. A generator like every bake: yields (fraction, text), returns (arrays, meta). Only geometry is
baked: kappa and mu are set per node at run time from the object's material, its veins and its
painted blur, so editing the material or the paint never needs a new bake. The bake keeps the
tetrahedra and the pose it was built in, so that a deformation of the mesh (armature, lattice, shape
keys) moves the nodes at run time.

Density. The paper's K (Alliez et al. 2005) sets how much larger interior tetrahedra are than those
at the surface. fTetWild (with its optimisation stopped early, ``tetra.OPTIMISE``) keeps tetrahedra
about as fine as the surface's triangles near the surface and no larger than a fraction of the
diagonal inside, which is the same kind of grading, so K is mapped onto the surface: over the paper's
range (Fig. 11: K = 1, 0.5, 0.3, 0.1 gave 141k, 246k, 468k, 973k nodes) N goes as K^-0.84, surface
nodes as N^(2/3), so the finest proxy has 5000 K^-0.56 triangles (5k at K = 1, DESIGN.md's "what the
scattering needs"), or n K^-0.56 for a mesh of n < 5000 triangles, subdivided where it has fewer than
asked.
Levels (Sec. 4.3): each coarser level tetrahedralises a proxy with a quarter of the triangles and
twice the interior edge.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from ...core import native
from ...core.geometry import world_visibility
from ...core.geometry.mesh_measures import vertex_normals
from ...core.geometry.mesh_subdivide import midpoint_subdivision
from . import graph as quadgraph
from . import tetra
from .deformation import embed

PROXY_AT_K1 = 5000  # finest proxy triangles at K = 1
K_EXPONENT = -0.56  # proxy triangles ~ K^-0.56 (N ~ K^-0.84, the paper's Fig. 11)
PROXY_RANGE = (200, 20000)
INTERIOR_EDGE = 0.05  # interior edge of the finest level, as a fraction of the diagonal (fTetWild's default)
DEFAULT_LEVELS = 3
DISPLAY_LINKS = 4  # surface nodes interpolated at each displayed vertex
DISPLAY_CANDIDATES = 16
DISPLAY_MIN_COS = 0.3  # a surface node whose normal turns further away is across a thin part


def proxy_triangles(K: float, levels: int, mesh_triangles: int | None = None) -> list[int]:
    """Triangle targets of the level proxies, coarsest first (each a quarter of the next, none above
    the finest). K scales the density of the surface at K = 1, which is PROXY_AT_K1 triangles or the
    mesh's own where it has fewer (a 12-triangle box is its own proxy at K = 1, and K = 0.5 asks for
    1.47 times its triangles, as it asks a 5k bunny proxy for 7.4k)."""
    base = PROXY_AT_K1 if mesh_triangles is None else min(PROXY_AT_K1, int(mesh_triangles))
    fine = int(np.clip(round(base * float(K) ** K_EXPONENT), min(PROXY_RANGE[0], base), PROXY_RANGE[1]))
    return [min(max(fine // 4 ** (levels - 1 - h), 32), fine) for h in range(levels)]


@dataclasses.dataclass
class BakeParameters:
    """QUADGRAPH's part of a bake's inputs (``BakeInputs.params``)."""

    K: float = 1.0  # density, the paper's K (``proxy_triangles`` maps it)
    levels: int = 3  # multi-resolution levels
    # Decimated proxies, coarsest first, made by Blender ([(vertices, triangles)], object space); None: the mesh.
    proxy_levels: list | None = None

    @classmethod
    def from_values(cls, values: dict) -> "BakeParameters":
        return cls(K=float(values.get("quadgraph_K", 1.0)), levels=int(values.get("quadgraph_levels", 3)))


def make_proxies(inputs, decimate):
    """Generator of (fraction, text): one proxy surface per level (``proxy_surface``), into ``inputs.params``."""
    n = len(inputs.triangles)
    if not n:
        return
    counts = proxy_triangles(inputs.params.K, inputs.params.levels, n)
    levels = []
    for k, count in enumerate(counts):
        yield k / len(counts), f"QUADGRAPH: proxy surface {k + 1} of {len(counts)} ({count:,} triangles)"
        levels.append(proxy_surface(inputs.vertices, inputs.triangles, count, decimate))
    inputs.params.proxy_levels = levels


def proxy_surface(vertices: np.ndarray, triangles: np.ndarray, target: int, decimate):
    """A surface of about ``target`` triangles (QUADGRAPH's density K): the mesh itself within 20 %, else
    ``decimate`` (Blender's collapse decimation) of the mesh, midpoint-subdivided first until it has more than
    target / 0.8 triangles where it has fewer (collapsing the subdivided mesh shortens its longest edges: the
    cow's largest from 0.98 to 0.56 at 7,370 triangles, its 90th percentile from 0.39 to 0.33). Without the
    subdivision a mesh with fewer triangles than the target kept them, and K changed nothing on its surface."""
    n = len(triangles)
    if 0.8 * n <= target <= 1.25 * n:
        return vertices, triangles
    while target >= 0.8 * len(triangles):
        vertices, triangles = midpoint_subdivision(vertices, triangles)
    return decimate(vertices, triangles, target)


def hash_parts(inputs, geometry: dict, material: dict) -> tuple[dict, dict]:
    """A QUADGRAPH bake is geometry only (kappa and mu are set per node at run time), so editing its material
    keeps the bake current; and only its topology: moving vertices (an armature, a lattice, shape keys) moves
    the nodes at run time instead."""
    stretch = np.round(inputs.stretch_matrix(), 9).ravel().tolist()
    return {"triangles": geometry["triangles"]}, {"K": float(inputs.params.K), "levels": int(inputs.params.levels),
                                                  "stretch": stretch, "vertex_count": int(len(inputs.vertices))}


def summary(meta: dict) -> list[str]:
    """What a QUADGRAPH bake holds, for the object panel."""
    mb = meta.get("bytes", 0) / 2**20
    return [f"Nodes: {meta.get('surface_nodes', 0):,} surface, {meta.get('inner_nodes', 0):,} inner "
            f"({len(meta.get('levels', []))} levels, link {meta.get('link_mm', 0.0):.1f} mm)",
            f"Proxy: {meta.get('proxy_triangles', 0):,} triangles; {mb:.0f} MB; baked in "
            f"{meta.get('seconds', 0.0):.1f} s"]


def display_links(display_v, display_t, graph: quadgraph.QuadGraph):
    """(index (V, 4), weight (V, 4)) of the surface nodes that light each displayed vertex: the nearest
    whose normal agrees (so that light does not jump across an ear), weights 1/d^2 (Shepard)."""
    from scipy.spatial import cKDTree

    S = graph.n_surface
    normals = vertex_normals(display_v, display_t)
    k = min(DISPLAY_CANDIDATES, S)
    dist, idx = cKDTree(graph.positions[:S]).query(display_v, k=k)
    dist, idx = dist.reshape(len(display_v), k), idx.reshape(len(display_v), k)
    agree = np.einsum("vd,vkd->vk", normals, graph.normals[idx]) > DISPLAY_MIN_COS
    agree[:, 0] |= ~agree.any(axis=1)  # no candidate agrees: keep the nearest
    rank = np.where(agree, dist, np.inf)
    order = np.argsort(rank, axis=1)[:, :DISPLAY_LINKS]
    rows = np.arange(len(display_v))[:, None]
    d, i, ok = dist[rows, order], idx[rows, order], np.isfinite(rank[rows, order])
    w = np.where(ok, 1.0 / np.maximum(d, 1e-6) ** 2, 0.0)
    w /= w.sum(axis=1, keepdims=True)
    return i.astype(np.int32), w.astype(np.float32)


def display_normals_at(points, display_v, display_t, proxy_normals):
    """The display mesh's smooth normals (angle-weighted, as Blender shades it) at the points' closest
    places on it: a surface node is lit with the normal the user sees, whatever proxy it was placed on
    (a subdivided low-poly proxy is flat inside each of the mesh's triangles; a decimated one has its
    own normals). Where the display's normal turns more than 90 degrees from the proxy's (a thin part
    whose other side is nearer), the proxy's is kept."""

    e = embed(points, display_v, display_t)
    corner = vertex_normals(display_v, display_t, by_angle=True)[np.asarray(display_t)[e.triangle]]
    n = np.einsum("nc,ncd->nd", e.bary, corner)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    agree = np.einsum("nd,nd->n", n, proxy_normals) > 0.0
    return np.where(agree[:, None], n, proxy_normals)


def boundary_surface(points, tets):
    """(points, boundary triangles) of a tetrahedral mesh: the faces only one tetrahedron has (closed,
    whatever the mesh it was built from; orientation left as it comes)."""
    tets = np.asarray(tets, np.int64)
    t, f = np.nonzero(tetra.face_adjacency(tets) < 0)
    return np.asarray(points, np.float64), tets[t[:, None], tetra.TET_FACES[f]]


def bake(inputs):
    """Generator: (fraction, text); returns (arrays, meta)."""
    t0 = time.perf_counter()
    mm = float(inputs.mm_per_unit)
    S = inputs.stretch_matrix()
    display_v = np.asarray(inputs.vertices, np.float64) @ S.T * mm
    display_t = np.asarray(inputs.triangles, np.int64)
    levels = max(1, int(inputs.params.levels))
    # Level surfaces, coarsest first: Blender-decimated proxies (params.proxy_levels), else the mesh.
    surfaces = [(np.asarray(v, np.float64) @ S.T * mm, np.asarray(t, np.int64))
                for v, t in (inputs.params.proxy_levels or [])]
    surfaces = ([(display_v, display_t)] * (levels - len(surfaces)) + surfaces)[-levels:]
    graphs = []
    arrays = {}
    meta_levels = []
    t_tet = 0.0
    for h in range(levels):  # h = 0 is the coarsest
        surface_v, surface_t = surfaces[h]
        fraction = INTERIOR_EDGE * 2.0 ** (levels - 1 - h)
        text = f"QUADGRAPH: tetrahedra of level {h + 1}/{levels} ({len(surface_t):,} triangles)"
        yield 0.05 + 0.8 * h / levels, text
        t1 = time.perf_counter()
        points, tets = yield from native.run(tetra.tetrahedralize, {"vertices_mm": surface_v, "triangles": surface_t},
                                             {"edge_fraction": float(fraction)}, what="fTetWild",
                                             timeout=native.time_limit(300.0, len(surface_t), 1e-2),
                                             fraction=0.05 + 0.8 * h / levels, text=text)
        t_tet += time.perf_counter() - t1
        yield 0.05 + 0.8 * (h + 0.6) / levels, f"QUADGRAPH: graph of level {h + 1}/{levels} ({len(tets):,} tetrahedra)"
        graph, _ = quadgraph.pack(quadgraph.build(points, tets, surface_v, surface_t))
        S_h = graph.n_surface
        graph.normals[:S_h] = display_normals_at(graph.positions[:S_h], display_v, display_t, graph.normals[:S_h])
        graph.check()
        graphs.append(graph)
        p = f"qg{h}_"
        arrays[p + "positions"] = graph.positions.astype(np.float32)
        arrays[p + "neighbours"] = graph.neighbours.astype(np.int32)
        arrays[p + "weights"] = graph.weights.astype(np.float32)
        arrays[p + "d_surface"] = graph.d_surface.astype(np.float32)
        arrays[p + "normals"] = graph.normals.astype(np.float32)
        arrays[p + "facets"] = graph.facets.astype(np.float32)
        arrays[p + "n_surface"] = np.array([graph.n_surface], np.int32)
        # Where the nodes lie, so that a deformation of the mesh can move them (quadgraph_data.LevelEmbedding).
        arrays[p + "points"] = graph.points.astype(np.float64)  # float32 would flatten slivers
        arrays[p + "tets"] = graph.tets.astype(np.int32)
        arrays[p + "inner_bary"] = graph.inner_bary.astype(np.float32)
        if h > 0:
            idx, w = quadgraph.level_links(graph, graphs[h - 1])
            arrays[p + "up_index"] = idx.astype(np.int32)
            arrays[p + "up_weight"] = w.astype(np.float32)
        meta_levels.append({"proxy_triangles": int(len(surface_t)), "tetrahedra": int(len(graph.tets)),
                            "split": graph.split, "surface_nodes": int(graph.n_surface),
                            "inner_nodes": int(graph.n_inner)})
    yield 0.88, "QUADGRAPH: the sky each surface node sees"
    occ = world_visibility.occupancy(*boundary_surface(graphs[-1].points, graphs[-1].tets))
    for h, graph in enumerate(graphs):
        S_h = graph.n_surface
        arrays[f"qg{h}_sky"] = world_visibility.cosine_visibility(graph.positions[:S_h], graph.normals[:S_h],
                                                                  occ).astype(np.float32)
    yield 0.9, "QUADGRAPH: display mapping"
    index, weight = display_links(display_v, display_t, graphs[-1])
    corners = display_t.reshape(-1)
    arrays["qg_display_index"] = index[corners]
    arrays["qg_display_weight"] = weight[corners]
    arrays["qg_levels"] = np.array([levels], np.int32)
    arrays["qg_rest_vertices"] = display_v.astype(np.float32)  # the pose the graph was built in [mm]
    arrays["qg_rest_triangles"] = display_t.astype(np.int32)
    arrays["stretch"] = S.astype(np.float64)
    finest = graphs[-1]
    meta = {
        "levels": meta_levels, "K": float(inputs.params.K),
        "link_mm": round(float(np.median(finest.d_surface)) * 2.0, 3),
        "surface_nodes": int(finest.n_surface), "inner_nodes": int(finest.n_inner),
        "nodes": int(sum(g.count for g in graphs)), "proxy_triangles": int(len(surfaces[-1][1])),
        "tetrahedralize_seconds": round(t_tet, 3), "seconds": round(time.perf_counter() - t0, 3),
        "bytes": int(sum(a.nbytes for a in arrays.values())),
    }
    yield 1.0, "QUADGRAPH: done"
    return arrays, meta

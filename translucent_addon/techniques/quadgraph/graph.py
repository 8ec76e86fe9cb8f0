"""The QuadGraph of Wang et al. 2010 (Sec. 4.1, 5.1): nodes, links, Laplacian weights, levels, packing.

Pure. A tetrahedron becomes an inner node at its (relaxed) centroid, linked to the four tetrahedra
across its faces; a boundary face becomes a surface node on the surface mesh, linked to the one
inner node behind it (Fig. 5). After the C2/C3 split (``tetra.split_boundary_tetrahedra``) every
inner node has exactly four links, which is what lets a fragment shader update it from four fetches.

Node order: surface nodes first (0..S-1), inner nodes after (S..N-1); ``pack`` renumbers each part
for locality (breadth-first blocks of r x r texels for inner nodes, Sec. 5.1; a Morton curve over
the surface for surface nodes, "proximity on the surface").
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.geometry.mesh_measures import vertex_normals
from . import tetra

# Inner nodes stay inside their tetrahedron during relaxation: barycentric coordinates >= this.
RELAX_MIN_BARY = 0.05
RELAX_ITERATIONS = 6
RELAX_STEP = 0.5
# Surface-node rays test this many surface triangles nearest to their boundary face.
RAY_CANDIDATES = 24
SHEPARD_SURFACE = 4  # b for surface nodes (Sec. 4.3)
SHEPARD_INNER = 8  # b for inner nodes
BLOCK = 32  # r: texels per block side (Sec. 5.1)


@dataclasses.dataclass
class QuadGraph:
    positions: np.ndarray  # (N, 3) mm
    n_surface: int  # S: nodes 0..S-1 are surface nodes
    neighbours: np.ndarray  # (N, 4) int64 node ids; a surface node has one link (column 0), -1 elsewhere
    weights: np.ndarray  # (N, 4) geometric Laplacian weights a_ij [mm^-2]; surface rows: 0
    d_surface: np.ndarray  # (S,) d_sk, surface node to its inner node [mm]
    normals: np.ndarray  # (S, 3) unit surface normals at the surface nodes
    # (S, 3) unit normals of the surface triangles the nodes lie on: a node on a facet turned away
    # from a light gets none of it, though its smooth normal may still face the light (the base pass's rule).
    facets: np.ndarray
    volumes: np.ndarray  # (N - S,) tetrahedron volume of each inner node [mm^3]
    # Where each node lies, for deformation and for painted maps: inner nodes by tetrahedron and
    # barycentric coordinates in (points, tets); surface nodes by surface triangle and barycentrics.
    points: np.ndarray  # (P, 3) tetrahedron corners [mm]
    tets: np.ndarray  # (T, 4)
    inner_bary: np.ndarray  # (T, 4)
    surface_triangle: np.ndarray  # (S,) index into the surface mesh the graph was built on
    surface_bary: np.ndarray  # (S, 3)
    split: int = 0  # tetrahedra split at their centroid (C2/C3)

    @property
    def count(self) -> int:
        return len(self.positions)

    @property
    def n_inner(self) -> int:
        return self.count - self.n_surface

    def check(self) -> None:
        """Invariants of Sec. 4.1: four links per inner node, one per surface node, links symmetric."""
        S, N = self.n_surface, self.count
        inner = self.neighbours[S:]
        assert (inner >= 0).all(), "an inner node has fewer than four links"
        assert (self.neighbours[:S, 0] >= S).all() and (self.neighbours[:S, 1:] < 0).all()
        rows = np.repeat(np.arange(N), 4)
        cols = self.neighbours.reshape(-1)
        ok = cols >= 0
        forward = set(zip(rows[ok].tolist(), cols[ok].tolist()))
        assert all((b, a) in forward for a, b in forward), "links are not symmetric"


def _face_geometry(points, tets):
    """Per (tet, face k): area (T, 4), centroid (T, 4, 3), outward unit normal (T, 4, 3)."""
    f = points[tets[:, tetra.TET_FACES]]  # (T, 4, 3, 3)
    cross = np.cross(f[:, :, 1] - f[:, :, 0], f[:, :, 2] - f[:, :, 0])
    length = np.linalg.norm(cross, axis=2)
    normal = cross / np.maximum(length, 1e-300)[..., None]
    return 0.5 * length, f.mean(axis=2), normal


def _barycentric_tet(points, tets, p):
    """Barycentric coordinates (T, 4) of points p (T, 3) in their tetrahedra."""
    c = points[tets]
    m = np.stack([c[:, 1] - c[:, 0], c[:, 2] - c[:, 0], c[:, 3] - c[:, 0]], axis=2)  # (T, 3, 3) columns
    x = np.linalg.solve(m, (p - c[:, 0])[..., None])[..., 0]
    return np.concatenate([1.0 - x.sum(axis=1, keepdims=True), x], axis=1)


def _relax(points, tets, adjacency, face_centroid):
    """Even out inner-node spacing (Sec. 4.1): move each node toward the mean of its four link ends,
    keeping it inside its tetrahedron (barycentric >= RELAX_MIN_BARY). Returns (positions, bary)."""
    corners = points[tets]
    bary = np.full((len(tets), 4), 0.25)
    p = corners.mean(axis=1)
    for _ in range(RELAX_ITERATIONS):
        ends = np.where((adjacency >= 0)[..., None], p[np.maximum(adjacency, 0)], face_centroid)
        target = (1.0 - RELAX_STEP) * p + RELAX_STEP * ends.mean(axis=1)
        bary = np.clip(_barycentric_tet(points, tets, target), 0.0, None)
        bary = RELAX_MIN_BARY + (1.0 - 4.0 * RELAX_MIN_BARY) * bary / bary.sum(axis=1, keepdims=True)
        p = np.einsum("tk,tkd->td", bary, corners)
    return p, bary


def _surface_hits(origins, targets, surface_v, surface_t, surface_normals):
    """Nearest intersection of the ray origin -> target (beyond the origin) with the surface mesh,
    among the RAY_CANDIDATES triangles nearest to the target. Returns (point, triangle, bary, normal,
    facet, found): ``normal`` interpolated from ``surface_normals``, ``facet`` the triangle's unit
    normal; a ray that hits nothing keeps the target and the nearest triangle's plane."""
    from scipy.spatial import cKDTree

    tri = surface_v[surface_t]  # (F, 3, 3)
    k = min(RAY_CANDIDATES, len(surface_t))
    _, cand = cKDTree(tri.mean(axis=1)).query(targets, k=k)
    cand = cand.reshape(len(targets), k)
    d = targets - origins
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    v0 = tri[cand, 0]
    e1 = tri[cand, 1] - v0
    e2 = tri[cand, 2] - v0
    pvec = np.cross(d[:, None, :], e2)
    det = np.einsum("rkd,rkd->rk", pvec, e1)
    inv = 1.0 / np.where(np.abs(det) > 1e-300, det, 1e-300)
    tvec = origins[:, None, :] - v0
    u = np.einsum("rkd,rkd->rk", tvec, pvec) * inv
    qvec = np.cross(tvec, e1)
    v = np.einsum("rd,rkd->rk", d, qvec) * inv
    t = np.einsum("rkd,rkd->rk", e2, qvec) * inv
    eps = 1e-6
    hit = (np.abs(det) > 1e-300) & (u >= -eps) & (v >= -eps) & (u + v <= 1 + eps) & (t > 0)
    t = np.where(hit, t, np.inf)
    j = np.argmin(t, axis=1)
    rows = np.arange(len(targets))
    found = np.isfinite(t[rows, j])
    j = np.where(found, j, 0)  # a miss: the nearest triangle (candidates are sorted by distance)
    triangle = cand[rows, j]
    point = np.where(found[:, None], origins + d * np.where(found, t[rows, j], 0.0)[:, None], targets)
    # Barycentrics of the point (projected onto the triangle's plane for a miss).
    a, b, c = (surface_v[surface_t[triangle, i]] for i in range(3))
    n = np.cross(b - a, c - a)
    nn = np.maximum(np.einsum("ij,ij->i", n, n), 1e-300)
    w_b = np.einsum("ij,ij->i", np.cross(point - a, c - a), n) / nn
    w_c = np.einsum("ij,ij->i", np.cross(b - a, point - a), n) / nn
    bary = np.stack([1.0 - w_b - w_c, w_b, w_c], axis=1)
    normal = np.einsum("sk,skd->sd", bary, surface_normals[surface_t[triangle]])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    facet = n / np.sqrt(nn)[:, None]
    return point, triangle, bary, normal, facet, found


def build(points, tets, surface_v, surface_t) -> QuadGraph:
    """QuadGraph of a tetrahedral mesh (Sec. 4.1); surface nodes on the surface mesh (surface_v, _t) [mm]."""

    points = np.asarray(points, np.float64)
    tets = tetra.orient(points, tets)
    points, tets, n_split = tetra.split_boundary_tetrahedra(points, tets)
    adjacency = tetra.face_adjacency(tets)
    area, face_centroid, face_normal = _face_geometry(points, tets)
    volumes = tetra.signed_volumes(points, tets)
    if (volumes <= 0).any():
        raise tetra.TetrahedraError(f"{int((volumes <= 0).sum())} tetrahedra have no volume")
    inner_pos, inner_bary = _relax(points, tets, adjacency, face_centroid)

    boundary_tet, boundary_face = np.nonzero(adjacency < 0)  # one surface node per boundary face
    S, T = len(boundary_tet), len(tets)
    surface_v = np.asarray(surface_v, np.float64)
    surface_t = np.asarray(surface_t, np.int64)
    s_pos, s_tri, s_bary, s_normal, s_facet, _ = _surface_hits(
        inner_pos[boundary_tet], face_centroid[boundary_tet, boundary_face], surface_v, surface_t,
        vertex_normals(surface_v, surface_t))
    neighbours = np.full((S + T, 4), -1, np.int64)
    surface_id = np.full((T, 4), -1, np.int64)
    surface_id[boundary_tet, boundary_face] = np.arange(S)
    neighbours[S:] = np.where(adjacency >= 0, S + adjacency, surface_id)
    neighbours[:S, 0] = S + boundary_tet
    positions = np.concatenate([s_pos, inner_pos])
    weights, d_surface, _ = link_geometry(positions, neighbours, S, points, tets)
    graph = QuadGraph(
        positions=positions, n_surface=S, neighbours=neighbours, weights=weights, d_surface=d_surface,
        normals=s_normal, facets=s_facet, volumes=volumes, points=points, tets=tets, inner_bary=inner_bary,
        surface_triangle=s_tri, surface_bary=s_bary, split=n_split)
    return graph


def link_geometry(positions, neighbours, S: int, points, tets, volume_floor=None):
    """(weights (N, 4), d_surface (S,), volumes (T,)) of a graph whose inner node S + t lies in
    tetrahedron t, with link k of an inner node across face k (``tetra.TET_FACES``).

    Finite-volume (two-point flux) weights of the Laplacian: a_ij = |f_ij| / (d_ij V_i), so that
    sum_j a_ij (phi_j - phi_i) approximates div grad phi for any tetrahedron shape. The surface link
    d_sk is kept at least a tenth of its face's size (the ray's hit falls short of the inner node's own
    side only on a badly folded surface) so that d_sk > 0. V_i is taken unsigned: a deformed sliver
    that turned over keeps positive weights (``quadgraph_data.LevelEmbedding`` refuses real folds), and
    ``volume_floor`` (T,) keeps one squashed flat from sending its weights to infinity.
    """
    area, _, _ = _face_geometry(points, tets)
    volumes = tetra.signed_volumes(points, tets)
    inner = positions[S:]
    d_inner = np.maximum(np.linalg.norm(positions[neighbours[S:]] - inner[:, None, :], axis=2), 1e-9)
    weights = np.zeros((len(positions), 4))
    V = np.abs(volumes) if volume_floor is None else np.maximum(np.abs(volumes), volume_floor)
    weights[S:] = area / (d_inner * V[:, None])
    t, f = np.nonzero(neighbours[S:] < S)  # inner node t's link across face f ends at a surface node
    s = neighbours[S:][t, f]
    d_surface = np.empty(S)
    d_surface[s] = np.maximum(np.linalg.norm(positions[s] - inner[t], axis=1), 0.1 * np.sqrt(area[t, f]))
    weights[S + t, f] = area[t, f] / (d_surface[s] * V[t])  # the link's weight with the length it is given
    return weights, d_surface, volumes


def inverse_square_weights(graph: QuadGraph) -> np.ndarray:
    """The paper's Laplacian weights 1 / d_ij^2 (Eq. 5, "inverse distance, alpha = -2", Tau95)."""
    S = graph.n_surface
    w = np.zeros_like(graph.weights)
    ends = graph.positions[graph.neighbours[S:]]
    w[S:] = 1.0 / np.maximum(np.sum((ends - graph.positions[S:, None, :]) ** 2, axis=2), 1e-18)
    return w


# -- levels (Sec. 4.3, Eq. 10) ----------------------------------------------------------------
def shepard(fine_positions, coarse_positions, b: int):
    """b nearest coarse nodes of each fine node and weights 1/d^2, normalised (Shepard 1968, Eq. 10)."""
    from scipy.spatial import cKDTree

    b = min(b, len(coarse_positions))
    dist, idx = cKDTree(coarse_positions).query(fine_positions, k=b)
    dist, idx = dist.reshape(len(fine_positions), b), idx.reshape(len(fine_positions), b)
    w = 1.0 / np.maximum(dist, 1e-9) ** 2
    return idx.astype(np.int64), w / w.sum(axis=1, keepdims=True)


def level_links(fine: QuadGraph, coarse: QuadGraph):
    """(indices (N_fine, 8), weights (N_fine, 8)) into the coarse graph: surface nodes from b = 4
    coarse surface nodes, inner nodes from b = 8 coarse inner nodes; unused columns weigh 0."""
    N, S = fine.count, fine.n_surface
    idx = np.zeros((N, SHEPARD_INNER), np.int64)
    w = np.zeros((N, SHEPARD_INNER))
    i_s, w_s = shepard(fine.positions[:S], coarse.positions[:coarse.n_surface], SHEPARD_SURFACE)
    idx[:S, :i_s.shape[1]], w[:S, :i_s.shape[1]] = i_s, w_s
    i_i, w_i = shepard(fine.positions[S:], coarse.positions[coarse.n_surface:], SHEPARD_INNER)
    idx[S:, :i_i.shape[1]], w[S:, :i_i.shape[1]] = i_i + coarse.n_surface, w_i
    return idx, w


# -- packing (Sec. 5.1, Fig. 7) ------------------------------------------------------------------
def breadth_first_order(neighbours: np.ndarray, start: int, count: int, offset: int) -> np.ndarray:
    """Order of the nodes offset..offset+count-1 by breadth-first traversals (links within the set):
    consecutive runs of r^2 nodes are then topologically close (Fig. 7)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import breadth_first_order as bfo

    local = neighbours[offset:offset + count] - offset
    rows = np.repeat(np.arange(count), local.shape[1])
    cols = local.reshape(-1)
    ok = (cols >= 0) & (cols < count)
    adj = csr_matrix((np.ones(ok.sum()), (rows[ok], cols[ok])), shape=(count, count))
    seen = np.zeros(count, bool)
    order = []
    seed = start
    while True:
        part = bfo(adj, seed, directed=False, return_predecessors=False)
        part = part[~seen[part]]
        seen[part] = True
        order.append(part)
        rest = np.flatnonzero(~seen)
        if len(rest) == 0:
            break
        seed = int(rest[0])
    return np.concatenate(order)


def morton_order(positions: np.ndarray) -> np.ndarray:
    """Order of points along a 3-D Morton (Z-order) curve, 10 bits per axis."""
    p = np.asarray(positions, np.float64)
    lo, hi = p.min(axis=0), p.max(axis=0)
    q = ((p - lo) / np.maximum(hi - lo, 1e-12) * 1023).astype(np.int64)
    code = np.zeros(len(p), np.int64)
    for bit in range(10):
        for axis in range(3):
            code |= ((q[:, axis] >> bit) & 1) << (3 * bit + axis)
    return np.argsort(code, kind="stable")


def pack(graph: QuadGraph) -> tuple[QuadGraph, np.ndarray]:
    """Renumber for locality: surface nodes along a Morton curve, inner nodes breadth-first.
    Returns (renumbered graph, old id of each new id)."""
    S, N = graph.n_surface, graph.count
    surface_order = morton_order(graph.positions[:S])
    inner_order = S + breadth_first_order(graph.neighbours, 0, N - S, S)
    old = np.concatenate([surface_order, inner_order])
    new_of_old = np.empty(N, np.int64)
    new_of_old[old] = np.arange(N)
    nb = graph.neighbours[old]
    nb = np.where(nb >= 0, new_of_old[np.maximum(nb, 0)], -1)
    inner_old = old[S:] - S
    packed = dataclasses.replace(
        graph, positions=graph.positions[old], neighbours=nb, weights=graph.weights[old],
        d_surface=graph.d_surface[surface_order], normals=graph.normals[surface_order],
        facets=graph.facets[surface_order],
        volumes=graph.volumes[inner_old], tets=graph.tets[inner_old], inner_bary=graph.inner_bary[inner_old],
        surface_triangle=graph.surface_triangle[surface_order], surface_bary=graph.surface_bary[surface_order])
    return packed, old


@dataclasses.dataclass(frozen=True)
class TextureLayout:
    """Node n -> texel: blocks of r x r texels, ``blocks_per_row`` across; surface nodes fill whole
    block rows first, inner nodes start on the next block row (Sec. 5.1: the node type is known
    from v alone)."""

    n_surface: int
    count: int
    blocks_per_row: int
    block: int = BLOCK

    @property
    def inner_start(self) -> int:
        """First linear texel slot of the inner nodes (a whole number of block rows)."""
        row = self.blocks_per_row * self.block**2
        return -(-self.n_surface // row) * row

    @property
    def size(self) -> tuple[int, int]:
        row = self.blocks_per_row * self.block**2
        slots = self.inner_start + (self.count - self.n_surface)
        return self.blocks_per_row * self.block, -(-slots // row) * self.block

    def slots(self, nodes: np.ndarray) -> np.ndarray:
        nodes = np.asarray(nodes, np.int64)
        return np.where(nodes < self.n_surface, nodes, nodes - self.n_surface + self.inner_start)

    def texels(self, nodes: np.ndarray) -> np.ndarray:
        """(n, 2) integer texel coordinates of node ids."""
        slot = self.slots(nodes)
        r = self.block
        b, local = slot // (r * r), slot % (r * r)
        return np.stack([(b % self.blocks_per_row) * r + local % r, (b // self.blocks_per_row) * r + local // r],
                        axis=-1)


def layout_for(n_surface: int, count: int, max_width: int = 2048) -> TextureLayout:
    """A near-square layout with whole blocks (the paper used r = 32) for S surface and N nodes in all."""
    blocks = -(-n_surface // BLOCK**2) + -(-(count - n_surface) // BLOCK**2)
    per_row = int(np.clip(np.ceil(np.sqrt(blocks)), 1, max_width // BLOCK))
    return TextureLayout(n_surface, count, per_row)

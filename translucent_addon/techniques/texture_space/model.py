"""TEXTURE_SPACE: the bake's arrays laid out for the GPU passes, and the CPU twin of a frame (pure).

The passes (``passes.py``) draw points: one per texel for the illumination map and the
filter, three per surface texel for the vertex gather. Tables that are longer than a texture row
(kernels, the sparse throughput matrix) are wrapped into images ``TABLE_WIDTH`` texels wide;
entry e sits at (e % width, e // width). Vertex quantities live in images ``VERTEX_WIDTH`` wide.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.bake_checks import count, indices, row_pointers, shaped
from ...core.bake_store import DamagedBakeError
from ...core.geometry.mesh_measures import facing_side
from ...core.physics.oblique_entry import packed_shape, unpacked_shape
from .atlas import TexelAtlas
from .proxy import carry_corners
from .throughput import (
    LenschBake,
    _offsets,
    _taps,
    gathered,
    has_through,
    local_radiosity,
    vertex_product,
    vertex_through,
)

TABLE_WIDTH = 4096
# Row starts of F travel as two exact floats, start = hi * ROW_SPLIT + lo (a float holds integers below
# 2^24 exactly); the form factors' table is TABLE_WIDTH texels wide and at most 16384 rows (the least
# texture size OpenGL 4.5 guarantees). Beyond that the product runs on the CPU.
ROW_SPLIT = 1 << 12
GPU_PRODUCT_LIMIT = TABLE_WIDTH * 16384
VERTEX_WIDTH = 256
# The local kernels (49 taps a surface texel) fill a table of the least guaranteed side both ways: 5.4M surface
# texels, an atlas of about 3300 texels a side. The bake refuses a larger one (``KernelTableError``).
KERNEL_WIDTH = 16384
KERNEL_TEXELS_MAX = KERNEL_WIDTH * 16384


class KernelTableError(ValueError):
    """The atlas has more surface texels than the GPU's kernel table holds; the message says what to lower."""


def check_kernel_table(surface_texels: int, taps: int, resolution: int) -> None:
    """KernelTableError unless the kernels of ``surface_texels`` fit ``KERNEL_TEXELS_MAX``."""
    if surface_texels * taps > KERNEL_TEXELS_MAX:
        raise KernelTableError(f"the atlas at {resolution} texels has {surface_texels:,} surface texels; the GPU's "
                               f"kernel table holds {KERNEL_TEXELS_MAX // taps:,}: lower Atlas resolution")


def wrap(table: np.ndarray, width: int = TABLE_WIDTH, channels: int = 4) -> np.ndarray:
    """A flat table (n,) or (n, c) as an image (rows, width, channels), zero padded."""
    table = np.asarray(table)
    if table.ndim == 1:
        table = table[:, None]
    rows = max(1, -(-len(table) // width))
    image = np.zeros((rows * width, channels), table.dtype)
    image[:len(table), :table.shape[1]] = table
    return image.reshape(rows, width, channels)


@dataclasses.dataclass
class GpuTables:
    atlas_size: tuple
    texel_count: int
    surface_count: int
    vertex_count: int
    # Illumination points (every texel): atlas texel, surface point (object units), normal and
    # the normal of its proxy triangle (turned to the normal's side).
    texel: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    facet: np.ndarray
    # ... and the normal field's shape operator there in object space (diagonal; xy, xz, yz), for light
    # entering at an angle (``object_curvature``; zeros for a bake from before it: no shift)
    curvature_d: np.ndarray
    curvature_o: np.ndarray
    # Filter points (every texel): the source's texel, kernel row, barycentrics and vertices.
    source_texel: np.ndarray
    row: np.ndarray
    bary: np.ndarray
    verts: np.ndarray
    # Gather points (three per surface texel).
    gather_texel: np.ndarray
    gather_target: np.ndarray
    gather_dual: np.ndarray
    gather_blend: np.ndarray
    kernels: np.ndarray  # (rows, TABLE_WIDTH, 4) float16
    local_half: int  # the local kernels are (2 local_half + 1)^2 texels
    F_indptr: np.ndarray  # (rows, TABLE_WIDTH, 2) int32: each row start as (hi, lo), see ROW_SPLIT
    F_indices: np.ndarray  # (rows, TABLE_WIDTH, 1) int32
    F_data: np.ndarray  # (rows, TABLE_WIDTH, 4) float32: the entry, its depth (``merged_rows``)
    display_uv: np.ndarray  # (3T', 2) float32, texel units, per corner of the drawn display
    vertex_corner: np.ndarray  # (V,) int32: drawn display corner nearest each proxy vertex
    # A refined proxy drawn in place of the display: each triangle's display triangle (T',) and corner
    # barycentrics there (T', 3, 3) (None: the display is drawn with its own triangles).
    display_parent: np.ndarray | None
    display_bary: np.ndarray | None
    form_factors: int  # entries of F^0 and G together
    cluster_count: int  # cluster slots of the far field (0: a bake from before it)
    cluster_points: tuple | None  # ``cluster_gather``: (texel (V L, 2), slot (V L,), A_i / 3 (V L,))
    z_r: tuple  # the medium's mean free paths, the through share's scale (1e30: none, a bake before it)

    @property
    def gpu_product(self) -> bool:
        return self.F_indices is not None

    @property
    def vertex_size(self) -> tuple:
        return VERTEX_WIDTH, max(1, -(-self.vertex_count // VERTEX_WIDTH))

    @property
    def cluster_size(self) -> tuple:
        return VERTEX_WIDTH, max(1, -(-self.cluster_count // VERTEX_WIDTH))

    def drawn_corners(self, display_corners: np.ndarray) -> np.ndarray:
        """Per-corner display attributes (3T, c) at the corners that are drawn (3T', c)."""
        if self.display_parent is None:
            return np.asarray(display_corners)
        return carry_corners(display_corners, self.display_parent, self.display_bary)

    def fits(self, display_corner_count: int) -> bool:
        """Whether the bake's display arrays belong to a display of this many corners."""
        if self.display_parent is None:
            return len(self.display_uv) == display_corner_count
        return (len(self.display_uv) == 3 * len(self.display_parent)
                and int(self.display_parent.max()) < display_corner_count // 3)


# The least texture side OpenGL 4.5 guarantees: an atlas larger than this was never baked.
MAX_ATLAS_SIDE = 16384
# Local kernels of at most (2 * 8 + 1)^2 taps; bakes make 7x7. A stored shape past this is damage, and would
# make the filter pass's loop over taps as long as the shape says.
MAX_LOCAL_HALF = 8
# Cluster slots of the far field: a bake makes fewer than its vertices; past this a stored array is damage.
MAX_CLUSTER_SLOTS = 1 << 24


def check(arrays: dict) -> None:
    """DamagedBakeError unless a stored TEXTURE_SPACE bake's arrays fit together: every index in range, the
    form factors' rows in order (SciPy's compiled product and the GPU's loop over a row trust them)."""
    width, height, n = shaped(arrays, "atlas_shape", (3,)).tolist()
    width = count(width, "atlas width", 1, MAX_ATLAS_SIDE)
    height = count(height, "atlas height", 1, MAX_ATLAS_SIDE)
    xy = indices(arrays, "atlas_texel_xy", (None, 2), max(width, height))
    N = len(xy)
    if N and (xy[:, 0].max() >= width or xy[:, 1].max() >= height):
        raise DamagedBakeError("its array 'atlas_texel_xy' holds texels outside the atlas")
    n = count(n, "surface texel count", 1, N)
    V = len(shaped(arrays, "proxy_vertices_mm", (None, 3)))
    T = len(indices(arrays, "proxy_triangles", (None, 3), V))
    for name, shape in (("atlas_uv", (T, 3, 2)), ("atlas_chart", (T,)), ("atlas_bary", (N, 3)),
                        ("atlas_position_mm", (N, 3)), ("atlas_normal", (N, 3)), ("atlas_area_mm2", (N,)),
                        ("lensch_A_v", (V,)), ("lensch_dual_weights", (n, 3)), ("lensch_blend_weights", (n, 3, 3))):
        shaped(arrays, name, shape)
    if "stretch" in arrays:  # bakes from before it was stored have none (identity)
        shaped(arrays, "stretch", (3, 3))
    if "atlas_curvature" in arrays:  # nor from before light entered at an angle (no shift)
        shaped(arrays, "atlas_curvature", (N, 6))
    indices(arrays, "atlas_source", (N,), n)
    indices(arrays, "atlas_triangle", (N,), T)
    indices(arrays, "lensch_dual_vertices", (n, 3), V)
    taps = shaped(arrays, "lensch_kernels", (n, None, 3)).shape[1]
    half = local_half(arrays["lensch_kernels"])
    if (2 * half + 1) ** 2 != taps or half > MAX_LOCAL_HALF:
        raise DamagedBakeError(f"its local kernels have {taps} taps, not a square of at most "
                               f"{(2 * MAX_LOCAL_HALF + 1) ** 2}")
    entries = len(indices(arrays, "lensch_F_indices", (None,), V))
    row_pointers(arrays, "lensch_F_indptr", V, entries)
    shaped(arrays, "lensch_F_data", (entries, 3))
    if "lensch_clusters" in arrays:  # the far field (bakes from before it have none)
        clusters = indices(arrays, "lensch_clusters", (V, None), MAX_CLUSTER_SLOTS)
        slots = int(clusters.max()) + 1 if clusters.size else 0
        entries = len(indices(arrays, "lensch_G_indices", (None,), slots))
        row_pointers(arrays, "lensch_G_indptr", V, entries)
        shaped(arrays, "lensch_G_data", (entries, 3))
        if "lensch_G_depth" in arrays or "lensch_F_depth" in arrays:  # the through share reads both
            shaped(arrays, "lensch_G_depth", (entries,))
    if "lensch_F_depth" in arrays:  # the through share's depths (bakes from before them have none)
        shaped(arrays, "lensch_F_depth", (len(arrays["lensch_F_indices"]),))
        shaped(arrays, "lensch_z_r", (3,))
    C = len(shaped(arrays, "display_uv", (None, 2)))
    indices(arrays, "vertex_corner", (V,), C)
    if "display_parent" in arrays:  # a refined display: its parents are checked against the mesh (``fits``)
        parents = len(indices(arrays, "display_parent", (None,), 2**31 - 1))
        shaped(arrays, "display_bary", (parents, 3, 3))


def load(arrays: dict, taps: bool = True) -> tuple[TexelAtlas, LenschBake]:
    """The atlas and Lensch tables of a stored bake, checked (``check``). Kernel taps are not stored: with
    ``taps`` they are recomputed from the atlas (the CPU twin needs them, the GPU finds its taps itself)."""
    check(arrays)
    atlas = TexelAtlas.from_arrays(arrays)
    fields = {f.name: arrays.get(f"lensch_{f.name}") for f in dataclasses.fields(LenschBake)}
    fields["kernels"] = np.asarray(fields["kernels"], np.float32)
    if fields["kernel_taps"] is None and taps:
        offsets = _offsets(local_half(fields["kernels"]))
        fields["kernel_taps"] = _taps(atlas, np.arange(atlas.surface_count), offsets)
    return atlas, LenschBake(**fields)


def split_rows(indptr: np.ndarray) -> np.ndarray:
    """(V+1, 2) int32: the row starts of F as (hi, lo) with start = hi * ROW_SPLIT + lo, both exact in float32."""
    indptr = np.asarray(indptr, np.int64)
    return np.stack([indptr // ROW_SPLIT, indptr % ROW_SPLIT], axis=1).astype(np.int32)


def local_half(kernels: np.ndarray) -> int:
    """h of a bake's (2h+1)^2 local kernels (n, taps, 3)."""
    side = int(round(np.sqrt(np.asarray(kernels).shape[1])))
    return (side - 1) // 2


def merged_rows(lensch: LenschBake):
    """F^0 and the far field G as one CSR over V + C sources (a cluster slot P is column V + P): what the GPU's
    product walks, each row F's entries then G's; data (nnz, 4): the entry, and its depth (``through_share``)."""
    F_depth = lensch.F_depth if lensch.F_depth is not None else np.zeros(len(lensch.F_indices), np.float32)
    F_data = np.concatenate([lensch.F_data, F_depth[:, None]], axis=1).astype(np.float32)
    if not lensch.has_far_field:
        return lensch.F_indptr, lensch.F_indices, F_data
    G_depth = lensch.G_depth if lensch.G_depth is not None else np.zeros(len(lensch.G_indices), np.float32)
    G_data = np.concatenate([lensch.G_data, G_depth[:, None]], axis=1).astype(np.float32)
    V = len(lensch.A_v)
    F_ptr, G_ptr = np.asarray(lensch.F_indptr, np.int64), np.asarray(lensch.G_indptr, np.int64)
    F_count, G_count = np.diff(F_ptr), np.diff(G_ptr)
    indptr = F_ptr + G_ptr
    F_pos = np.arange(len(lensch.F_indices)) + np.repeat(indptr[:-1] - F_ptr[:-1], F_count)
    G_pos = np.arange(len(lensch.G_indices)) + np.repeat(indptr[:-1] + F_count - G_ptr[:-1], G_count)
    indices = np.empty(int(indptr[-1]), np.int64)
    data = np.empty((int(indptr[-1]), 4), np.float32)
    indices[F_pos], indices[G_pos] = lensch.F_indices, np.asarray(lensch.G_indices, np.int64) + V
    data[F_pos], data[G_pos] = F_data, G_data
    return indptr, indices, data


def cluster_gather(lensch: LenschBake):
    """The points that gather the clusters' power E_P = sum A_i / 3 E^g_i each frame: per vertex and level, its
    texel in the vertex image, its cluster slot and A_i / 3 (``ts_gather`` with the vertex image as input)."""
    V, L = lensch.clusters.shape
    i = np.repeat(np.arange(V), L)
    texel = np.stack([i % VERTEX_WIDTH, i // VERTEX_WIDTH], axis=1).astype(np.float32)
    return texel, lensch.clusters.reshape(-1).astype(np.float32), np.repeat(lensch.A_v / 3.0, L).astype(np.float32)


def gpu_tables(arrays: dict, mm_per_unit: float) -> GpuTables:
    atlas, lensch = load(arrays, taps=False)
    F_indptr, F_indices, F_data = merged_rows(lensch)
    gpu_product = len(F_indices) <= GPU_PRODUCT_LIMIT
    n, N = atlas.surface_count, atlas.count
    # Back to object space: p = S^-1 x / mm, and normals n_o ~ S^T n (their transform is S^-T).
    S = np.asarray(arrays.get("stretch", np.eye(3)), np.float64).reshape(3, 3)
    position = atlas.position_mm.astype(np.float64) @ np.linalg.inv(S).T / float(mm_per_unit)
    normal = atlas.normal.astype(np.float64) @ S
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    tri = np.asarray(arrays["proxy_triangles"], np.int64)
    p = np.asarray(arrays["proxy_vertices_mm"], np.float64)[tri[atlas.triangle]]
    facet = facing_side(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) @ S, normal)
    facet /= np.maximum(np.linalg.norm(facet, axis=1, keepdims=True), 1e-30)
    verts = tri[atlas.triangle]
    src = atlas.source
    curvature = object_curvature(arrays.get("atlas_curvature"), atlas.normal, S, mm_per_unit)
    kernels = np.asarray(arrays["lensch_kernels"], np.float16)
    rows = kernels.reshape(-1, 3)
    return GpuTables(
        atlas_size=(atlas.width, atlas.height), texel_count=N, surface_count=n, vertex_count=len(lensch.A_v),
        texel=atlas.texel_xy.astype(np.float32),
        position=position.astype(np.float32),
        normal=normal.astype(np.float32),
        facet=facet.astype(np.float32),
        curvature_d=np.ascontiguousarray(curvature[:, :3]),  # a batch reads its attributes as dense rows
        curvature_o=np.ascontiguousarray(curvature[:, 3:]),
        source_texel=atlas.texel_xy[src].astype(np.float32),
        row=src.astype(np.float32),
        bary=atlas.bary.astype(np.float32),
        verts=verts.astype(np.float32),
        gather_texel=np.repeat(atlas.texel_xy[:n], 3, axis=0).astype(np.float32),
        gather_target=lensch.dual_vertices.reshape(-1).astype(np.float32),
        gather_dual=lensch.dual_weights.reshape(-1).astype(np.float32),
        gather_blend=lensch.blend_weights.reshape(-1, 3).astype(np.float32),
        kernels=wrap(rows, width=KERNEL_WIDTH),
        local_half=local_half(kernels),
        F_indptr=wrap(split_rows(F_indptr), channels=2) if gpu_product else None,
        F_indices=wrap(F_indices.astype(np.int32), channels=1) if gpu_product else None,
        F_data=wrap(np.asarray(F_data, np.float32)) if gpu_product else None,
        z_r=tuple(float(x) for x in (lensch.z_r if has_through(lensch) else np.full(3, 1e30))),
        form_factors=int(len(F_indices)),
        cluster_count=lensch.cluster_count,
        cluster_points=cluster_gather(lensch) if lensch.has_far_field else None,
        display_uv=np.asarray(arrays["display_uv"], np.float32),
        vertex_corner=np.asarray(arrays["vertex_corner"], np.int32),
        display_parent=np.asarray(arrays["display_parent"], np.int64) if "display_parent" in arrays else None,
        display_bary=(np.asarray(arrays["display_bary"], np.float32).reshape(-1, 3, 3)
                      if "display_parent" in arrays else None),
    )


def object_curvature(packed_mm, normals_mm: np.ndarray, S: np.ndarray, mm_per_unit: float) -> np.ndarray:
    """(N, 6) float32: the bake's per-texel shape operators (``bake.texel_curvature``, per mm in mm space) in
    object space, as the vertex stage takes them (``world_shape_operator``). With x = S p mm and the normal
    n_p = S^T n / |S^T n|: dn_p = P S^T S_mm S dp mm / |S^T n|, P = I - n_p n_p^T (the normalisation's own
    change), taken on the tangent plane and symmetric (the Weingarten map is). Zeros without them."""
    if packed_mm is None:
        return np.zeros((len(normals_mm), 6), np.float32)
    S_mm = unpacked_shape(packed_mm)
    n_p = np.asarray(normals_mm, np.float64) @ S
    length = np.linalg.norm(n_p, axis=1)
    n_p /= np.maximum(length, 1e-30)[:, None]
    P = np.eye(3) - n_p[:, :, None] * n_p[:, None, :]
    A = np.einsum("ji,njk,kl->nil", S, S_mm, S) * (float(mm_per_unit) / np.maximum(length, 1e-30))[:, None, None]
    A = P @ A @ P
    return packed_shape(0.5 * (A + np.swapaxes(A, 1, 2)))


def vertex_image(values: np.ndarray, vertex_count: int) -> np.ndarray:
    """(V, 3) per-vertex values as an RGBA image VERTEX_WIDTH wide."""
    return wrap(np.concatenate([values, np.ones((len(values), 1), values.dtype)], axis=1), VERTEX_WIDTH)


def frame_radiosity(arrays: dict, E: np.ndarray, T_p_vertex: np.ndarray | None = None):
    """CPU twin of the GPU passes: (B^l (N, 3), B^g / T_p interpolated (N, 3), its share through thin parts B^t / T_p
    (N, 3)) at every texel.

    ``E`` (N, 3) is the illumination map at every texel (border texels hold their source's); a
    border texel's outputs are its source's, as the filter pass draws them.
    """
    atlas, lensch = load(arrays)
    n = atlas.surface_count
    E_g, B_d = gathered(lensch, np.asarray(E, np.float64)[:n])
    B_vertex = vertex_product(lensch, E_g, B_d)
    B_through = vertex_through(lensch, E_g) if has_through(lensch) else np.zeros_like(B_vertex)
    if T_p_vertex is not None:
        B_vertex /= np.maximum(T_p_vertex, 1e-4)
        B_through /= np.maximum(T_p_vertex, 1e-4)
    verts = np.asarray(arrays["proxy_triangles"], np.int64)[atlas.triangle]
    B_global = np.einsum("nk,nkc->nc", atlas.bary.astype(np.float64), B_vertex[verts])
    B_t = np.einsum("nk,nkc->nc", atlas.bary.astype(np.float64), B_through[verts])
    return local_radiosity(lensch, E)[atlas.source], B_global, B_t

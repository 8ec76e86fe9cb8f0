"""The texture atlas of TEXTURE_SPACE (Lensch Sec. 5.1): xatlas charts and per-texel surface samples.

Pure (NumPy, SciPy, xatlas). Lensch builds charts by growing triangles within 30 degrees of the
chart normal and packs their bounding boxes; xatlas does the same job better (it minimises
distortion and packs the charts themselves). Each texel whose centre lies in a triangle's image
is a *surface texel*: it stands for the piece of surface S(u, v) projected into it, with the
surface point x_c at its centre, the interpolated normal and the area A(u, v) (the texel's
area times the triangle's area ratio, 3D over texture space).

Lensch adds a border of up to 3 texels of neighbouring triangles around each chart, so that the
7x7 kernels see the surface across a chart seam. Here the border is made of *gutter texels*:
a texel within ``BORDER`` texels of a chart is extended along its nearest chart triangle's plane
(barycentrics outside the triangle), and takes the surface texel of another part of the atlas
that lies nearest to that point in 3D (its source). A gutter texel carries its source's
position, normal and irradiance and its own area. Where nothing lies there (an open boundary)
the gutter texel stays empty. The packing leaves ``2 * BORDER`` texels between charts so that
two charts' borders never meet.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.geometry.mesh_checks import triangle_areas
from ...core.geometry.mesh_measures import vertex_normals

# Texels of border around each chart: the half-width of the 9x9 blending kernels (Lensch 5.4).
BORDER = 4


@dataclasses.dataclass
class TexelAtlas:
    """Surface texels first (``surface_count`` of them), then the gutter texels."""

    width: int
    height: int
    uv: np.ndarray  # (T, 3, 2) float32: triangle corners in texel units (texel (x, y) spans [x, x+1))
    chart: np.ndarray  # (T,) int32: chart of each triangle
    texel_xy: np.ndarray  # (N, 2) int32: texel column and row
    source: np.ndarray  # (N,) int32: the surface texel whose geometry and irradiance a texel takes
    triangle: np.ndarray  # (N,) int32: proxy triangle of the source
    bary: np.ndarray  # (N, 3) float32: barycentrics of the source's centre in that triangle
    position_mm: np.ndarray  # (N, 3) float32: x_c of the source
    normal: np.ndarray  # (N, 3) float32
    area_mm2: np.ndarray  # (N,) float32: A(u, v) of the texel itself
    surface_count: int

    @property
    def count(self) -> int:
        return len(self.texel_xy)

    def index_image(self) -> np.ndarray:
        """(height, width) int32: the texel list index at each texel, -1 where empty."""
        image = np.full((self.height, self.width), -1, np.int32)
        image[self.texel_xy[:, 1], self.texel_xy[:, 0]] = np.arange(self.count, dtype=np.int32)
        return image

    def to_arrays(self, prefix: str = "atlas_") -> dict[str, np.ndarray]:
        out = {f"{prefix}{f.name}": np.asarray(getattr(self, f.name)) for f in dataclasses.fields(self)
               if isinstance(getattr(self, f.name), np.ndarray)}
        out[f"{prefix}shape"] = np.array([self.width, self.height, self.surface_count], np.int32)
        return out

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str = "atlas_") -> "TexelAtlas":
        width, height, surface = (int(x) for x in arrays[f"{prefix}shape"])
        names = [f.name for f in dataclasses.fields(cls) if f.name not in ("width", "height", "surface_count")]
        return cls(width=width, height=height, surface_count=surface, **{n: arrays[f"{prefix}{n}"] for n in names})


def texel_mm(area_mm2: float, resolution: int) -> float:
    """The side of a texel in mm for a surface of this area at about ``resolution`` texels a side: charts
    cover about half of the square once the wide gutters are counted."""
    return float(np.sqrt(max(area_mm2, 1e-30) / 0.5)) / float(resolution)


def parametrize(vertices_mm: np.ndarray, triangles: np.ndarray, resolution: int, padding: int = 2 * BORDER):
    """xatlas charts packed at about ``resolution`` texels a side: (uv (T,3,2) texel units, chart (T,), w, h)."""
    import xatlas

    v = np.ascontiguousarray(vertices_mm, np.float32)
    t = np.ascontiguousarray(triangles, np.uint32)
    area = triangle_areas(v, t).sum()
    atlas = xatlas.Atlas()
    atlas.add_mesh(v, t)
    pack = xatlas.PackOptions()
    pack.padding = int(padding)
    pack.bilinear = True
    pack.resolution = 0  # one atlas, as large as the texel density makes it
    pack.texels_per_unit = 1.0 / texel_mm(area, resolution)
    atlas.generate(pack_options=pack)
    vmapping, indices, uvs = atlas[0]
    if len(indices) != len(t) or not np.array_equal(vmapping[indices], t):
        raise RuntimeError("xatlas changed the triangle order; the atlas cannot be mapped back")
    _, chart_of_vertex = atlas.get_mesh_vertex_assignment(0)
    width, height = int(atlas.width), int(atlas.height)
    uv = (uvs[indices] * np.array([width, height], np.float32)).astype(np.float32)
    return uv, chart_of_vertex[indices[:, 0]].astype(np.int32), width, height


def _barycentric(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentrics (N, 3) of 2D points p in triangles (a, b, c); NaN for degenerate triangles."""
    v0, v1, v2 = b - a, c - a, p - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
        l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
    return np.stack([1.0 - l1 - l2, l1, l2], axis=1)


def rasterize(uv: np.ndarray, width: int, height: int):
    """Texels whose centre lies in a triangle's image: (texel_xy (N,2), triangle (N,), bary (N,3)).

    Vectorised over all (triangle, texel of its bounding box) candidates; a centre on a shared
    edge goes to the first triangle.
    """
    uv = np.asarray(uv, np.float64)
    lo = np.ceil(uv.min(axis=1) - 0.5).astype(np.int64)
    hi = np.floor(uv.max(axis=1) - 0.5).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [width - 1, height - 1])
    nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    count = nx * ny
    tri = np.repeat(np.arange(len(uv)), count)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    x = lo[tri, 0] + local % nx[tri]
    y = lo[tri, 1] + local // nx[tri]
    centre = np.stack([x + 0.5, y + 0.5], axis=1)
    bary = _barycentric(centre, uv[tri, 0], uv[tri, 1], uv[tri, 2])
    inside = np.all(bary >= -1e-9, axis=1)
    tri, x, y, bary = tri[inside], x[inside], y[inside], bary[inside]
    _, first = np.unique(y * width + x, return_index=True)
    return (np.stack([x[first], y[first]], axis=1).astype(np.int32), tri[first].astype(np.int32),
            np.clip(bary[first], 0.0, 1.0).astype(np.float64))


def build_atlas(vertices_mm: np.ndarray, triangles: np.ndarray, resolution: int = 512,
                corner_normals: np.ndarray | None = None, charts: tuple | None = None) -> TexelAtlas:
    """The atlas of a proxy mesh (vertices in mm) with its surface and gutter texels.

    ``corner_normals`` (T, 3, 3): the shading normals at the triangles' corners, interpolated to
    each texel (default: the area-weighted vertex normals). The bake passes the display's: light
    at grazing incidence changes with a few degrees of normal. ``charts``: what ``parametrize`` returned
    for this mesh (the bake runs xatlas in a child process, ``core/native.py``), or None to run it here.
    """
    from scipy import ndimage
    from scipy.spatial import cKDTree

    v = np.asarray(vertices_mm, np.float64)
    t = np.asarray(triangles, np.int64)
    uv, chart, width, height = parametrize(v, t, resolution) if charts is None else charts
    xy, tri, bary = rasterize(uv, width, height)
    normals = vertex_normals(v, t)[t] if corner_normals is None else np.asarray(corner_normals, np.float64)
    corners = v[t]  # (T, 3, 3)
    area_3d = triangle_areas(v, t)
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    area_uv = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).astype(np.float64)
    texel_area = np.divide(area_3d, area_uv, out=np.zeros_like(area_3d), where=area_uv > 0)  # mm^2 per texel^2

    facet = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    facet /= np.maximum(np.linalg.norm(facet, axis=1, keepdims=True), 1e-30)

    def surface_point(tris, b):
        p = np.einsum("nk,nkd->nd", b, corners[tris])
        n = np.einsum("nk,nkd->nd", b, normals[tris])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        # Corner normals that cancel (a crease folded back) leave the facet's normal.
        return p, np.where(length > 1e-6, n / np.maximum(length, 1e-30), facet[tris])

    position, normal = surface_point(tri, bary)
    area = texel_area[tri]

    # Gutter texels within BORDER of a chart: extend the nearest chart triangle, take the nearest
    # surface texel elsewhere in the atlas as the source.
    index = np.full((height, width), -1, np.int64)
    index[xy[:, 1], xy[:, 0]] = np.arange(len(xy))
    distance, (near_y, near_x) = ndimage.distance_transform_edt(index < 0, return_indices=True)
    gy, gx = np.nonzero((index < 0) & (distance <= BORDER))
    nearest = index[near_y[gy, gx], near_x[gy, gx]]
    g_tri = tri[nearest]
    g_bary = _barycentric(np.stack([gx + 0.5, gy + 0.5], axis=1).astype(np.float64),
                          uv[g_tri, 0].astype(np.float64), uv[g_tri, 1].astype(np.float64),
                          uv[g_tri, 2].astype(np.float64))
    extended = np.einsum("nk,nkd->nd", g_bary, corners[g_tri])
    spacing = np.sqrt(texel_area[g_tri])
    tree = cKDTree(position)
    k = min(16, len(position))
    dist, cand = tree.query(extended, k=k)
    dist, cand = dist.reshape(len(gx), k), cand.reshape(len(gx), k)
    # A candidate of the same chart near the gutter texel is the chart the border extends, not the
    # surface across the seam.
    far_in_atlas = np.max(np.abs(xy[cand] - np.stack([gx, gy], axis=1)[:, None, :]), axis=2) > 2 * BORDER
    other_chart = chart[tri[cand]] != chart[g_tri][:, None]
    ok = (far_in_atlas | other_chart) & (dist <= 1.5 * spacing[:, None])
    has = ok.any(axis=1)
    pick = cand[np.arange(len(gx)), np.argmax(ok, axis=1)]
    gx, gy, pick, g_tri = gx[has], gy[has], pick[has], g_tri[has]

    n_surface = len(xy)
    return TexelAtlas(
        width=width, height=height, uv=uv.astype(np.float32), chart=chart,
        texel_xy=np.concatenate([xy, np.stack([gx, gy], axis=1)]).astype(np.int32),
        source=np.concatenate([np.arange(n_surface), pick]).astype(np.int32),
        triangle=np.concatenate([tri, tri[pick]]).astype(np.int32),
        bary=np.concatenate([bary, bary[pick]]).astype(np.float32),
        position_mm=np.concatenate([position, position[pick]]).astype(np.float32),
        normal=np.concatenate([normal, normal[pick]]).astype(np.float32),
        area_mm2=np.concatenate([area, texel_area[g_tri]]).astype(np.float32),
        surface_count=n_surface,
    )

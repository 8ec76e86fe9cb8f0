"""The TEXTURE_SPACE bake (Lensch 2002): proxy, atlas, Lensch tables, display mapping.

Pure. A generator like every bake: yields (fraction, text), returns (arrays, meta). The arrays
are what ``techniques/texture_space/passes.py`` draws with; kernels are stored as float16 (three
significant digits, the same as the GPU reads them).
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from ...core import native
from ...core.geometry.mesh_measures import vertex_normals
from ...core.physics.oblique_entry import corner_shape_operators, packed_shape
from . import proxy
from . import throughput as lensch
from .atlas import build_atlas, parametrize
from .model import check_kernel_table

# A display corner may lie off its proxy triangle (the two meshes differ); its atlas position is
# extrapolated at most this many texels past the triangle, into the chart's border.
MAX_EXTRAPOLATION_TEXELS = 3.0


@dataclasses.dataclass
class BakeParameters:
    """TEXTURE_SPACE's part of a bake's inputs (``BakeInputs.params``)."""

    atlas_resolution: int = 512  # texels along the atlas's side
    proxy_spacing: float = 3.5  # mean proxy edge in atlas texels (``proxy.py``)
    blending: bool = True  # Lensch Sec. 5.4: local and global parts blended
    # A decimated proxy made by Blender (object space, ``make_proxies``), or None to derive it here.
    proxy_vertices: np.ndarray | None = None
    proxy_triangles: np.ndarray | None = None

    @classmethod
    def from_values(cls, values: dict) -> "BakeParameters":
        return cls(atlas_resolution=int(values.get("atlas_resolution", 512)),
                   proxy_spacing=float(values.get("proxy_spacing", 3.5)),
                   blending=bool(values.get("texture_blending", True)))


def make_proxies(inputs, decimate):
    """Generator of (fraction, text): the mesh decimated by Blender to the atlas's spacing, where the mesh is
    much finer than the atlas needs, into ``inputs.params``."""
    n, p = len(inputs.triangles), inputs.params
    if not n:
        return
    target = proxy.target_triangles(proxy.surface_area(inputs.vertices * inputs.mm_per_unit, inputs.triangles),
                                    p.atlas_resolution, p.proxy_spacing)
    if target < 0.8 * n:
        yield 0.0, f"TEXTURE_SPACE: decimating {n:,} triangles to {target:,} for the atlas"
        p.proxy_vertices, p.proxy_triangles = decimate(inputs.vertices, inputs.triangles, target)


def hash_parts(inputs, geometry: dict, material: dict) -> tuple[dict, dict]:
    """The geometry (with the corner normals the illumination map lights with), the material and the atlas.
    thin_parts: F^0 carries light through thin parts (physics.slab_through); far_field: distant sources by
    cluster (far_field.py); oblique_entry: the texels' curvature (texel_curvature). Bakes before any of them are
    stale."""
    p = inputs.params
    if inputs.corner_normals is not None:
        geometry = {**geometry, "corner_normals": np.asarray(inputs.corner_normals, np.float32)}
    return geometry, {**material, "atlas_resolution": int(p.atlas_resolution), "blending": bool(p.blending),
                      "profile": inputs.profile, "thin_parts": 1, "far_field": 1, "oblique_entry": 1,
                      "proxy_spacing": round(float(p.proxy_spacing), 4),
                      "stretch": np.round(inputs.stretch_matrix(), 9).ravel().tolist()}


def summary(meta: dict) -> list[str]:
    """What a TEXTURE_SPACE bake holds, for the object panel."""
    atlas = meta.get("atlas", ["?", "?"])
    return [f"Proxy: {meta.get('proxy_vertices', 0):,} vertices, atlas {atlas[0]} x {atlas[1]}",
            f"Texels: {meta.get('surface_texels', 0):,} ({meta.get('texel_mm', 0.0):.2f} mm), "
            f"form factors: {meta.get('form_factors', 0):,}",
            f"Stored: {meta.get('bytes', 0) / 2**20:.0f} MB, baked in {meta.get('seconds', 0.0):.1f} s"]


def _display_uv(atlas, tri, bary) -> np.ndarray:
    uv = atlas.uv[tri].astype(np.float64)
    bary = bary.astype(np.float64)
    inside = np.clip(bary, 0.0, None)
    inside /= np.maximum(inside.sum(axis=1, keepdims=True), 1e-12)
    p_in = np.einsum("nk,nkd->nd", inside, uv)
    step = np.einsum("nk,nkd->nd", bary, uv) - p_in
    length = np.linalg.norm(step, axis=1, keepdims=True)
    return p_in + step * np.minimum(1.0, MAX_EXTRAPOLATION_TEXELS / np.maximum(length, 1e-12))


def bake(inputs):
    t0 = time.perf_counter()
    mm = float(inputs.mm_per_unit)
    S = inputs.stretch_matrix()  # physical mm = S @ object-space vertex * mm per unit
    display_v = np.asarray(inputs.vertices, np.float64) @ S.T * mm
    display_t = np.asarray(inputs.triangles, np.int64)
    yield 0.02, "TEXTURE_SPACE: proxy mesh"
    # The display's shading normals at its corners, in mm space (normals transform with S^-T).
    display_n = (vertex_normals(display_v, display_t, by_angle=True)[display_t] if inputs.corner_normals is None
                 else np.asarray(inputs.corner_normals, np.float64).reshape(-1, 3, 3) @ np.linalg.inv(S))
    refinement = None
    params = inputs.params
    if params.proxy_vertices is not None:
        proxy_v = np.asarray(params.proxy_vertices, np.float64) @ S.T * mm
        proxy_t = np.asarray(params.proxy_triangles, np.int64)
        proxy_n = proxy.transfer_normals(display_v, display_t, display_n, proxy_v, proxy_t)[proxy_t]
    else:
        refinement = proxy.refine_for_atlas(display_v, display_t, params.atlas_resolution, params.proxy_spacing)
        proxy_v, proxy_t = refinement.vertices, refinement.triangles
        # The refined display's corners carry its normals, interpolated like the positions.
        proxy_n = refinement.corners(display_n.reshape(-1, 3)).reshape(-1, 3, 3)
    text = f"TEXTURE_SPACE: atlas of {len(proxy_t):,} triangles at {params.atlas_resolution} texels"
    yield 0.05, text
    t_atlas = time.perf_counter()
    charts = yield from native.run(parametrize, {"vertices_mm": proxy_v, "triangles": proxy_t},
                                   {"resolution": int(params.atlas_resolution)}, what="xatlas",
                                   timeout=native.time_limit(120.0, len(proxy_t), 1e-3), fraction=0.05, text=text)
    atlas = build_atlas(proxy_v, proxy_t, params.atlas_resolution, proxy_n, charts=charts)
    check_kernel_table(atlas.surface_count, len(lensch.LOCAL_OFFSETS), params.atlas_resolution)
    t_atlas = time.perf_counter() - t_atlas
    material = lensch.Material(tuple(inputs.sigma_a), tuple(inputs.sigma_s_prime), float(inputs.eta), inputs.profile)
    job = lensch.precompute(atlas, proxy_v, proxy_t, material, blend=params.blending)
    try:
        while True:
            fraction, text = next(job)
            yield 0.1 + 0.85 * fraction, f"TEXTURE_SPACE: {text}"
    except StopIteration as done:
        tables = done.value
    yield 0.96, "TEXTURE_SPACE: display mapping"
    if refinement is not None:  # the refined display is drawn with the proxy's own coordinates
        display_uv = atlas.uv.reshape(-1, 2).astype(np.float64)
        corners = refinement.corners(display_v[display_t].reshape(-1, 3))
    else:
        tri, bary = proxy.display_mapping(display_v, display_t, proxy_v, proxy_t)
        display_uv = _display_uv(atlas, tri, bary)
        corners = display_v[display_t].reshape(-1, 3)
    # T_p at each proxy vertex (Lensch Eq. 13): the base colour of the nearest (drawn) display corner.
    from scipy.spatial import cKDTree

    _, vertex_corner = cKDTree(corners).query(proxy_v)
    arrays = {
        "proxy_vertices_mm": proxy_v.astype(np.float32),
        "proxy_triangles": proxy_t.astype(np.int32),
        "display_uv": display_uv.astype(np.float32),
        "vertex_corner": vertex_corner.astype(np.int32),
        **({} if refinement is None else {"display_parent": refinement.parent.astype(np.int32),
                                          "display_bary": refinement.bary.astype(np.float32)}),
        "stretch": S.astype(np.float64),
        "atlas_curvature": texel_curvature(atlas, proxy_corner_curvature(display_v, display_t, display_n, proxy_v,
                                                                         proxy_t, proxy_n, refinement)),
        **atlas.to_arrays(),
        **tables.to_arrays(),
    }
    arrays["lensch_kernels"] = tables.kernels.astype(np.float16)
    del arrays["lensch_kernel_taps"]  # recomputed from the atlas when loaded
    meta = {
        "proxy_vertices": int(len(proxy_v)), "proxy_triangles": int(len(proxy_t)),
        "proxy_spacing": float(params.proxy_spacing), "atlas": [atlas.width, atlas.height],
        "surface_texels": int(atlas.surface_count),
        "border_texels": int(atlas.count - atlas.surface_count), "form_factors": int(len(tables.F_indices)),
        "far_entries": int(len(tables.G_indices)), "clusters": int(tables.cluster_count),
        "texel_mm": float(np.sqrt(np.median(atlas.area_mm2[:atlas.surface_count]))),
        "atlas_seconds": round(t_atlas, 3), "seconds": round(time.perf_counter() - t0, 3),
        "bytes": int(sum(a.nbytes for a in arrays.values())),
    }
    yield 1.0, "TEXTURE_SPACE: done"
    return arrays, meta


def proxy_corner_curvature(display_v, display_t, display_n, proxy_v, proxy_t, proxy_n, refinement) -> np.ndarray:
    """(T', 3, 3, 3): the shape operator (dN = S dP, per mm) at each proxy corner: the display's
    (``oblique_entry.corner_shape_operators`` of its corners, the field IMAGE_SPACE takes) carried to a refined
    proxy's corners as its normals are; a decimated proxy's own corners' (its transferred normals). Taken on the
    refined proxy itself it is a little rougher (Spot at atlas 512: texel-to-texel changes of the trace 20 %
    larger in the median and at the 99th percentile)."""
    def unit(normals):  # mm-space normals are the object's turned by S^-T: not of unit length when scaled
        n = np.asarray(normals, np.float64).reshape(-1, 3, 3)
        return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)

    if refinement is None:
        return corner_shape_operators(proxy_v[proxy_t], unit(proxy_n))
    display = corner_shape_operators(display_v[display_t], unit(display_n))
    return refinement.corners(display.reshape(-1, 9)).reshape(-1, 3, 3, 3)


def texel_curvature(atlas, corners: np.ndarray) -> np.ndarray:
    """(N, 6) float32 per texel, per mm in the bake's mm space: the shape operator S of the normal field the
    texels' normals come from (``proxy_corner_curvature`` at the proxy's corners, interpolated as the normals
    are), as its diagonal and its (xy, xz, yz) entries: light entering at an angle is read where it entered
    (``oblique_entry``)."""
    return packed_shape(np.einsum("nk,nkij->nij", atlas.bary.astype(np.float64),
                                  np.asarray(corners, np.float64)[atlas.triangle]))

"""Which way is out: each connected part of a mesh turned so that its triangles wind outward.

Scans and exports are often wound inward (normals pointing in). Every subsurface method reads the inside
of the medium from the winding and the normals, so an inward part drew 7x (IMAGE_SPACE) to 40x
(TEXTURE_SPACE) too dark, and the Cycles twin black. A part's signed volume (divergence theorem, about its
own centroid) is positive when it winds outward; a part with a negative one is turned. Parts that enclose
no volume (a plane, a leaf) are left as they are: they have no inside.
"""
from __future__ import annotations

import dataclasses

import numpy as np

# A part is turned when its signed volume is below -FLAT_SHARE of its bounding box's: an open sheet (a
# plane, a leaf) encloses about nothing either way and keeps its winding.
FLAT_SHARE = 1e-3


@dataclasses.dataclass(frozen=True)
class Orientation:
    flip: np.ndarray  # (T,) bool: triangles to turn (swap corners 1 and 2)
    parts: int  # connected parts that enclose a volume
    turned: int  # of those, wound inward and turned

    def message(self, name: str) -> str | None:
        """One line for the panel and the render log, or None when nothing was turned."""
        if not self.turned:
            return None
        which = "the mesh is" if self.parts == 1 else f"{self.turned} of its {self.parts} closed parts are"
        return (f"'{name}': {which} wound inward (normals point in); drawn turned outward. "
                f"Mesh > Normals > Recalculate Outside fixes the mesh itself")


def components(triangles: np.ndarray, vertex_count: int) -> tuple[int, np.ndarray]:
    """(count, label per triangle) of the parts connected through shared vertices."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    rows = np.concatenate([t[:, 0], t[:, 1]])
    cols = np.concatenate([t[:, 1], t[:, 2]])
    graph = coo_matrix((np.ones(len(rows), np.int8), (rows, cols)), shape=(vertex_count, vertex_count))
    count, label = connected_components(graph, directed=False)
    return count, label[t[:, 0]]


def orient_outward(positions: np.ndarray, triangles: np.ndarray) -> Orientation:
    """Per connected part, the triangles to turn so that it winds outward (positive signed volume).

    positions (V, 3); triangles (T, 3) indices into them. Vectorised: one connected-components pass, one
    bincount per measure.
    """
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    if not len(t):
        return Orientation(np.zeros(0, bool), 0, 0)
    return orient_parts(positions, t, components(t, len(positions)))


def orient_parts(positions: np.ndarray, triangles: np.ndarray, parts: tuple[int, np.ndarray]) -> Orientation:
    """``orient_outward`` with the parts already known (``components``): what a deforming mesh pays per frame,
    its connectivity being read once."""
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    p = np.asarray(positions, np.float64)
    count, part = parts
    if not len(t):
        return Orientation(np.zeros(0, bool), 0, 0)
    # Signed volume about each part's centroid (so an open part's value does not depend on the origin). Corners
    # as (3, T) rows: contiguous per coordinate, several times faster than (T, 3) columns.
    P = np.ascontiguousarray(p.T)
    A, B, C = (np.take(P, np.ascontiguousarray(t[:, k]), axis=1) for k in range(3))
    first = int(part[0])
    if count == 1 or (part == first).all():
        # The usual mesh, one part (loose vertices aside): whole-array reductions, no per-part bookkeeping.
        centroid = ((A.sum(axis=1) + B.sum(axis=1) + C.sum(axis=1)) / (3.0 * len(t)))[:, None]
        A, B, C = A - centroid, B - centroid, C - centroid
        volume = np.zeros(count)
        volume[first] = _triple(A, B, C).sum() / 6.0
        lo = np.full((count, 3), np.inf)
        hi = np.full((count, 3), -np.inf)
        lo[first] = np.minimum(np.minimum(A.min(axis=1), B.min(axis=1)), C.min(axis=1))
        hi[first] = np.maximum(np.maximum(A.max(axis=1), B.max(axis=1)), C.max(axis=1))
    else:
        weights = np.bincount(part, minlength=count).astype(np.float64) * 3.0
        S = A + B + C
        centroid = np.stack([np.bincount(part, S[k], minlength=count) for k in range(3)])
        centroid /= np.maximum(weights, 1.0)[None]
        offset = centroid[:, part]
        A, B, C = A - offset, B - offset, C - offset
        volume = np.bincount(part, _triple(A, B, C), minlength=count) / 6.0
        # Per-part boxes by sorted segments (ufunc.at took 60 ms for the bunny's corners), about each part's
        # own centroid (the box's extent is the same).
        order = np.argsort(part, kind="stable")
        sorted_part = part[order]
        starts = np.flatnonzero(np.r_[True, sorted_part[1:] != sorted_part[:-1]])
        ids = sorted_part[starts]
        lo = np.full((count, 3), np.inf)
        hi = np.full((count, 3), -np.inf)
        lo[ids] = np.minimum.reduceat(np.minimum(np.minimum(A, B), C)[:, order], starts, axis=1).T
        hi[ids] = np.maximum.reduceat(np.maximum(np.maximum(A, B), C)[:, order], starts, axis=1).T
    box = np.prod(hi - lo, axis=1)
    # (a part of loose vertices has no triangle and no box: it encloses nothing)
    encloses = np.isfinite(box) & (np.abs(volume) > FLAT_SHARE * box)
    inward = encloses & (volume < 0)
    return Orientation(inward[part], int(encloses.sum()), int(inward.sum()))


def _triple(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """a . (b x c) per column of (3, N) rows (six times the signed volume of the tetrahedron on the origin)."""
    return a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) + a[2] * (b[0] * c[1] - b[1] * c[0])


def turned(flip: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """A per-triangle corner array (T, 3, ...) with the flipped triangles turned (corners 0, 2, 1): vertex
    indices, positions, normals, loops alike."""
    out = np.array(corners, copy=True)
    out[flip] = out[flip][:, [0, 2, 1]]
    return out


def outward_normals(corner_positions: np.ndarray, normals: np.ndarray, flip: np.ndarray) -> np.ndarray:
    """Corner normals (T, 3, 3) of already-turned triangles (corner positions (T, 3, 3)), negated where a
    flipped triangle's normal points against its turned facet: Blender's computed normals follow the old
    winding, custom normals that already point out are kept."""
    p = np.asarray(corner_positions, np.float64)
    facet = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    out = np.array(normals, copy=True)
    against = (np.einsum("tij,tj->ti", out, facet) < 0) & np.asarray(flip, bool)[:, None]
    out[against] *= -1.0
    return out

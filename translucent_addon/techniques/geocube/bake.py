"""The GEOCUBE bake (Chan & Wang 2005, Sec. 2): cube placement, distance and normal cubes, cones A, B, C,
sphere D and the starting cube of every triangle.

Pure (NumPy, SciPy). Geometry in the bake frame: millimetres, ``stretch @ v * mm_per_unit`` (the object's
scale applied, its rotation and translation not), so that path lengths are physical and the shader's
world-to-bake transform is a scaled rotation.

Ray casting goes through a ``tracer`` with ``closest_hit(origins, dirs) -> (t, tri, u, v)``: Blender's BVH
when the Blender side passes it in (``BakeInputs.tracer_factory``: ``blender/bvh_tracer.py``), brute force
otherwise (tests on small meshes).

Placement (the paper placed cubes by hand and called automatic placement an open art-gallery problem):
candidate centres are the midpoints of inward rays from surface samples (points near the medial surface,
which see far); a greedy set cover adds the candidate that sees the most area not yet covered until every
surface sample is seen by some centre at an angle no flatter than ``GRAZING_COS`` (a surface seen edge-on is
sampled too coarsely by the cube to refract through). Coverage is reported.

Cones (Sec. 2.1, Fig. 4), per texel with surface point S at distance l from the centre O, normal N, and
the object's surface sampled at points P (area-uniform, about one per texel):
* cone A, apex S, base centre O: cos theta_A = max over P inside the finite cone of cos(angle(P - S, O - S)),
  and no wider than the tangent plane at S allows;
* cone B, apex O, base centre S on the tangent plane: cos theta_B = max over P behind the tangent plane by
  more than epsilon / 2 of cos(angle(P - O, S - O)) (epsilon: one texel's footprint);
* cone C, apex S, axis -N, half angle the critical angle asin(1 / eta): R_C = the distance to the nearest P
  inside it (k nearest neighbours; beyond them R_C is capped at the k-th distance, which is conservative);
* sphere D: the distance from O to the nearest triangle (exact point-triangle distance).
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from ...core.bake_checks import count, indices, shaped
from ...core.geometry import cubemap
from ...core.geometry.mesh_checks import triangle_areas
from ...core.geometry.mesh_measures import vertex_normals
from ...core.geometry.raycast import BruteForceTracer

GRAZING_COS = 0.15  # a centre covers a surface sample it sees at cos(angle to the normal) above this
COVERAGE_SAMPLES = 6000  # area-uniform surface samples the placement must cover
CANDIDATES = 240  # candidate centres tried by the greedy cover
MAX_CUBES = 64  # more cubes cost bake time, memory and a longer cube switch (each cube is tested there)
# The cone and normal atlases stack the cubes, res + 2 texels each, in one texture of at most this height (the
# least maximum OpenGL 4.5 guarantees): 63 cubes at 256 texels.
MAX_ATLAS_ROWS = 16384
TARGETED_ROUNDS = 3  # rounds of candidates placed for the samples still uncovered
TARGETED_SAMPLES = 48
RES_RANGE = (16, 256)
CONE_C_NEIGHBOURS = 48  # dense neighbours bounding the cones near each texel
COARSE_POINTS = 3000  # surface points bounding the cones everywhere
CONE_SAFETY = 0.98  # cone half-angle tangents shrunk by this factor against the surface sampling's gaps


class GeocubeError(ValueError):
    """The object cannot be covered by geocubes; the message says why in one line."""


@dataclasses.dataclass
class GeocubeSet:
    """Every cube of one object, in the bake frame (mm)."""

    centres: np.ndarray  # (C, 3)
    radius_D: np.ndarray  # (C,) inscribed sphere D
    res: int
    # (C, 6, res + 2, res + 2, 4): surface distance d, cos theta_A, cos theta_B, R_C (bordered faces)
    cones: np.ndarray
    normals: np.ndarray  # (C, 6, res + 2, res + 2, 3) unit normals at the surface samples
    start_cube: np.ndarray  # (T,) int: the cube a ray entering through triangle t starts in
    coverage: float  # fraction of the placement samples seen by some centre
    min_step: float  # delta of Sec. 2.3 (mm)
    size: float  # bounding-box diagonal (mm)

    @property
    def count(self) -> int:
        return len(self.centres)


@dataclasses.dataclass
class BakeParameters:
    """GEOCUBE's part of a bake's inputs (``BakeInputs.params``)."""

    resolution: int = 0  # cube face texels; 0: from the object's size on the camera's image (``resolution_for``)

    @classmethod
    def from_values(cls, values: dict) -> "BakeParameters":
        return cls(resolution=int(values.get("geocube_resolution", 0)))


def hash_parts(inputs, geometry: dict, material: dict) -> tuple[dict, dict]:
    """Cone C's half angle is the critical angle (eta); the rest is geometry. An automatic resolution is chosen
    once, at bake time: moving the camera later does not stale it."""
    return geometry, {"eta": material["eta"], "res": int(inputs.params.resolution) or "auto",
                      "stretch": np.round(inputs.stretch_matrix(), 9).ravel().tolist()}


def resolution_of(inputs) -> int:
    """The cube face texels a bake makes: the chosen ones, else from the object's size on screen."""
    return int(inputs.params.resolution) or resolution_for(inputs.screen_pixels)


def summary(meta: dict) -> list[str]:
    """What a GEOCUBE bake holds, for the object panel."""
    mb = meta.get("bytes", 0) / 2**20
    return [f"Cubes: {meta.get('geocube_cubes', 0)} of {meta.get('geocube_res', 0)}^2 texels a face, "
            f"{100 * meta.get('geocube_coverage', 0.0):.1f} % of the surface seen",
            f"Stored: {mb:.1f} MB, baked in {meta.get('seconds', meta.get('geocube_seconds', 0.0)):.1f} s"]


def resolution_for(screen_pixels: float | None) -> int:
    """Cube face resolution from the object's size on screen (the paper used 64 everywhere): about one
    texel per two pixels across the object (a face spans 90 degrees, a quarter of the way around), as a
    power of two in RES_RANGE; 64 when no camera sees the object."""
    if not screen_pixels or screen_pixels <= 0:
        return 64
    res = 2 ** int(round(np.log2(max(screen_pixels, 1.0) / 2.0)))
    return int(np.clip(res, *RES_RANGE))


def area_samples(v: np.ndarray, t: np.ndarray, n: int, seed: int = 0):
    """n area-uniform surface points, their smooth normals and triangle indices."""
    rng = np.random.default_rng(seed)
    area = triangle_areas(v, t)
    tri = rng.choice(len(t), size=n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    b = np.stack([1 - s, s * (1 - r2), s * r2], axis=1)
    p = np.einsum("nk,nkd->nd", b, v[t[tri]])
    vn = vertex_normals(v, t)
    nrm = np.einsum("nk,nkd->nd", b, vn[t[tri]])
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
    return p, nrm, tri


def face_normals(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)


def visibility(centres: np.ndarray, points: np.ndarray, normals: np.ndarray, tracer, faces=None) -> np.ndarray:
    """(C, P) bool: centre c sees point p unoccluded, at an angle to p's normal no flatter than GRAZING_COS.
    ``faces``: the samples' face normals, accepted as well (smooth normals twist on parts thinner than
    the smoothing, and would hide a sample no centre could see)."""
    seen = np.zeros((len(centres), len(points)), bool)
    for c, o in enumerate(centres):
        to = points - o
        dist = np.linalg.norm(to, axis=1)
        d = to / np.maximum(dist, 1e-12)[:, None]
        facing = np.einsum("pd,pd->p", d, normals) > GRAZING_COS
        if faces is not None:
            facing |= np.einsum("pd,pd->p", d, faces) > GRAZING_COS
        idx = np.flatnonzero(facing)
        t, _, _, _ = tracer.closest_hit(np.repeat(o[None], len(idx), 0), d[idx])
        seen[c, idx] = t >= dist[idx] * (1.0 - 1e-4) - 1e-6 * dist.max()
    return seen


def inside(points: np.ndarray, tracer) -> np.ndarray:
    """Parity test along three directions (majority): True for points inside the closed surface."""
    votes = np.zeros(len(points), int)
    for d in ((0.5773, 0.5774, 0.5773), (-0.2673, 0.5345, -0.8018), (0.8729, -0.2182, 0.4364)):
        d = np.array(d) / np.linalg.norm(d)
        count = np.zeros(len(points), int)
        o = points.copy()
        alive = np.ones(len(points), bool)
        for _ in range(16):  # up to 16 crossings
            if not alive.any():
                break
            idx = np.flatnonzero(alive)
            t, _, _, _ = tracer.closest_hit(o[idx], np.repeat(d[None], len(idx), 0))
            hit = np.isfinite(t)
            count[idx[hit]] += 1
            o[idx[hit]] += (t[hit] + 1e-7)[:, None] * d
            alive[idx[~hit]] = False
        votes += count % 2
    return votes >= 2


def candidates(points: np.ndarray, normals: np.ndarray, tracer, n: int, seed: int = 1):
    """Centres half-way along inward rays from n surface samples (near the medial surface), and the
    centroid of the mesh; only those inside the surface, deepest (longest inward ray) first."""
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(points), size=min(n, len(points)), replace=False)
    o = points[pick] - normals[pick] * 1e-6
    t, _, _, _ = tracer.closest_hit(o, -normals[pick])
    ok = np.isfinite(t)
    mids = o[ok] - normals[pick][ok] * (0.5 * t[ok])[:, None]
    order = np.argsort(-t[ok])
    cand = np.concatenate([points.mean(axis=0)[None], mids[order]])
    return cand[inside(cand, tracer)]


def place(points, normals, areas, tracer, n_candidates=CANDIDATES, max_cubes=MAX_CUBES, batch: int = 24,
          seed: int = 1, faces=None):
    """Greedy cover: centres (C, 3) and the fraction of sample area they cover together.

    Lazy: candidates are tried in batches, deepest first, and the greedy choice runs over those tried so
    far; a new batch is tried only while some area is still uncovered (a convex object stops after one)."""
    cand = candidates(points, normals, tracer, n_candidates, seed)
    if len(cand) == 0:
        raise GeocubeError("no point inside the surface was found for a geocube centre (is the mesh closed?)")
    seen = np.zeros((0, len(points)), bool)
    covered = np.zeros(len(points), bool)
    chosen: list[int] = []
    for start in range(0, len(cand), batch):
        seen = np.concatenate([seen, visibility(cand[start:start + batch], points, normals, tracer, faces)])
        while len(chosen) < max_cubes and not covered.all():
            gain = (seen & ~covered) @ areas
            best = int(np.argmax(gain))
            # Take a candidate now only if no untried one could do better: it covers at least half of
            # what is left, or every candidate has been tried.
            if gain[best] <= 0 or (start + batch < len(cand) and gain[best] < 0.5 * areas[~covered].sum()):
                break
            chosen.append(best)
            covered |= seen[best]
        if covered.all() or len(chosen) >= max_cubes:
            break
    # Targeted rounds for what is left (crevices, horns, the inside of a bend): candidates on the inward
    # normals of uncovered samples, near them, where they see the sample head-on.
    rng = np.random.default_rng(seed + 1)
    for _ in range(TARGETED_ROUNDS):
        if covered.all() or len(chosen) >= max_cubes:
            break
        miss = np.flatnonzero(~covered)
        pick = rng.choice(miss, size=min(TARGETED_SAMPLES, len(miss)), replace=False)
        o = points[pick] - normals[pick] * 1e-6
        t, _, _, _ = tracer.closest_hit(o, -normals[pick])
        # Points of the segment from a sample to the first surface behind it are inside by construction
        # (on a closed mesh), however thin the part: no parity test, which fails within a hair of a surface.
        ok = np.isfinite(t) & (t > 1e-9 * np.ptp(points, axis=0).max())
        extra = np.concatenate([o[ok] - normals[pick][ok] * (f * t[ok])[:, None] for f in (0.5, 0.25, 0.1)])
        if len(extra) == 0:
            break
        cand = np.concatenate([cand, extra])
        seen = np.concatenate([seen, visibility(extra, points, normals, tracer, faces)])
        while len(chosen) < max_cubes and not covered.all():
            gain = (seen & ~covered) @ areas
            best = int(np.argmax(gain))
            if gain[best] <= 0:
                break
            chosen.append(best)
            covered |= seen[best]
    return cand[chosen], float(areas[covered].sum() / areas.sum())


def point_triangle_distance(p: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Distance from one point p to each triangle (T, 3, 3) (Ericson, Real-Time Collision Detection 5.1.5)."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = p - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = p - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    den = np.where(np.abs(va + vb + vc) > 1e-30, va + vb + vc, 1e-30)
    v = vb / den
    w = vc / den
    q = a + ab * v[:, None] + ac * w[:, None]  # interior
    # Edge and vertex regions.
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ab = np.clip(d1 / np.where(d1 - d3 != 0, d1 - d3, 1), 0, 1)
        t_ac = np.clip(d2 / np.where(d2 - d6 != 0, d2 - d6, 1), 0, 1)
        t_bc = np.clip((d4 - d3) / np.where((d4 - d3) + (d5 - d6) != 0, (d4 - d3) + (d5 - d6), 1), 0, 1)
    on_ab = a + ab * t_ab[:, None]
    on_ac = a + ac * t_ac[:, None]
    on_bc = b + (c - b) * t_bc[:, None]
    cands = np.stack([q, on_ab, on_ac, on_bc, a, b, c])
    inside_face = (va >= 0) & (vb >= 0) & (vc >= 0)
    dist = np.linalg.norm(cands - p, axis=2)
    dist[0] = np.where(inside_face, dist[0], np.inf)
    return dist.min(axis=0)


def cube_surface(centre, res, tracer, v, t, vn):
    """Distance and interpolated normal of the first surface along every bordered texel direction."""
    dirs = cubemap.texel_directions(res).reshape(-1, 3)
    hit_t, tri, bu, bv = tracer.closest_hit(np.repeat(centre[None], len(dirs), 0), dirs)
    ok = np.isfinite(hit_t)
    tri_ok = np.where(ok, tri, 0)
    n = (1 - bu - bv)[:, None] * vn[t[tri_ok, 0]] + bu[:, None] * vn[t[tri_ok, 1]] + bv[:, None] * vn[t[tri_ok, 2]]
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    n[~ok] = dirs[~ok]
    return dirs, np.where(ok, hit_t, 0.0), n, ok


def _cone_cosines(centre, v_hat, l, S, N, epsilon, P):
    """Largest cos theta_A and cos theta_B the points P allow, per texel. P: (1 or t, p, 3)."""
    PS = P - S[:, None, :]
    PS_len = np.sqrt((PS * PS).sum(-1))
    # Cone A: apex S, axis -v_hat, length l (Chan & Wang Fig. 4).
    axial = -(PS * v_hat[:, None, :]).sum(-1)
    inA = (axial > 1e-4 * l[:, None]) & (axial <= l[:, None])
    cA = np.where(inA, axial / np.maximum(PS_len, 1e-20), -1.0).max(axis=1)
    # Cone B: apex O, axis v_hat, cut by the tangent plane at S; points behind it by more than epsilon/2.
    behind = (PS * N[:, None, :]).sum(-1) < -0.5 * epsilon[:, None]
    Pc = P - centre
    ax_B = (Pc * v_hat[:, None, :]).sum(-1)
    cB = np.where(behind & (ax_B > 0), ax_B / np.maximum(np.sqrt((Pc * Pc).sum(-1)), 1e-20), -1.0).max(axis=1)
    return cA, cB


def cone_parameters(centre, dirs, dist, normals, coarse, dense, eta: float, epsilon: np.ndarray,
                    chunk: int = 512):
    """cos theta_A, cos theta_B and R_C of every texel (see the module docstring).

    Two scales of surface points bound the cones: a coarse set everywhere (a far point's angle is
    resolved by a coarse sampling) and the ``CONE_C_NEIGHBOURS`` nearest of a dense set around each
    texel's sample (where the angles change fast). Cost: texels x (coarse + k), not texels x dense."""
    from scipy.spatial import cKDTree

    S = centre + dirs * dist[:, None]
    n_tex = len(dirs)
    tree = cKDTree(dense)
    k = min(CONE_C_NEIGHBOURS, len(dense))
    dk, ik = tree.query(S, k=k)
    dk, ik = dk.reshape(n_tex, k), ik.reshape(n_tex, k)
    near = dense[ik]  # (t, k, 3)
    cosA = np.empty(n_tex)
    cosB = np.empty(n_tex)
    far_C = np.empty(n_tex)
    cos_c = np.sqrt(1.0 - 1.0 / eta ** 2)
    far = np.asarray(coarse, np.float32)[None]
    near32 = near.astype(np.float32)
    for s in range(0, n_tex, chunk):
        sl = slice(s, s + chunk)
        args = tuple(np.asarray(x, np.float32) for x in (centre, dirs[sl], dist[sl], S[sl], normals[sl], epsilon[sl]))
        a1, b1 = _cone_cosines(*args, far)
        a2, b2 = _cone_cosines(*args, near32[sl])
        # No wider than the tangent plane at S allows: theta_A <= asin(|a . N|) = asin(v . N).
        a_dot_n = np.clip(np.einsum("td,td->t", dirs[sl], normals[sl]), 0.0, 1.0)
        cosA[sl] = np.maximum(np.maximum(a1, a2), np.sqrt(1.0 - a_dot_n ** 2))
        cosB[sl] = np.maximum(b1, b2)
        # Cone C among the coarse points (the dense neighbours may all lie outside it).
        PS = far - args[3][:, None, :]
        far_d = np.sqrt((PS * PS).sum(-1))
        inside_c = -(PS * args[4][:, None, :]).sum(-1) > cos_c * far_d
        far_C[sl] = np.where(inside_c & (far_d > 0.5 * args[5][:, None]), far_d, np.inf).min(axis=1)
    # Shrink each cone's tangent a little: the sampling of P leaves gaps a cone could reach into.
    cosA = _shrink(cosA)
    cosB = _shrink(np.maximum(cosB, 0.0))
    # Cone C: apex S, axis -N, half angle asin(1 / eta): the nearest dense point inside it, or else the
    # nearest coarse point inside it less the coarse spacing (a surface between coarse samples).
    to = near - S[:, None, :]
    cos_to = -np.einsum("tkd,td->tk", to, normals) / np.maximum(dk, 1e-20)
    min_d = 0.5 * epsilon[:, None]  # the sample's own neighbourhood on the tangent plane
    in_c = (cos_to > cos_c) & (dk > min_d)
    R_C = np.where(in_c, dk, np.inf).min(axis=1)
    spacing = np.sqrt(np.pi * np.max(dk[:, -1]) ** 2 / k * len(dense) / max(len(coarse), 1))
    # No coarse point in the cone either (the cone leaves through a gap of the sampling): the k-th
    # neighbour's distance, which is conservative.
    beyond = np.where(np.isfinite(far_C), np.maximum(dk[:, -1], far_C - spacing), dk[:, -1])
    R_C = np.where(np.isfinite(R_C), R_C, beyond) * CONE_SAFETY
    return cosA, cosB, R_C


def _shrink(cos_theta: np.ndarray) -> np.ndarray:
    c = np.clip(cos_theta, 1e-6, 1.0)
    tan = np.sqrt(1.0 - c * c) / c * CONE_SAFETY
    return 1.0 / np.sqrt(1.0 + tan * tan)


def starting_cubes(v, t, centres, tracer) -> np.ndarray:
    """Per triangle: the nearest centre that sees its centroid from inside (Sec. 2.3), else the nearest."""
    cen = v[t].mean(axis=1)
    fn = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-30)
    dist = np.linalg.norm(cen[:, None, :] - centres[None], axis=2)  # (T, C)
    sees = np.zeros_like(dist, bool)
    for c, o in enumerate(centres):
        to = cen - o
        d = to / np.maximum(dist[:, c], 1e-30)[:, None]
        facing = np.einsum("td,td->t", d, fn) > 0
        idx = np.flatnonzero(facing)
        th, _, _, _ = tracer.closest_hit(np.repeat(o[None], len(idx), 0), d[idx])
        sees[idx, c] = th >= dist[idx, c] * (1 - 1e-4) - 1e-9
    rank = np.where(sees, dist, dist + 1e30)
    return np.argmin(rank, axis=1).astype(np.int32)


def build(v_mm, t, res: int, eta: float, tracer, coverage_samples: int = COVERAGE_SAMPLES) -> GeocubeSet:
    """Place the cubes and fill them (``build_steps`` run to the end)."""
    job = build_steps(v_mm, t, res, eta, tracer, coverage_samples)
    while True:
        try:
            next(job)
        except StopIteration as done:
            return done.value


def build_steps(v_mm, t, res: int, eta: float, tracer, coverage_samples: int = COVERAGE_SAMPLES):
    """Generator: yields (fraction, text) between steps, returns the GeocubeSet."""
    v = np.asarray(v_mm, np.float64)
    t = np.asarray(t, np.int64)
    size = float(np.linalg.norm(v.max(0) - v.min(0)))
    pts, nrm, tri = area_samples(v, t, coverage_samples, seed=0)
    areas = np.full(len(pts), 1.0 / len(pts))
    yield 0.05, "placing cubes"
    centres, coverage = place(pts, nrm, areas, tracer, max_cubes=min(MAX_CUBES, MAX_ATLAS_ROWS // (res + 2)),
                              faces=face_normals(v, t)[tri])
    tris = v[t]
    radius_D = np.array([point_triangle_distance(o, tris).min() for o in centres])
    vn = vertex_normals(v, t)
    n_dense = int(np.clip(6 * res * res, 2000, 60000))
    dense, _, _ = area_samples(v, t, n_dense, seed=2)
    coarse, _, _ = area_samples(v, t, COARSE_POINTS, seed=3)
    w = res + 2
    cones = np.zeros((len(centres), 6, w, w, 4), np.float32)
    normals = np.zeros((len(centres), 6, w, w, 3), np.float32)
    for c, o in enumerate(centres):
        yield 0.1 + 0.8 * c / len(centres), f"cube {c + 1} of {len(centres)}: surface and cones"
        dirs, dist, n, ok = cube_surface(o, res, tracer, v, t, vn)
        # epsilon: one texel's footprint at the sample (a face spans 2 / res in tan units).
        epsilon = np.maximum(dist, 1e-9) * (2.0 / res)
        cosA, cosB, R_C = cone_parameters(o, dirs, dist, n, coarse, dense, eta, epsilon)
        block = np.stack([dist, cosA, cosB, R_C], axis=1)
        block[~ok] = (0.0, 1.0, 1.0, 0.0)  # no surface: a ray here is outside at once
        cones[c] = block.reshape(6, w, w, 4)
        normals[c] = n.reshape(6, w, w, 3)
    yield 0.92, "starting cube of each triangle"
    start = starting_cubes(v, t, centres, tracer)
    mean_l = float(np.mean(cones[..., 0][cones[..., 0] > 0])) if (cones[..., 0] > 0).any() else size
    min_step = 0.5 * mean_l * 2.0 / res  # half a texel's footprint at the mean distance
    return GeocubeSet(centres=centres, radius_D=radius_D, res=res, cones=cones, normals=normals,
                      start_cube=start, coverage=coverage, min_step=min_step, size=size)


def to_arrays(g: GeocubeSet) -> dict[str, np.ndarray]:
    return {
        "gc_centres": g.centres.astype(np.float32).ravel(),
        "gc_radius_D": g.radius_D.astype(np.float32),
        "gc_cones": g.cones.astype(np.float32).ravel(),
        "gc_normals": g.normals.astype(np.float32).ravel(),
        "gc_start_cube": g.start_cube.astype(np.int32),
        "gc_scalars": np.array([g.res, g.coverage, g.min_step, g.size], np.float32),
    }


# The largest cube face a bake makes is 256 texels; a stored side past this is damage.
MAX_RES = 1024


def from_arrays(a: dict) -> GeocubeSet:
    """The GeocubeSet of a stored bake, checked (DamagedBakeError: ``core/bake_checks``): the shaders loop over
    its cubes and fetch at the cube indices it stores."""
    res, coverage, min_step, size = (float(x) for x in shaped(a, "gc_scalars", (4,)))
    res = count(res, "cube resolution", 1, MAX_RES)
    centres = np.asarray(a["gc_centres"], np.float64).reshape(-1, 3)
    # The shaders' cube switch loops over every cube for each step of each pixel (a bake makes at most MAX_CUBES;
    # bakes of before the atlas limit may hold more), and the atlases stack them in one texture.
    C, w = count(len(centres), "cube count", 1, min(4 * MAX_CUBES, MAX_ATLAS_ROWS // (res + 2))), res + 2
    indices(a, "gc_start_cube", (None,), C)
    return GeocubeSet(
        centres=centres, radius_D=np.asarray(a["gc_radius_D"], np.float64), res=res,
        cones=np.asarray(a["gc_cones"], np.float32).reshape(C, 6, w, w, 4),
        normals=np.asarray(a["gc_normals"], np.float32).reshape(C, 6, w, w, 3),
        start_cube=np.asarray(a["gc_start_cube"], np.int32), coverage=coverage, min_step=min_step, size=size)


def default_tracer(tris: np.ndarray, factory=None):
    """The tracer ``factory`` makes of the triangles (the Blender side passes its BVH in, ``BakeInputs.
    tracer_factory``), brute force when there is none or it cannot load (ImportError: no Blender)."""
    if factory is not None:
        try:
            return factory(tris)
        except ImportError:
            pass
    return BruteForceTracer(tris)


def bake(inputs):
    """Generator (fraction, text) -> (arrays, meta) for the registry."""
    t0 = time.perf_counter()
    v = (inputs.stretch_matrix() @ np.asarray(inputs.vertices, np.float64).T).T * float(inputs.mm_per_unit)
    t = np.asarray(inputs.triangles, np.int64)
    res = resolution_of(inputs)
    tracer = default_tracer(v[t], inputs.tracer_factory)
    yield 0.0, f"geocube: {res}x{res}x6 cubes"
    job = build_steps(v, t, res, float(inputs.eta), tracer)
    while True:
        try:
            fraction, text = next(job)
            yield fraction, f"geocube: {text}"
        except StopIteration as done:
            g = done.value
            break
    arrays = to_arrays(g)
    arrays["stretch"] = inputs.stretch_matrix().astype(np.float32).ravel()
    meta = {"geocube_cubes": g.count, "geocube_res": res, "geocube_coverage": round(g.coverage, 5),
            "geocube_seconds": round(time.perf_counter() - t0, 2),
            "bytes": int(sum(a.nbytes for a in arrays.values()))}
    yield 1.0, f"geocube: {g.count} cubes cover {100 * g.coverage:.1f} % of the surface"
    return arrays, meta

"""CPU reference of the dipole model itself: what a subsurface method should converge to.

For each camera pixel that sees a translucent mesh at x_o (Shah Eq. 6.13-6.15, Jensen 2001):

    L_o(x_o) = F_t(eta, w_o) / pi * a(n . w_o) * int_A R_d(|x_i - x_o|) C(h) E(x_i) dA(x_i)  +  F_r(eta, w_o) L_world(r)

with C(h) the thin-part factor of x_i lying h below x_o's tangent plane (``physics.slab_through``), a the
profile's angular law (``physics.angular_law``; 1 for the papers' dipole) and L_world(r) the world's radiance in
the mirror direction (SH order 2, as the surface layer draws a smooth boundary); the light of pairs across a thin
part leaves by the diffusion mode's law M(mu_o) in place of a(mu_o), over the factor's ramp.
    E(x_i)   = sum_lights I / d^2 F_t(eta, w_i) a(n . w_i) (n . w_i) V(x_i)  +  pi L_world (1 - F_dr_in)
               (an environment image: its irradiance E_sh(n) in spherical harmonics, Shah Eq. 6.19)

The integral is split by a smooth partition of unity w(r) (0 below rho, 1 above 2 rho): the near
part takes E as E(x_o) and integrates R_d (1 - w) radially (1-D quadrature, so the sharp peak at
r = 0 costs nothing), and the samples inside 2 rho add R_d (1 - w) (E(x_i) - E(x_o)) dA, the part
of a shadow edge crossing the disk that E(x_o) misses (nothing where E is uniform); the far part
is a midpoint quadrature over the surface, each triangle cut into n x n equal sub-triangles no
larger than the target sample area, gathered with a KD-tree up to r_max (99.9 % of the profile's
energy). rho is two sample spacings, so the far integrand is smooth on the sample grid. The near
part stands for x_o's tangent disk: points well off that plane (the far side of a thin part) keep
their whole share in the far part (``partition_off_plane``), as in IMAGE_SPACE. This measures a GPU
method's discretisation error apart from the dipole's own model error. Light crosses only within
one mesh (no bleeding between objects), as in the GPU methods.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..frame import FrameInputs, Medium, MeshInstance  # noqa: F401  (Medium re-exported)
from ..geometry.camera import pixel_rays
from ..geometry.mesh_measures import facing_side, subtriangle_centroids
from ..geometry.raycast import BruteForceTracer
from ..physics import angular_law, exit_lean, oblique_entry, slab_through
from ..physics.fresnel import fresnel_dielectric
from ..physics.lut import near_integral, partition_off_plane, profile_model
from ..physics.sh_irradiance import irradiance, sh_basis, transmittance_kernel
from .lambert import render_lambert, scene_triangles, shadowed_irradiance


def sample_surface(mesh: MeshInstance, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """About ``count`` quadrature points on a mesh (world space): centroids of equal sub-triangles.

    Returns points (N, 3), interpolated normals (N, 3), the area each point stands for (N,) and the
    facet normals (N, 3), turned to the interpolated normal's side.
    """
    return surface_samples(mesh, count)[:4]


def surface_samples(mesh: MeshInstance, count: int) -> tuple[np.ndarray, ...]:
    """``sample_surface``'s arrays, each point's triangle (N,) and its barycentric coordinates (N, 3)."""
    tris = mesh.world_positions().reshape(-1, 3, 3)
    nors = mesh.world_normals().reshape(-1, 3, 3)
    areas = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    target = float(areas.sum()) / count
    splits = np.maximum(1, np.ceil(np.sqrt(areas / target))).astype(int)
    points, normals, weights, facets, triangles, barys = [], [], [], [], [], []
    n_g = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n_g /= np.maximum(np.linalg.norm(n_g, axis=1, keepdims=True), 1e-30)
    for n in np.unique(splits):
        sel = np.flatnonzero(splits == n)
        uv = subtriangle_centroids(int(n))
        w0 = 1.0 - uv[:, 0] - uv[:, 1]
        bary = np.stack([w0, uv[:, 0], uv[:, 1]], axis=1)  # (k, 3)
        points.append(np.einsum("kc,tcd->tkd", bary, tris[sel]).reshape(-1, 3))
        normals.append(np.einsum("kc,tcd->tkd", bary, nors[sel]).reshape(-1, 3))
        weights.append(np.repeat(areas[sel] / n**2, len(uv)))
        facets.append(np.repeat(n_g[sel], len(uv), axis=0))
        triangles.append(np.repeat(sel, len(uv)))
        barys.append(np.tile(bary, (len(sel), 1)))
    normals = np.concatenate(normals)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-20)
    return (np.concatenate(points), normals, np.concatenate(weights), facing_side(np.concatenate(facets), normals),
            np.concatenate(triangles), np.concatenate(barys))


def transmitted_irradiance(frame: FrameInputs, points: np.ndarray, normals: np.ndarray, medium: Medium, tracer: Any,
                           scale: float, facet_normals: np.ndarray, angular: np.ndarray | None = None,
                           gradient: np.ndarray | None = None) -> np.ndarray:
    """E(x) (N, 3) entering the medium: lights with Fresnel transmission and shadow rays, plus the world.
    ``angular``: the angular law's table, weighing each light's power by a(cos_i) (the world's light is diffuse:
    a averages 1 over it). ``gradient`` (N, 3, 3): the shape operator at each point (the corners'
    ``oblique_entry.corner_shape_operators`` interpolated): a light's cosine is then read where its light entered
    (``physics.oblique_entry``, the EXACT profile's; IMAGE_SPACE's ``oblique_cosine``).

    The cosine is the interpolated normal's; visibility is the facet's, as a light's view (IMAGE_SPACE
    samples, shadow maps) and Cycles' shadow rays (offset along the facet normal) see it: a facet that
    faces away from the light is hidden by the surface in front of it even where the interpolated
    normal still faces the light (near the terminator of a coarse mesh).
    """
    p_off = points + facet_normals * 1e-4 * scale
    E = np.zeros((len(points), 3))
    # ell in world units
    ell = oblique_entry.medium_shift_mm(medium) / medium.mm_per_unit if gradient is not None else np.zeros(3)
    for E_e, to_light in shadowed_irradiance(frame.emitters, p_off, normals, tracer):
        cos_i = np.einsum("ij,ij->i", normals, to_light)
        facing = np.einsum("ij,ij->i", facet_normals, to_light) > 0
        if ell.any():  # E_e holds cos_i: the cosine where the light entered instead
            lit = cos_i > 0.0
            E_e = E_e.copy()
            E_e[lit] *= (oblique_entry.entering_cosine(to_light[lit], normals[lit], gradient[lit], ell, medium.eta)
                         / cos_i[lit, None])
        transmitted = E_e * ((1.0 - fresnel_dielectric(cos_i, medium.eta)) * facing)[:, None]
        E += transmitted if angular is None else transmitted * angular_law.lookup(angular, cos_i)
    # The world's irradiance through the boundary, unoccluded, to SH order 2 (Shah Eq. 6.19); for a
    # uniform world exactly pi L (1 - F_dr).
    E += irradiance(frame.world_sh(), transmittance_kernel(medium.eta), normals)
    return E


def render_dipole(frame: FrameInputs, media: dict[str, Medium], samples: int = 200_000,
                  epsilon: float = 1e-3, tracer: Any = None, max_pairs: int = 20_000_000,
                  entry_shift: bool = True, lean: bool = True) -> np.ndarray:
    """Linear RGBA image: the dipole model on meshes named in ``media``; other meshes as the Lambert base.
    ``entry_shift``: light entering at an angle is read where it entered (``physics.oblique_entry``, the
    EXACT profile's, as IMAGE_SPACE and TEXTURE_SPACE draw it). ``lean``: the
    light leaving leans away from where it entered (``physics.exit_lean``, the EXACT profile's, on every
    pair, those across a thin part too, as IMAGE_SPACE's splats draw it; not TEXTURE_SPACE's: False).

    ``tracer`` answers ray queries over the frame's triangles in order (``closest_hit`` and
    ``occluded``); by default a brute-force one, fine for test scenes of a few thousand triangles.
    """
    from scipy.spatial import cKDTree

    all_tris, _, _ = scene_triangles(frame)
    tracer = tracer or BruteForceTracer(all_tris)
    image = render_lambert(frame, tracer=tracer)
    cam = frame.camera
    origins, dirs = pixel_rays(cam.view_proj, cam.width, cam.height)
    origins, dirs = origins.reshape(-1, 3), dirs.reshape(-1, 3)
    scale = max(float(np.ptp(all_tris.reshape(-1, 3), axis=0).max()), 1e-6) if len(all_tris) else 1.0
    t, tri, u, v = tracer.closest_hit(origins, dirs)
    offsets = np.cumsum([0] + [m.triangle_count for m in frame.meshes])
    flat = image.reshape(-1, 4)
    for k, mesh in enumerate(frame.meshes):
        medium = media.get(mesh.name)
        if medium is None:
            continue
        mine = (tri >= offsets[k]) & (tri < offsets[k + 1])
        if not mine.any():
            continue
        # Receiving points x_o and their normals.
        ti = tri[mine] - offsets[k]
        nors = mesh.world_normals().reshape(-1, 3, 3)
        uu, vv = u[mine, None], v[mine, None]
        x_o = origins[mine] + t[mine, None] * dirs[mine]
        n_o = (1 - uu - vv) * nors[ti, 0] + uu * nors[ti, 1] + vv * nors[ti, 2]
        n_o /= np.linalg.norm(n_o, axis=1, keepdims=True)
        to_eye = -dirs[mine]
        cos_o = np.abs(np.einsum("ij,ij->i", n_o, to_eye))
        # Emitting points x_i.
        tri_o = mesh.world_positions().reshape(-1, 3, 3)[ti]
        g_o = facing_side(np.cross(tri_o[:, 1] - tri_o[:, 0], tri_o[:, 2] - tri_o[:, 0]), n_o)
        g_o /= np.maximum(np.linalg.norm(g_o, axis=1, keepdims=True), 1e-30)
        x_i, n_i, area, g_i, tri_i, bary_i = surface_samples(mesh, samples)
        # The normal field per triangle (a light's cosine is read where its light entered: physics.oblique_entry).
        shape = oblique_entry.corner_shape_operators(mesh.world_positions().reshape(-1, 3, 3), nors)
        mm = medium.mm_per_unit
        sa, ss = np.asarray(medium.sigma_a, float), np.asarray(medium.sigma_s_prime, float)
        model = profile_model(medium.profile)  # the medium's own profile: this is the discretisation check
        angular = model.angular_table(sa, ss, medium.eta)
        E_i = transmitted_irradiance(frame, x_i, n_i, medium, tracer, scale, g_i, angular,
                                     np.einsum("nc,ncij->nij", bary_i, shape[tri_i]) if entry_shift else None)
        bary_o = np.concatenate([1 - uu - vv, uu, vv], axis=1)
        E_o = transmitted_irradiance(frame, x_o, n_o, medium, tracer, scale, g_o, angular,
                                     np.einsum("nc,ncij->nij", bary_o, shape[ti]) if entry_shift else None)
        area_mm2 = area * mm * mm
        rho = 2.0 * math.sqrt(float(area_mm2.max()))  # two sample spacings
        reach = max(float(np.max(model.r_max(sa, ss, medium.eta, epsilon))), 2 * rho) / mm
        total = E_o * near_integral(sa, ss, medium.eta, rho, profile=medium.profile)
        slab = slab_through.constants(sa, ss, medium.eta, layered=medium.layer_thickness_mm is not None)
        # M(mu_o) / a(mu_o) per receiver: how light across a thin part leaves, over the angular law (EXACT only).
        through = None if medium.profile != "EXACT" else angular_law.through_exit_ratio(sa, ss, medium.eta, cos_o)
        leans = lean and medium.profile == "EXACT" and medium.layer_thickness_mm is None
        tree_i = cKDTree(x_i)
        # Gather in chunks of receivers so that the pair list stays near max_pairs in memory.
        neighbours = len(x_i) * min(1.0, math.pi * reach**2 / max(float(area.sum()), 1e-30))
        chunk = max(1, int(max_pairs / max(neighbours, 1.0)))
        for start in range(0, len(x_o), chunk):
            stop = min(start + chunk, len(x_o))
            pairs = cKDTree(x_o[start:stop]).sparse_distance_matrix(tree_i, reach, output_type="coo_matrix")
            r_mm = pairs.data * mm
            rows, cols = pairs.row, pairs.col
            h_mm = np.abs(np.einsum("ij,ij->i", x_i[cols] - x_o[start + rows], n_o[start + rows])) * mm
            weight = partition_off_plane(r_mm, rho, h_mm) * area_mm2[cols]
            # Far part: E_i w A_i. Near part: the disk integral took E(x_o); the samples add what E
            # differs from it there, (E_i - E_o)(1 - w) A_i, so a shadow edge inside the disk is
            # resolved on the sample grid (zero for a uniform E, which the disk integral has exactly).
            near_share = area_mm2[cols] - weight
            depth_mm = np.einsum("ij,ij->i", x_o[start + rows] - x_i[cols], n_o[start + rows]) * mm
            ramp = slab_through.ramp(depth_mm, slab[1])
            contrib = model.R_d(r_mm[:, None], sa, ss, medium.eta) * (
                E_i[cols] * area_mm2[cols, None] - E_o[start + rows] * near_share[:, None])
            if leans:  # the light leaving leans away from x_i: the far part's, and the near part's E_i - E_o (the
                # disk's E(x_o), even about x_o, leans to nothing; leaning it pair by pair would weigh R_d's
                # unresolved peak at the nearest samples)
                contrib *= exit_lean.pair_factor(exit_lean.beta(r_mm, sa, ss, medium.eta), x_i[cols],
                                                 x_o[start + rows], n_o[start + rows], to_eye[start + rows])
            # Light through thin parts, as the methods draw it.
            contrib *= slab_through.factor(depth_mm, *slab)
            if through is not None:  # ... and leaves by the diffusion mode's law, not a(mu_o) (angular_law)
                contrib *= 1.0 + (through[start + rows] - 1.0) * ramp
            for c in range(3):
                total[start:stop, c] += np.bincount(rows, weights=contrib[:, c], minlength=stop - start)
        F_r = fresnel_dielectric(cos_o, medium.eta)[:, None]
        # Subsurface light, plus the smooth boundary's reflection of the world (unoccluded), its radiance in the
        # mirror direction to SH order 2, as the surface layer draws a smooth medium's (roughness 0).
        n_f = n_o * np.sign(np.einsum("ij,ij->i", n_o, to_eye))[:, None]
        mirror = 2.0 * np.einsum("ij,ij->i", n_f, to_eye)[:, None] * n_f - to_eye
        L_world = np.maximum(sh_basis(mirror) @ np.asarray(frame.world_sh(), np.float64)[:, :3], 0.0)
        L = (1.0 - F_r) / math.pi * angular_law.lookup(angular, cos_o) * total + F_r * L_world
        flat[np.flatnonzero(mine), :3] = L
    return image

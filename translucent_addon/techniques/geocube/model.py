"""GEOCUBE at run time, in NumPy: the cone-propelled exit search (Chan & Wang 2005, Sec. 2.2-2.3), the
appendix's step functions, and the GPU atlases. Pure; the twin of ``gpu_shaders/geocube/cube_search.glsl`` line by
line, so the GPU pass is tested against it and the search is measured against exact ray casting.

The search, per ray (origin on the surface, unit direction r inside):
1. p = origin + r max(R_C, delta) (cone C: a refracted ray travels at least R_C inside);
2. repeat up to ``max_steps``: q = p - O, l = |q|;
   inside sphere D: step to its surface; else fetch d, cos theta_A, cos theta_B, N in q's direction
   (bilinear); if l >= d the current cube no longer sees p inside: switch to the cube that does and
   whose centre lies nearest the plane through p perpendicular to p - O (Sec. 2.3; the paper picks by
   the plane rule alone, we also require that the new cube sees p inside, which tells a cube switch from
   an exit); if none does, p has left the object: the exit lies between the last point and p and is
   found by bisection (``REFINE`` halvings); else step max(cone A, cone B, delta);
3. no exit within the cap: a premature exit at the last fetched surface point O + d q/l (the paper's rule).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.geometry import cubemap

REFINE = 6  # bisection steps once an exit is bracketed
NO_STEP = 1.0e30


def c_star(mu, gamma):
    """Appendix: distance from a unit cone's apex-side axis point to its lateral surface, per unit of
    (1 - f): C*(mu, gamma) = sqrt(1 - mu^2) / (gamma sqrt(1 - mu^2) + mu sqrt(1 - gamma^2))."""
    s_mu = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    den = gamma * s_mu + mu * np.sqrt(np.maximum(1.0 - gamma * gamma, 0.0))
    return s_mu / np.maximum(den, 1e-30)


def s_star(f, gamma):
    """Appendix: distance along the ray to a unit sphere's surface from a point at distance f from its
    centre, gamma = cosine between the ray and the centre-to-point direction."""
    return np.sqrt(np.maximum(1.0 - f * f * (1.0 - gamma * gamma), 0.0)) - f * gamma


def cone_step(f, h, a, n, mu):
    """Appendix C(f, h, a, n, mu): distance along unit ray h from the axis point at distance f from the
    base centre to the boundary of a unit cone (apex to base centre = 1) with axis a (apex to base), base
    normal n and half-apex cosine mu: the nearer of the lateral surface and the base plane."""
    ha = np.einsum("...d,...d->...", h, a)
    hn = np.einsum("...d,...d->...", h, n)
    an = np.einsum("...d,...d->...", a, n)
    lateral = np.where(ha < mu, (1.0 - f) * c_star(mu, -ha), np.inf)
    base = np.where(hn > 1e-12, f * an / np.where(hn > 1e-12, hn, 1.0), np.inf)
    out = np.minimum(lateral, base)
    return np.where(np.isfinite(out), out, 0.0)


@dataclasses.dataclass(frozen=True)
class MediumExtras:
    """GEOCUBE's own part of an object's medium (``Medium.extras``)."""

    max_steps: int = 32  # cap on the exit search's steps


@dataclasses.dataclass
class Atlases:
    """The GPU layout: cube c's six bordered faces in rows [c (res + 2), (c + 1)(res + 2))."""

    res: int
    cones: np.ndarray  # (C (res + 2), 6 (res + 2), 4): d, cos theta_A, cos theta_B, R_C
    normals: np.ndarray  # (C (res + 2), 6 (res + 2), 4): N, 0
    centres: np.ndarray  # (C, 4): O, radius of sphere D


def atlases(gset) -> Atlases:
    w = gset.res + 2
    C = gset.count
    cones = np.concatenate([cubemap.atlas_from_faces(gset.cones[c]) for c in range(C)], axis=0)
    nrm = np.concatenate([cubemap.atlas_from_faces(gset.normals[c]) for c in range(C)], axis=0)
    nrm = np.concatenate([nrm, np.zeros(nrm.shape[:2] + (1,), nrm.dtype)], axis=2)
    centres = np.concatenate([gset.centres, gset.radius_D[:, None]], axis=1)
    assert cones.shape == (C * w, 6 * w, 4)
    return Atlases(gset.res, cones.astype(np.float32), nrm.astype(np.float32), centres.astype(np.float64))


def fetch(at: Atlases, cube: np.ndarray, q: np.ndarray):
    """Bilinear (d, cos A, cos B, R_C) and normal of cube ``cube`` (per ray) in directions q."""
    out = np.empty(q.shape[:-1] + (4,))
    nrm = np.empty(q.shape[:-1] + (3,))
    w = at.res + 2
    for c in np.unique(cube):
        m = cube == c
        out[m] = cubemap.sample_atlas(at.cones, at.res, q[m], row0=int(c) * w)
        nrm[m] = cubemap.sample_atlas(at.normals, at.res, q[m], row0=int(c) * w)[..., :3]
    nrm /= np.maximum(np.linalg.norm(nrm, axis=-1, keepdims=True), 1e-20)
    return out, nrm


def inside_cube(at: Atlases, cube, p):
    """True where cube ``cube`` sees p inside the surface (|p - O| < d in p's direction)."""
    q = p - at.centres[cube, :3]
    l = np.linalg.norm(q, axis=-1)
    d, _ = fetch(at, cube, q)
    return (l < d[..., 0]) | (l < at.centres[cube, 3])


def surely_inside_cube(at: Atlases, cube, p):
    """The strict test a cube switch needs: p is inside by more than a texel's footprint under the
    nearest of the four texels around its direction. Bilinear d blends a near and a far surface across
    a depth edge of a cube that sees the object's parts behind one another, and a cube that sees the
    surface near p edge-on represents it only to within a texel's footprint; either would take a point
    just outside the object for one inside and carry the ray through a thin part."""
    q = p - at.centres[cube, :3]
    l = np.linalg.norm(q, axis=-1)
    w = at.res + 2
    d_min = np.full(l.shape, np.inf)
    for c in np.unique(cube):
        m = cube == c
        d_min[m] = cubemap.gather_min(at.cones[..., 0], at.res, q[m], row0=int(c) * w)
    return (l < d_min * (1.0 - 1.0 / at.res)) | (l < at.centres[cube, 3])


@dataclasses.dataclass
class Exit:
    point: np.ndarray  # (R, 3)
    normal: np.ndarray  # (R, 3) outward
    cube: np.ndarray  # (R,) the cube that saw the ray last
    steps: np.ndarray  # (R,) fetch iterations used
    premature: np.ndarray  # (R,) bool: the cap was reached


def switch_cube(at: Atlases, cube, p):
    """The cube that sees p inside and whose centre is nearest the plane through p perpendicular to p - O
    of the current cube; -1 where no cube sees p inside."""
    C = len(at.centres)
    O = at.centres[:, :3]
    w_hat = O[cube] - p
    w_hat /= np.maximum(np.linalg.norm(w_hat, axis=-1, keepdims=True), 1e-20)
    best = np.full(len(p), -1)
    best_dist = np.full(len(p), np.inf)
    for k in range(C):
        ks = np.full(len(p), k)
        ok = surely_inside_cube(at, ks, p) & (ks != cube)
        plane = np.abs(np.einsum("rd,rd->r", O[k] - p, w_hat))
        better = ok & (plane < best_dist)
        best[better] = k
        best_dist[better] = plane[better]
    return best


def exit_search(at: Atlases, origin, r, start_cube, max_steps: int, min_step: float, first_step=True) -> Exit:
    """The search of the module docstring, vectorised over rays."""
    R = len(origin)
    r = r / np.linalg.norm(r, axis=1, keepdims=True)
    cube = np.asarray(start_cube, np.int64).copy()
    O = at.centres[:, :3]
    D = at.centres[:, 3]
    p = origin.astype(np.float64).copy()
    if first_step:
        vals, _ = fetch(at, cube, p - O[cube])
        p += r * np.maximum(vals[:, 3], min_step)[:, None]
    prev = origin.astype(np.float64).copy()
    prev_cube = cube.copy()
    done = np.zeros(R, bool)
    steps = np.zeros(R, np.int64)
    point = np.zeros((R, 3))
    last_surface = origin.astype(np.float64).copy()
    for _ in range(max_steps):
        live = np.flatnonzero(~done)
        if len(live) == 0:
            break
        steps[live] += 1
        pl, cl, rl = p[live], cube[live], r[live]
        q = pl - O[cl]
        l = np.linalg.norm(q, axis=1)
        in_D = l < D[cl]
        step = np.zeros(len(live))
        # Sphere D (Sec. 2.1): step to its surface, D S*(l / D, r . v).
        if in_D.any():
            v = q[in_D] / np.maximum(l[in_D], 1e-20)[:, None]
            Dk = D[cl[in_D]]
            step[in_D] = Dk * s_star(l[in_D] / Dk, np.einsum("rd,rd->r", rl[in_D], v))
        out = ~in_D
        if out.any():
            idx = np.flatnonzero(out)
            v = q[idx] / l[idx, None]
            vals, N = fetch(at, cl[idx], q[idx])
            d, cosA, cosB = vals[:, 0], vals[:, 1], vals[:, 2]
            last_surface[live[idx]] = O[cl[idx]] + v * d[:, None]
            outside = l[idx] >= d
            if outside.any():
                o_idx = idx[outside]
                other = switch_cube(at, cl[o_idx], pl[o_idx])
                sw = other >= 0
                cube[live[o_idx[sw]]] = other[sw]
                ex = live[o_idx[~sw]]
                if len(ex):
                    point[ex] = _bisect(at, prev[ex], p[ex], prev_cube[ex])
                    done[ex] = True
            ins = ~outside
            if ins.any():
                ii = idx[ins]
                lv, dv = l[ii], d[ins]
                hv = rl[ii]
                vi = v[ins]
                # Chan & Wang Sec. 2.2: |r| = (c + l) C(l / (c + l), r, -v, -v, cos theta_A) for cone A,
                # (c + l) C(c / (c + l), r, v, N, cos theta_B) for cone B, with c + l = d.
                sA = dv * cone_step(lv / dv, hv, -vi, -vi, cosA[ins])
                sB = dv * cone_step((dv - lv) / dv, hv, vi, N[ins], cosB[ins])
                step[ii] = np.maximum(sA, sB)
        moving = ~done[live]
        mv = live[moving]
        prev[mv] = p[mv]
        prev_cube[mv] = cube[mv]
        p[mv] += r[mv] * np.maximum(step[moving], min_step)[:, None]
    premature = ~done
    point[premature] = last_surface[premature]
    _, N = fetch(at, prev_cube, point - O[prev_cube])
    return Exit(point=point, normal=N, cube=prev_cube, steps=steps, premature=premature)


def _bisect(at, inside_p, outside_p, cube):
    a, b = inside_p.copy(), outside_p.copy()
    for _ in range(REFINE):
        m = 0.5 * (a + b)
        ins = inside_cube(at, cube, m)
        a = np.where(ins[:, None], m, a)
        b = np.where(ins[:, None], b, m)
    return 0.5 * (a + b)


# -- frame data --------------------------------------------------------------------------------------
GC_FLOATS = 2 * 16 + 5 * 4 + 16 * 4
MAX_ENV_LEVELS = 16
TRANSFER_ENTRIES = 64


def bake_from_world(model: np.ndarray, stretch: np.ndarray, mm_per_unit: float) -> np.ndarray:
    """The bake frame (mm, ``stretch @ v * mm``) from world space: mm S model^-1 (a scaled rotation
    for the linear part, since model = R S)."""
    m = np.eye(4)
    m[:3, :3] = np.asarray(stretch, np.float64).reshape(3, 3) * float(mm_per_unit)
    return m @ np.linalg.inv(np.asarray(model, np.float64))


def transfer_image(table) -> tuple[np.ndarray, float]:
    """The slab transfer fit (f_t, theta_bar, c_t, c_r) resampled at TRANSFER_ENTRIES depths uniform in
    s = log(1 + tau) / log(1 + tau_max): (1, n, 4) image and log(1 + tau_max)."""
    log_max = float(np.log1p(table.tau[-1]))
    tau = np.expm1(np.linspace(0.0, 1.0, TRANSFER_ENTRIES) * log_max)
    _, f_t, theta_bar, c_t, c_r = table.at(tau)
    return np.stack([f_t, theta_bar, c_t, c_r], axis=1)[None].astype(np.float32), log_max


def transfer_lookup(image: np.ndarray, log_max: float, tau) -> np.ndarray:
    """The GLSL ``transfer`` twin: (f_t, theta_bar, c_t, c_r) at depths tau."""
    n = image.shape[1]
    x = np.clip(np.log1p(np.asarray(tau, np.float64)) / log_max, 0.0, 1.0) * (n - 1)
    i = np.minimum(np.floor(x).astype(int), n - 2)
    f = (x - i)[..., None]
    return image[0, i] * (1 - f) + image[0, i + 1] * f


def gc_block(to_bake: np.ndarray, sigma_a, sigma_s, eta: float, min_step: float, res: int, cubes: int,
             max_steps: int, env, log_tau_max: float, mode: int = 0) -> bytes:
    """GeocubeData (std140) of ``gpu_shaders/common/structs.glsl``; env: an EnvironmentChain."""
    if env.levels > MAX_ENV_LEVELS:
        raise ValueError(f"environment chain has {env.levels} levels, the shader takes {MAX_ENV_LEVELS}")
    data = np.zeros(GC_FLOATS, np.float32)
    data[0:16] = np.asarray(to_bake, np.float32).T.ravel()
    data[16:32] = np.linalg.inv(to_bake).astype(np.float32).T.ravel()
    data[32:35], data[35] = sigma_a, eta
    data[36:39], data[39] = sigma_s, min_step
    data[40:44] = (res, cubes, max_steps, env.levels)
    data[44:48] = (log_tau_max, TRANSFER_ENTRIES, mode, 0.0)
    data[48:51] = env.mean[:3]
    for l in range(env.levels):
        data[52 + 4 * l: 55 + 4 * l] = (env.sigma[l], env.rows[l], env.level_res(l))
    return data.tobytes()

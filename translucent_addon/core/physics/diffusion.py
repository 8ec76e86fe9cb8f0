"""The diffusion equation with the diffusive-source Robin boundary (Wang et al. 2010, Sec. 3-4).

Pure. Units: mm and mm^-1; RGB coefficients broadcast. The discrete system lives on a QuadGraph
(``techniques/quadgraph/graph.py``) given as arrays: ``neighbours`` (N, 4), geometric Laplacian weights
``weights`` (N, 4), ``d_surface`` (S,), surface nodes first.

Conventions, derived here because the paper's printed equations disagree with each other:
- kappa = 1 / (3 (mu + sigma_s')) (DESIGN.md section 3; the paper prints [3 mu + sigma_s']^-1, and
  ``tests/test_quadgraph.py`` shows which one reproduces the dipole's total diffuse reflectance).
- Where the light enters. Wang puts it in the Robin boundary (Eq. 2) as an incoming diffuse current,
  phi + 2 A kappa dphi/dn = 4 q / (1 - F_dr) (Eq. 9 prints 4 q / (1 + F_dr); Eq. 6 gives 1 - F_dr):
  a source at the surface. Light entering a medium first scatters about one transport mean free path
  deep, and with the source at the surface a slab of 2 to 10 mm of marble or skin (red) transmits
  0.74-0.81 of what a random walk finds, a source at z_0 = 1 / sigma_t' 0.96-1.06 of it (and reflects
  within 1 %). So q is a point source at depth z_0 = 3 kappa on each surface node's link to its inner
  node (at the inner node where the link is shorter): the fitted link's Green's function
  sends sinh(sigma_tr (d - z_0)) / sinh(sigma_tr d) of it to the surface node's end and
  sinh(sigma_tr z_0) / sinh(sigma_tr d) to the inner node's (``source_split``); the boundary is then
  phi + 2 A kappa dphi/dn = 0 (J_in = F_dr J_out).
- The outward partial current at the surface is J_out = phi / (2 (1 + F_dr)) and the exitance
  B = (1 - F_dr) J_out = phi / (2 A); a slab of albedo 1 gives B = q: all light leaves.
- Outgoing radiance: L_o = F_t(w_o) / pi * B, the convention of the dipole methods (Jensen's
  S_d = F_t R_d F_t / pi, with B in the place of the dipole's exitance int R_d E_t). Wang's Eq. 7
  (with F_t for the printed F_r) is F_t(w_o) / pi * J_out, which rendered a thick skin slab under a
  white world 1.66 to 2.06 times as bright as the closed form that Cycles' brute force follows
  within 12 % (``tests/test_cycles_conversion.py``); with B, 0.97 to 1.17 times
  (``tests/test_quadgraph_gpu.py``).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .dipole import A as internal_reflection
from .fresnel import F_dr as diffuse_fresnel

if TYPE_CHECKING:
    from scipy.sparse import csr_matrix


def kappa(sigma_a: ArrayLike, sigma_s_prime: ArrayLike) -> np.ndarray | float:
    """Diffusion coefficient kappa = 1 / (3 (mu + sigma_s')) [mm] (mu = sigma_a)."""
    return 1.0 / (3.0 * (np.asarray(sigma_a, np.float64) + np.asarray(sigma_s_prime, np.float64)))


def kappa_as_printed(sigma_a: ArrayLike, sigma_s_prime: ArrayLike) -> np.ndarray | float:
    """The paper's printed kappa = 1 / (3 mu + sigma_s') (Sec. 3), kept to show that it is wrong."""
    return 1.0 / (3.0 * np.asarray(sigma_a, np.float64) + np.asarray(sigma_s_prime, np.float64))


def radiosity(phi_s: ArrayLike, eta: ArrayLike) -> np.ndarray | float:
    """The exitance B = (1 - F_dr) J_out, J_out = phi(n_s) / (2 (1 + F_dr)): L_o = F_t(w_o) / pi B."""
    F = diffuse_fresnel(eta)
    return (1.0 - F) * np.asarray(phi_s) / (2.0 * (1.0 + F))


def slab_reflectance(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: ArrayLike,
                     kappa_of: Callable[[np.ndarray, ArrayLike], np.ndarray | float] = kappa) -> np.ndarray | float:
    """Fraction of the light entering a semi-infinite slab that leaves it, for the continuous model.

    A point source q at depth z_0 = 3 kappa (one transport mean free path), sigma_tr = sqrt(mu / kappa),
    the boundary phi - 2 A kappa phi' = 0: phi(0) = q e^{-sigma_tr z_0} / (kappa (sigma_tr + 1 / (2 A kappa)))
    and the exitance phi(0) / (2 A) over q is e^{-sigma_tr z_0} / (1 + 2 A kappa sigma_tr): the
    counterpart of the dipole's total diffuse reflectance (Jensen 2001 Eq. 6), equal to 1 without
    absorption.
    """
    mu = np.asarray(sigma_a, np.float64)
    k = kappa_of(mu, sigma_s_prime)
    sigma_tr = np.sqrt(mu / k)
    A = internal_reflection(eta)
    return np.exp(-sigma_tr * 3.0 * k) / (1.0 + 2.0 * A * k * sigma_tr)


def held_source_gain(kappa_nodes: np.ndarray, mu_nodes: np.ndarray, d_surface: np.ndarray) -> np.ndarray:
    """R_graph / R per surface node, (S, C): how much more the graph reflects of the light entering at a
    node whose link is shorter than z_0, where ``source_split`` holds the source at the inner node, at
    depth d instead of z_0.

    A planar source at depth z under the boundary phi - 2 A kappa phi' = 0 leaves the exitance
    e^{-sigma_tr z} / (1 + 2 A kappa sigma_tr) per unit power (``slab_reflectance`` at z = z_0), so the
    graph's flat face reflects R e^{sigma_tr (z_0 - min(d, z_0))}: 1 where the link reaches z_0, about
    1.5 for skin1's blue on a 10 mm ball's 0.4 mm links (the direct solution there gave 1.3-1.5 times R).
    The display takes this, not R alone, from where light enters (``qg_display``'s loss_scale)."""
    S = len(d_surface)
    k = np.asarray(kappa_nodes, np.float64)[:S]
    mu = np.asarray(mu_nodes, np.float64)[:S]
    d = np.asarray(d_surface, np.float64)[:, None]
    z0 = 3.0 * k
    return np.exp(np.sqrt(mu / k) * np.maximum(z0 - d, 0.0))


def slab_transfer(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float,
                  thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """(R, T), each (C,): the continuous model's exitance from the lit face and from the far face of a
    slab of ``thickness`` mm over the light entering, a point source at z_0 = 3 kappa (at most the
    thickness) with phi - 2 A kappa phi' = 0 on both faces. Index-matched, a random walk through
    2-10 mm of marble or skin (red) finds T within 6 %; with the source at the surface instead (Wang's
    Robin source) the model transmits 0.74-0.81 of it."""
    A = float(internal_reflection(eta))
    R, T = [], []
    for mu, k in zip(np.atleast_1d(np.asarray(sigma_a, np.float64)),
                     np.atleast_1d(kappa(sigma_a, sigma_s_prime))):
        phi_0, phi_L = _point_source_1d(k, mu, 2.0 * A * k, float(thickness), min(3.0 * k, float(thickness)))
        R.append(float(phi_0) / (2.0 * A))
        T.append(float(phi_L) / (2.0 * A))
    return np.array(R), np.array(T)


def _point_source_1d(k, mu, h, L, z0):
    """(phi(0), phi(L)) of kappa phi'' = mu phi on [0, L] with phi - h phi' = 0 at z = 0, phi + h phi' = 0
    at z = L and a unit point source at z0 (the solve of ``slab_transfer``), for each absorption in ``mu``
    (array; k, h, L, z0 scalars); phi(L) = 0 beyond 18 diffusion lengths (below e^-18; past that the
    system's cosh terms leave float64's precision)."""
    s = np.maximum(np.sqrt(np.asarray(mu, np.float64) / k), 1e-12)
    far = s * (L - z0) > 18.0
    m = np.minimum(L - z0, 18.0 / s)
    # phi = a cosh(s t) + b sinh(s t) / s, t = z - z_0, on each side (a basis that stays independent
    # as s -> 0); continuity at z_0 (one a) and the jump k (b_below - b_above) = -1.
    ch0, sh0, chm, shm = np.cosh(s * z0), np.sinh(s * z0), np.cosh(s * m), np.sinh(s * m)
    zero = np.zeros_like(s)
    M = np.stack([np.stack([ch0 + h * s * sh0, -sh0 / s - h * ch0, zero], axis=-1),
                  np.stack([chm + h * s * shm, zero, shm / s + h * chm], axis=-1),
                  np.stack([zero, zero - k, zero + k], axis=-1)], axis=-2)
    rhs = np.broadcast_to(np.array([0.0, 0.0, -1.0]), s.shape + (3,))[..., None]
    a, b1, b2 = np.moveaxis(np.linalg.solve(M, rhs)[..., 0], -1, 0)
    return a * ch0 - b1 * sh0 / s, np.where(far, 0.0, a * chm + b2 * shm / s)


def box_transfer(sigma_a: float, sigma_s_prime: float, eta: float, width: float, thickness: float,
                 centre: float, modes: int = 120) -> tuple[float, float]:
    """(R, T): the continuous model of ``slab_transfer`` in a box width x width x thickness [mm] lit
    uniformly over one square face, exitance over the centre square |x|, |y| < centre of the lit and the
    far face. Across the box phi is a sum of the Robin eigenmodes cos(k_m x), k tan(k w / 2) = 1 / h
    (h = 2 A kappa; even ones: the light is), each a slab problem with mu + kappa (k_m^2 + k_n^2) in
    place of mu. A 40 mm box of marble 12 mm thick transmits 0.947 of the unbounded slab's T at its
    centre (its light leaves by the sides too), 3 mm thick all of it; tests compare the graph with this."""
    from scipy.optimize import brentq

    k = float(kappa(sigma_a, sigma_s_prime))
    A = float(internal_reflection(eta))
    h = 2.0 * A * k
    z0 = min(3.0 * k, float(thickness))
    half = 0.5 * float(width)
    km = np.array([brentq(lambda x: x * np.tan(x * half) - 1.0 / h, m * np.pi / half + 1e-12,
                          (m + 0.5) * np.pi / half - 1e-12) for m in range(modes)])
    coefficient = (2.0 * np.sin(km * half) / km) / (half + np.sin(2.0 * km * half) / (2.0 * km))
    weight = coefficient * np.sin(km * centre) / (km * centre)  # the mode's share, averaged over the centre
    pair = np.outer(weight, weight)
    phi_0, phi_L = _point_source_1d(k, float(sigma_a) + k * (km[:, None] ** 2 + km[None, :] ** 2), h,
                                    float(thickness), z0)
    return float((pair * phi_0).sum() / (2.0 * A)), float((pair * phi_L).sum() / (2.0 * A))


# -- the discrete system (Eq. 5-6) and its relaxation (Eq. 8-9) -----------------------------------
# The surface link s-k is exponentially fitted: between the surface node and its inner node the
# flux follows the 1-D solution of kappa phi'' = mu phi, phi = a e^{-sigma_tr x} + b e^{sigma_tr x},
# instead of a straight line. With x = sigma_tr d_sk, the outward derivative at s is
# (e2 phi_s - e1 phi_k) / d and the inward one at k is (e1 phi_s - e2 phi_k) / d, with
# e1 = x / sinh x and e2 = x / tanh x (both 1 at x = 0, giving back Eq. 6 and 9). On a graph too
# coarse for the material (sigma_tr d >> 1: skin's blue, 0.7 mm, between nodes 5 mm apart) the
# straight line sends several times too much light out of the surface; the fitted link gives the
# slab's exact surface flux at any spacing.


def link_factors(x: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(e1, e2) = (x / sinh x, x / tanh x), with their series near 0 (the hyperbolics held at 300, where
    x / sinh x is 0 to double precision and tanh 1)."""
    x = np.asarray(x, np.float64)
    small = x < 1e-3
    xs = np.where(small, 1.0, np.minimum(x, 300.0))
    e1 = np.where(small, 1.0 - x * x / 6.0, x / np.sinh(xs))
    e2 = np.where(small, 1.0 + x * x / 3.0, x / np.tanh(xs))
    return e1, e2


def surface_link(kappa_nodes: np.ndarray, mu_nodes: np.ndarray,
                 d_surface: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e1, e2) of every surface link, (S, C), from the surface node's own sigma_tr = sqrt(mu / kappa)."""
    S = len(d_surface)
    k = np.asarray(kappa_nodes, np.float64)[:S]
    mu = np.asarray(mu_nodes, np.float64)[:S]
    return link_factors(np.sqrt(mu / k) * d_surface[:, None])


def _sinh_ratio(sigma, a, b):
    """sinh(sigma a) / sinh(sigma b) for lengths 0 <= a <= b, without overflow; its series
    (a / b)(1 + sigma^2 (a^2 - b^2) / 6) where sigma b is small, so that a medium that absorbs nothing (sigma_tr
    = 0: spectralon) gets the limit a / b, not 0 / 0."""
    sigma = np.asarray(sigma, np.float64)
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    x, y = sigma * a, sigma * b
    small = y < 1e-4
    safe_y = np.where(small, 1.0, y)
    ratio = np.exp(x - safe_y) * np.expm1(-2.0 * x) / np.expm1(-2.0 * safe_y)
    series = a / np.maximum(b, 1e-300) * (1.0 + (x * x - y * y) / 6.0)
    return np.where(small, series, ratio)


def source_split(kappa_nodes: np.ndarray, mu_nodes: np.ndarray,
                 d_surface: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(w_s, w_k), (S, C): the shares of light entering at a surface node, a point source at depth
    z_0 = 3 kappa_s (1 / sigma_t') on its link of length d to its inner node, that the fitted link's
    Green's function carries to the surface node's end and to the inner node's:
    sinh(sigma_tr (d - z_0)) / sinh(sigma_tr d) and sinh(sigma_tr z_0) / sinh(sigma_tr d)
    ((d - z_0) / d and z_0 / d without absorption; less than 1 together with it). Where the link is
    shorter than z_0 the source sits at the inner node (z_0 = d: w_s = 0, w_k = 1). Extrapolating the
    shares beyond it (w_s < 0, w_k > 1) is exact in 1-D, but the inner node then stands for the field
    at z_0, 1.5-2 times its own, and passes it to unlit surface nodes that share it: on the back-lit cow
    that drew 0.231 against 0.213 with the source held at the inner node."""
    S = len(d_surface)
    k = np.asarray(kappa_nodes, np.float64)[:S]
    mu = np.asarray(mu_nodes, np.float64)[:S]
    sigma_tr = np.sqrt(mu / k)
    d = np.asarray(d_surface, np.float64)[:, None]
    z0 = np.minimum(3.0 * k, d)
    return _sinh_ratio(sigma_tr, d - z0, d), _sinh_ratio(sigma_tr, z0, d)


def edge_kappa(kappa_nodes: np.ndarray, neighbours: np.ndarray) -> np.ndarray:
    """Conductance of each link: the harmonic mean of its two ends' kappa, (N, 4, C); 0 where unlinked."""
    k = np.asarray(kappa_nodes, np.float64)
    kj = k[np.maximum(neighbours, 0)]
    ki = k[:, None, :]
    return np.where((neighbours >= 0)[..., None], 2.0 * ki * kj / np.maximum(ki + kj, 1e-300), 0.0)


def matrix(neighbours: np.ndarray, weights: np.ndarray, d_surface: np.ndarray, kappa_nodes: np.ndarray,
           mu_nodes: np.ndarray, eta: float, channel: int) -> csr_matrix:
    """Sparse M with M phi = b for one colour channel (rows: surface nodes, Eq. 6; inner nodes, Eq. 5)."""
    from scipy.sparse import csr_matrix

    N, S = len(neighbours), len(d_surface)
    A = float(internal_reflection(eta))
    k = np.asarray(kappa_nodes, np.float64)[:, channel]
    mu = np.asarray(mu_nodes, np.float64)[:, channel]
    ke = edge_kappa(kappa_nodes, neighbours)[..., channel]
    e1, e2 = (e[:, channel] for e in surface_link(kappa_nodes, mu_nodes, d_surface))
    inner = np.arange(S, N)
    # Inner: (sum_j a_ij k_ij + mu_i) phi_i - sum_j a_ij k_ij phi_j = 0; a link to a surface node
    # carries e1 on phi_s and e2 on phi_i.
    c = weights[S:] * ke[S:]
    to_surface = neighbours[S:] < S
    nb = neighbours[S:]
    off = c * np.where(to_surface, e1[np.minimum(nb, S - 1)], 1.0)
    on = c * np.where(to_surface, e2[np.minimum(nb, S - 1)], 1.0)
    diag = np.concatenate([2.0 * A * k[:S] * e2 + d_surface, on.sum(axis=1) + mu[S:]])
    rows = [np.arange(N), np.repeat(inner, 4), np.arange(S)]
    cols = [np.arange(N), nb.reshape(-1), neighbours[:S, 0]]
    vals = [diag, -off.reshape(-1), -2.0 * A * k[:S] * e1]
    # Surface: (2 A k_s e2 + d) phi_s - 2 A k_s e1 phi_k = 2 A d w_s q (Eq. 6 times d, the source in the link).
    return csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(N, N))


def right_hand_side(neighbours: np.ndarray, weights: np.ndarray, d_surface: np.ndarray, kappa_nodes: np.ndarray,
                    mu_nodes: np.ndarray, q: ArrayLike, eta: float) -> np.ndarray:
    """b of M phi = b, (N, C): the light entering, a source one mean free path deep in each surface
    link (``source_split``): 2 A d w_s q on surface rows; on an inner row, a d w_k q over its links to
    surface nodes (a d: the link face's area over the inner node's volume)."""
    S = len(d_surface)
    q = np.asarray(q, np.float64)
    w_s, w_k = source_split(kappa_nodes, mu_nodes, d_surface)
    b = np.zeros((len(neighbours), q.shape[1]))
    b[:S] = 2.0 * float(internal_reflection(eta)) * d_surface[:, None] * w_s * q
    b[S:] = inner_source(neighbours, weights, d_surface, w_k * q)
    return b


def inner_source(neighbours: np.ndarray, weights: np.ndarray, d_surface: np.ndarray,
                 share: np.ndarray) -> np.ndarray:
    """Per inner node, sum over its links to surface nodes s of a_ks d_s share_s, (T, C)."""
    S = len(d_surface)
    nb = neighbours[S:]
    to_surface = (nb >= 0) & (nb < S)
    j = np.where(to_surface, nb, 0)
    per_link = np.where(to_surface[..., None], (weights[S:] * np.asarray(d_surface)[j])[..., None] * share[j], 0.0)
    return per_link.sum(axis=1)


def solve_direct(neighbours: np.ndarray, weights: np.ndarray, d_surface: np.ndarray, kappa_nodes: np.ndarray,
                 mu_nodes: np.ndarray, q: ArrayLike, eta: float) -> np.ndarray:
    """phi (N, C) by a sparse LU factorisation, per channel: the reference for the relaxation."""
    from scipy.sparse.linalg import splu

    b = right_hand_side(neighbours, weights, d_surface, kappa_nodes, mu_nodes, q, eta)
    phi = np.zeros_like(b)
    for c in range(b.shape[1]):
        M = matrix(neighbours, weights, d_surface, kappa_nodes, mu_nodes, eta, c).tocsc()
        phi[:, c] = splu(M).solve(b[:, c])
    return phi


def relax(neighbours: np.ndarray, weights: np.ndarray, d_surface: np.ndarray, kappa_nodes: np.ndarray,
          mu_nodes: np.ndarray, q: ArrayLike, eta: float, phi: ArrayLike, iterations: int) -> np.ndarray:
    """``iterations`` Jacobi steps (Eq. 8 for inner nodes, Eq. 9 for surface nodes, with the fitted surface
    link), all nodes at once
    from the previous iterate, as the GPU pass does. The CPU twin of ``quadgraph/relaxation.glsl``."""
    S = len(d_surface)
    A = float(internal_reflection(eta))
    k = np.asarray(kappa_nodes, np.float64)
    mu = np.asarray(mu_nodes, np.float64)
    e1, e2 = surface_link(k, mu, d_surface)
    inner_nb = neighbours[S:]
    to_surface = (inner_nb < S)[..., None]
    c = weights[S:, :, None] * edge_kappa(k, neighbours)[S:]  # (T, 4, C)
    off = c * np.where(to_surface, e1[np.minimum(inner_nb, S - 1)], 1.0)
    denom = (c * np.where(to_surface, e2[np.minimum(inner_nb, S - 1)], 1.0)).sum(axis=1) + mu[S:]
    w_s, w_k = source_split(k, mu, d_surface)
    q = np.asarray(q, np.float64)
    source = 2.0 * A * d_surface[:, None] * w_s * q
    source_inner = inner_source(neighbours, weights, d_surface, w_k * q)
    ks = 2.0 * A * k[:S]
    surface_nb = neighbours[:S, 0]
    phi = np.array(phi, np.float64)
    for _ in range(iterations):
        new = np.empty_like(phi)
        new[S:] = (np.einsum("tkc,tkc->tc", off, phi[inner_nb]) + source_inner) / denom
        new[:S] = (ks * e1 * phi[surface_nb] + source) / (ks * e2 + d_surface[:, None])
        phi = new
    return phi


# The GPU relaxation holds phi in RGBA32F: once converged, successive iterates still differ by a few units
# in the last place (2**-23 of the largest value each), so a tolerance below this floor can never be met and
# would run every level to its iteration cap. 1e-6 is eight such units.
FLOAT32_TOLERANCE = 1e-6


def reachable_tolerance(tolerance: float) -> float:
    """The convergence threshold the float32 relaxation can meet: at least ``FLOAT32_TOLERANCE``."""
    return max(float(tolerance), FLOAT32_TOLERANCE)


def relative_change(new: np.ndarray, old: np.ndarray) -> float:
    """max |new - old| / max |new|: the convergence test of the relaxation (Sec. 5.2)."""
    scale = max(float(new.max()), -float(new.min()))
    diff = np.subtract(new, old)
    change = max(float(diff.max()), -float(diff.min()))
    return change / scale if scale > 0 else 0.0


def upsample(phi_coarse: ArrayLike, link_index: np.ndarray, link_weight: np.ndarray) -> np.ndarray:
    """Initial phi at the finer level from the coarser solution (Eq. 10)."""
    return np.einsum("nb,nbc->nc", link_weight, np.asarray(phi_coarse)[link_index])

"""Light that enters a curved surface beside its terminator and leaves past it.

``qg_single``'s local multiple scattering (``single_scattering.multiple_half_space``) is the response of
a flat face under uniform light: at the pixel it takes the light's cosine mu_i and is 0 where mu_i <= 0.
On a curved surface mu_i changes along the surface, mu_i(x) = mu_i + g x along its surface gradient
(g = |grad_s mu_i|: the normal's curvature times the light's tangential part), and the medium spreads
what enters over a diffusion length 1 / sigma_tr. The response to the clamped ramp max(0, mu_i(x)) is
the lateral kernel's average of it: mu_i where the ramp stays positive under the kernel, more than
max(mu_i, 0) near the terminator, and more than 0 past it, where the flat law gives nothing. That is
the glow of a back-lit rim: light entering just on the lit side and leaving just past the terminator
(Penner 2011 pre-integrates the same clamped cosine around a circle of radius 1 / curvature).

The lateral kernel is the dipole's R_d (Jensen et al. 2001, Eq. 4) normalised to unit integral, so
the ramp's response, lengths in units of the kernel's mean radius rho = E[r], is in polar coordinates
about the pixel

    F(s) = int R_d(r) r A(s, r) dr / int R_d(r) r 2 pi dr,   s = mu_i / (g rho),
    A(s, r) = int_0^{2 pi} max(0, s + r cos phi) dphi
            = 2 pi s (s >= r),  0 (s <= -r),  2 (s phi_0 + r sin phi_0), cos phi_0 = -s / r, otherwise,

and the effective cosine is mu_eff = g rho F(s) = max(mu_i, 0) + g rho G(s) with G(s) = F(s) - max(s, 0),
which is even (F(s) - F(-s) = s for a symmetric kernel), non-negative, largest at the terminator,
G(0) = 1 / pi (E|r cos phi| / 2), and 0 once |s| passes the kernel's reach: on a flat face (g = 0)
mu_eff = mu_i exactly. The ramp holds while the kernel spans less than the curvature's radius, so g rho
is taken at most 1 (SCALE_MAX; a ball much smaller than rho averages max(0, cos) to 1 / 4, where
g rho / pi would grow without bound on a low-poly mesh's sharp bends).
"""
from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import ArrayLike

from . import dipole

TABLE_SIZE = 257
SCALE_MAX = 1.0  # the largest g rho the ramp is trusted with
# A medium that does not absorb (sigma_a = 0 is valid: spectralon) has sigma_tr = 0 and a kernel whose
# mean radius grows without bound (R_d r ~ 1 / r^2 far out): its grid is taken at this absorption (a
# 10^8 mm absorption length), where rho is a few tens of the transport mean free path and g rho is
# held at SCALE_MAX anyway.
SIGMA_A_FLOOR = 1e-8


def _radial_grid(sigma_a: float, sigma_s_prime: float, eta: float):
    """Radii (per unit of sigma's length) and trapezoid weights of R_d(r) r dr, fine where R_d peaks
    (the real source's depth z_r, much less than 1 / sigma_tr at high albedo), out to 40 / sigma_tr,
    and the mean radius rho on that grid."""
    sigma_a = max(float(sigma_a), SIGMA_A_FLOOR)
    _, sigma_tr, z_r, _ = dipole.dipole_parameters(sigma_a, sigma_s_prime, eta)
    r = np.concatenate([[0.0], np.geomspace(1e-4 * min(z_r, 1.0 / sigma_tr), 40.0 / sigma_tr, 4000)])
    f = dipole.R_d(r, sigma_a, sigma_s_prime, eta) * r
    w = np.zeros_like(r)
    dr = np.diff(r)
    w[:-1] += 0.5 * dr
    w[1:] += 0.5 * dr
    weight = f * w
    return r, weight, float((r * weight).sum() / weight.sum())


def kernel_mean_radius(sigma_a: float, sigma_s_prime: float, eta: float) -> float:
    """rho = E[r] under the normalised R_d r dr: the length unit of the table (G(0) = rho / pi)."""
    return _radial_grid(sigma_a, sigma_s_prime, eta)[2]


def kernel_mean_radii(sigma_a: Iterable[float], sigma_s_prime: Iterable[float], eta: float) -> np.ndarray:
    """rho per channel, (3,): what ``qg_single`` scales the table's coordinate with."""
    return np.array([kernel_mean_radius(a, sp, eta) for a, sp in zip(sigma_a, sigma_s_prime)])


def ramp_angular(s: ArrayLike, r: ArrayLike) -> np.ndarray:
    """A(s, r): the clamped ramp max(0, s + r cos phi) integrated over the circle of radius r."""
    s, r = np.broadcast_arrays(np.asarray(s, np.float64), np.asarray(r, np.float64))
    c = np.clip(-s / np.maximum(r, 1e-300), -1.0, 1.0)
    phi_0 = np.arccos(c)
    partial = 2.0 * (s * phi_0 + r * np.sin(phi_0))
    return np.where(s >= r, 2.0 * np.pi * s, np.where(s <= -r, 0.0, partial))


def ramp_response(s: ArrayLike, sigma_a: float, sigma_s_prime: float, eta: float) -> np.ndarray:
    """F(s): the dipole kernel's average of max(0, s + x), s and the lateral offset x in units of rho."""
    r, weight, rho = _radial_grid(sigma_a, sigma_s_prime, eta)
    r = r / rho
    s = np.atleast_1d(np.asarray(s, np.float64))
    total = 2.0 * np.pi * weight.sum()
    return (ramp_angular(s[:, None], r[None, :]) * weight[None, :]).sum(axis=1) / total


def excess(s: ArrayLike, sigma_a: float, sigma_s_prime: float, eta: float) -> np.ndarray:
    """G(s) = F(s) - max(s, 0): what the clamp adds to the flat face's cosine, in units of g rho."""
    s = np.atleast_1d(np.asarray(s, np.float64))
    return ramp_response(s, sigma_a, sigma_s_prime, eta) - np.maximum(s, 0.0)


def beyond_line(s: ArrayLike, sigma_a: float, sigma_s_prime: float, eta: float) -> np.ndarray:
    """beta(s): the share of the lateral kernel that lies beyond a line s rho away (s >= 0), 1 / 2 at
    s = 0. It is -dG/ds (F'(s) = P(x > -s), G = F - max(s, 0)), which ``qg_single`` takes from the
    table by a forward difference; ``facet_weight`` builds on it."""
    r, weight, rho = _radial_grid(sigma_a, sigma_s_prime, eta)
    s = np.atleast_1d(np.asarray(s, np.float64))
    # Around the circle of radius r the arc beyond the line x = s rho spans 2 arccos(s rho / r).
    arc = 2.0 * np.arccos(np.clip(s[:, None] * rho / np.maximum(r[None, :], 1e-300), -1.0, 1.0))
    return (arc * weight[None, :]).sum(axis=1) / (2.0 * np.pi * weight.sum())


def facet_weight(edge_distances: ArrayLike, sigma_a: float, sigma_s_prime: float, eta: float) -> np.ndarray:
    """The triangle's own normal's share t in the medium's normal at the kernel's scale,
    n_k ~ n_smooth + t (n_facet - n_smooth), from the point's distances to the triangle's three edges
    (..., 3), in sigma's length unit.

    The medium Cycles walks in is bounded by the flat triangles, not by the interpolated normals the
    mesh is shaded with. The kernel's share inside the triangle is about w = prod_i (1 - beta(d_i / rho)):
    1 deep inside a triangle much wider than rho, 1 / 2 on an edge, 1 / 4 at a vertex, little anywhere
    on a mesh much finer than the kernel. n_k must not jump across an edge, where the smooth normal is
    the one normal both triangles share, so t = max(2 w - 1, 0): the triangle's normal deep inside a
    triangle wider than the kernel, the smooth one within about a kernel radius of its edges and on fine
    meshes (where the smooth normal is the kernel's average)."""
    d = np.asarray(edge_distances, np.float64)
    rho = kernel_mean_radius(sigma_a, sigma_s_prime, eta)
    inside = np.prod(1.0 - beyond_line(d.reshape(-1) / rho, sigma_a, sigma_s_prime, eta).reshape(d.shape), axis=-1)
    return np.maximum(2.0 * inside - 1.0, 0.0)


def table_coordinate(s: ArrayLike) -> np.ndarray | float:
    """u = (1 + s / (|s| + 1)) / 2 in [0, 1]: fine at the terminator, the tails (G < 1e-3 G(0) past
    |s| = 40) in the last texels."""
    s = np.asarray(s, np.float64)
    return 0.5 * (1.0 + s / (np.abs(s) + 1.0))


def excess_table(sigma_a: ArrayLike, sigma_s_prime: ArrayLike, eta: float, n: int = TABLE_SIZE) -> np.ndarray:
    """G per channel at u_k = k / (n - 1), s = (2 u - 1) / (1 - |2 u - 1|), (n, 3): the table
    ``qg_single`` reads linearly for the local multiple scattering beside the terminator; the ends
    (s = -inf, +inf) hold 0."""
    v = 2.0 * np.arange(n) / (n - 1) - 1.0
    s = v[1:-1] / (1.0 - np.abs(v[1:-1]))
    table = np.zeros((n, 3))
    for c, (a, sp) in enumerate(zip(np.atleast_1d(sigma_a), np.atleast_1d(sigma_s_prime))):
        table[1:-1, c] = np.maximum(excess(s, a, sp, eta), 0.0)
    return table


def effective_cosine(mu_i: ArrayLike, g: ArrayLike, sigma_a: float, sigma_s_prime: float, eta: float) -> np.ndarray:
    """mu_eff = max(mu_i, 0) + g rho G(mu_i / (g rho)) for one channel, g rho at most SCALE_MAX; g per
    unit length (as sigma_a). ``qg_single`` draws the same."""
    rho = kernel_mean_radius(sigma_a, sigma_s_prime, eta)
    mu_i, g = np.broadcast_arrays(np.atleast_1d(np.asarray(mu_i, np.float64)), np.asarray(g, np.float64))
    scale = np.minimum(g * rho, SCALE_MAX)
    G = np.zeros_like(mu_i)
    live = scale > 0
    if live.any():
        G[live] = excess(mu_i[live] / scale[live], sigma_a, sigma_s_prime, eta)
    return np.maximum(mu_i, 0.0) + scale * G

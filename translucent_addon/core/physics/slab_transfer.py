"""Slab transfer functions T_tau, R_tau for environment-map compositing (Chan & Wang 2005, Sec. 3.3).

A ray crossing a slightly scattering medium over optical depth tau sees the background
blurred as if it had crossed a plane-parallel slab of optical thickness tau (Chan & Wang
Sec. 3.3, Fig. 10). The slab is lit by a beam at normal incidence; the transmission function
T_tau is the angular distribution of the light leaving the far side, the reflection function
R_tau that of the light leaving the lit side (Fig. 11). The paper takes them from the
Legendre-expansion solution of the radiative transfer equation; we solve the same problem
offline by Monte Carlo:

* photons start at the top surface (optical depth z = 0) heading along the inward normal
  (mu = cos of the angle to the inward normal = 1); the boundaries are index matched (Fresnel
  is applied at the real surfaces by the renderer, not here);
* free flights are exponential in optical depth (extinction, so the unscattered beam falls as
  exp(-tau) whatever omega_0); at each collision the weight is multiplied by the albedo
  omega_0 and the direction is scattered by the Henyey-Greenstein phase function of
  anisotropy g; weights below ``ROULETTE_WEIGHT`` play Russian roulette (unbiased);
* the slab is laterally infinite and lit uniformly, and HG is symmetric about the incoming
  direction, so the exit distribution depends only on (z, mu): we track just those, updating
  mu with the z component of the exact rotation of the direction vector (``rotate_cosine``),
  which is what a full 3-D tracker would produce for mu;
* photons are tracked in vectorised batches (arrays of live photons, compacted after every
  flight) until each leaves through the bottom (transmitted) or the top (reflected). Those
  that leave on their first flight are the unscattered beam, kept apart from the scattered
  transmitted light that T_tau describes.

The scattered transmitted distribution is fitted by the paper's f_t G_thetabar + c_t
(Chan & Wang Sec. 3.3) with G a hemisphere-normalised Gaussian lobe in angle, so that f_t and
c_t are energy fractions of the incident beam; the reflection is approximated by a constant,
its total c_r. The renderer composites

    transmitted = unscattered * C_sharp + f_t * C_blurred(theta_bar) + c_t * C_average,
    reflected   = c_r * C_average.

Cost: ``transfer_table(0.9)`` (24 depths up to tau = 30, 50 000 photons each) takes about
1.0-1.2 s on a 2-core AMD EPYC machine (single-threaded NumPy; see ``transfer_table``).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike

ROULETTE_WEIGHT = 1e-3  # weights below this play Russian roulette ...
ROULETTE_SURVIVAL = 0.1  # ... surviving with this probability (weight divided by it)
BATCH = 1 << 18  # photons tracked at once (bounds memory for large n_photons)

DEFAULT_TAUS = np.concatenate([[0.0], np.geomspace(0.05, 30.0, 23)])
"""Default depth grid: 0, then 23 geometrically spaced optical depths from 0.05 to 30."""

_GL_X, _GL_W = np.polynomial.legendre.leggauss(64)


def sample_henyey_greenstein(g: float, xi: ArrayLike) -> np.ndarray:
    """cos theta of Henyey-Greenstein scattering for uniform numbers xi in [0, 1) (inversion).

    cos = (1 + g^2 - ((1 - g^2) / (1 - g + 2 g xi))^2) / (2 g); g = 0 is isotropic (2 xi - 1).
    """
    xi = np.asarray(xi, dtype=np.float64)
    g = float(g)
    if abs(g) < 1e-6:
        return 2.0 * xi - 1.0
    s = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi)
    return np.clip((1.0 + g * g - s * s) / (2.0 * g), -1.0, 1.0)


def hg_backscatter_fraction(g: ArrayLike) -> np.ndarray | float:
    """P(cos theta < 0) for HG: (1 - g)/(2 g) ((1 + g)/sqrt(1 + g^2) - 1), 1/2 - 3g/4 near g = 0.

    This is the single-scattering reflectance per unit optical depth of a thin slab lit at
    normal incidence (R ~ omega_0 tau P(cos < 0) as tau -> 0).
    """
    g = np.asarray(g, dtype=np.float64)
    small = np.abs(g) < 1e-4
    gs = np.where(small, 1.0, g)
    exact = (1.0 - gs) / (2.0 * gs) * ((1.0 + gs) / np.sqrt(1.0 + gs * gs) - 1.0)
    out = np.where(small, 0.5 - 0.75 * g, exact)  # series error O(g^3)
    return float(out) if out.ndim == 0 else out


def rotate_cosine(mu: ArrayLike, cos_theta: ArrayLike, phi: ArrayLike) -> np.ndarray:
    """New direction cosine to the slab normal after deflecting by (theta, phi).

    The z component of the standard rotation of a unit vector with cosine mu to the normal
    by polar angle theta and azimuth phi about itself (spherical law of cosines):
    mu' = mu cos theta + sqrt(1 - mu^2) sin theta cos phi.
    """
    mu = np.asarray(mu, dtype=np.float64)
    cos_theta = np.asarray(cos_theta, dtype=np.float64)
    sin_mu = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    sin_t = np.sqrt(np.maximum(1.0 - cos_theta * cos_theta, 0.0))
    return np.clip(mu * cos_theta + sin_mu * sin_t * np.cos(phi), -1.0, 1.0)


def bin_solid_angles(theta_edges: ArrayLike) -> np.ndarray:
    """Solid angle of the rings between polar angles theta_edges: 2 pi (cos a - cos b)."""
    c = np.cos(np.asarray(theta_edges, dtype=np.float64))
    return 2.0 * np.pi * (c[:-1] - c[1:])


@dataclasses.dataclass(frozen=True)
class SlabTransfer:
    """Monte Carlo transfer functions of a slab lit by a unit beam at normal incidence.

    ``transmitted`` and ``reflected`` are scattered energy per steradian per unit incident
    energy, per polar-angle bin (angle to the slab normal on the exit side); the unscattered
    beam is only in ``unscattered``. With omega_0 = 1, unscattered + T_scattered + R = 1.
    """

    tau: float
    g: float
    omega_0: float
    n_photons: int
    unscattered: float
    theta_edges: np.ndarray
    transmitted: np.ndarray
    reflected: np.ndarray
    T_scattered: float
    R: float

    @property
    def theta_centres(self) -> np.ndarray:
        return 0.5 * (self.theta_edges[:-1] + self.theta_edges[1:])

    @property
    def solid_angles(self) -> np.ndarray:
        return bin_solid_angles(self.theta_edges)

    def fit(self) -> tuple[float, float, float]:
        """(f_t, theta_bar, c_t) of the scattered transmitted light (``fit_transmission``)."""
        return fit_transmission(self.theta_centres, self.transmitted, self.solid_angles)


def simulate_slab(tau: float, g: float, omega_0: float = 1.0, n_photons: int = 200_000,
                  n_bins: int = 90, seed: int = 0) -> SlabTransfer:
    """Monte Carlo solution of the slab problem of Chan & Wang Sec. 3.3 (Fig. 10a, Fig. 11).

    Deterministic for a given seed. See the module docstring for the method.
    """
    tau = float(tau)
    if tau < 0.0 or not 0.0 <= omega_0 <= 1.0 or not -1.0 < g < 1.0:
        raise ValueError("need tau >= 0, 0 <= omega_0 <= 1, -1 < g < 1")
    rng = np.random.default_rng(seed)
    absorbing = omega_0 < 1.0
    dtheta = 0.5 * np.pi / n_bins
    hist_t = np.zeros(n_bins)
    hist_r = np.zeros(n_bins)
    n_unscattered = 0

    def deposit(hist: np.ndarray, cos_exit: np.ndarray, weight: np.ndarray | None) -> None:
        idx = np.minimum((np.arccos(cos_exit) / dtheta).astype(np.intp), n_bins - 1)
        hist += np.bincount(idx, weights=weight, minlength=n_bins)

    for start in range(0, n_photons, BATCH):
        n = min(BATCH, n_photons - start)
        # First flight from the surface along the normal: past tau means unscattered.
        z = rng.standard_exponential(n)
        first_out = z >= tau
        n_unscattered += int(np.count_nonzero(first_out))
        z = z[~first_out]
        mu = np.ones_like(z)
        w = np.ones_like(z) if absorbing else None
        while z.size:
            m = z.size
            # Collision: albedo, HG deflection about the current direction.
            if absorbing:
                w *= omega_0
            cos_t = sample_henyey_greenstein(g, rng.random(m))
            mu = rotate_cosine(mu, cos_t, 2.0 * np.pi * rng.random(m))
            if absorbing:  # Russian roulette for faint photons (unbiased)
                faint = w < ROULETTE_WEIGHT
                if faint.any():
                    survive = rng.random(m) < ROULETTE_SURVIVAL
                    w = np.where(faint, np.where(survive, w / ROULETTE_SURVIVAL, 0.0), w)
                    alive = w > 0.0
                    z, mu, w = z[alive], mu[alive], w[alive]
                    m = z.size
            # Free flight, exponential in optical depth.
            z = z + mu * rng.standard_exponential(m)
            down = z >= tau
            up = z <= 0.0
            if down.any():
                deposit(hist_t, mu[down], w[down] if absorbing else None)
            if up.any():
                deposit(hist_r, -mu[up], w[up] if absorbing else None)
            inside = ~(down | up)
            z, mu = z[inside], mu[inside]
            if absorbing:
                w = w[inside]

    theta_edges = np.linspace(0.0, 0.5 * np.pi, n_bins + 1)
    omega = bin_solid_angles(theta_edges)
    return SlabTransfer(
        tau=tau, g=float(g), omega_0=float(omega_0), n_photons=int(n_photons),
        unscattered=n_unscattered / n_photons, theta_edges=theta_edges,
        transmitted=hist_t / omega / n_photons, reflected=hist_r / omega / n_photons,
        T_scattered=float(hist_t.sum()) / n_photons, R=float(hist_r.sum()) / n_photons,
    )


def gaussian_lobe_norm(theta_bar: ArrayLike) -> np.ndarray | float:
    """Z = hemisphere integral of exp(-theta^2 / (2 theta_bar^2)) dOmega (Gauss-Legendre).

    Z = 2 pi int_0^{pi/2} exp(-theta^2 / (2 theta_bar^2)) sin theta dtheta; the integrand is
    cut at 10 theta_bar where it is below 1e-21 of its peak.
    """
    tb = np.asarray(theta_bar, dtype=np.float64)
    upper = np.minimum(0.5 * np.pi, 10.0 * tb)[..., None]
    theta = 0.5 * upper * (_GL_X + 1.0)
    f = np.exp(-0.5 * (theta / tb[..., None]) ** 2) * np.sin(theta)
    return 2.0 * np.pi * 0.5 * upper[..., 0] * (f @ _GL_W)


def gaussian_lobe(theta: ArrayLike, theta_bar: float | np.ndarray) -> np.ndarray | float:
    """G(theta; theta_bar): Gaussian lobe in angle with unit integral over the hemisphere [sr^-1]."""
    theta = np.asarray(theta, dtype=np.float64)
    return np.exp(-0.5 * (theta / theta_bar) ** 2) / gaussian_lobe_norm(theta_bar)


def _energy_fit(a, y, wts, total):
    """Weighted least squares of y ~ f a + c / (2 pi) with f, c >= 0 and f S + c = total.

    S = sum(wts a) is the lobe's energy on the bins, so the fit keeps the data's energy.
    Returns (f, c, residual). Without the bounds this is the plain weighted least squares:
    the normal equation of c already says sum(wts (y - fit)) = 0.
    """
    b = 1.0 / (2.0 * np.pi)
    s = float(np.sum(wts * a))
    u = a - s * b  # residual y - f a - (total - f s) b = (y - total b) - f u
    v = y - total * b
    suu = float(np.sum(wts * u * u))
    f = float(np.sum(wts * u * v)) / suu if suu > 0.0 else 0.0
    f = min(max(f, 0.0), total / s)
    r = v - f * u
    return f, max(total - f * s, 0.0), float(np.sum(wts * r * r))


def fit_transmission(theta_centres: ArrayLike, per_sr: ArrayLike,
                     solid_angles: ArrayLike) -> tuple[float, float, float]:
    """Fit per_sr(theta) ~ f_t G(theta; theta_bar) + c_t / (2 pi) (Chan & Wang Sec. 3.3).

    Returns (f_t, theta_bar [rad], c_t): f_t is the energy fraction in the hemisphere-normalised
    Gaussian lobe G, c_t the energy fraction spread uniformly over the hemisphere. Least squares
    weighted by solid angle (approximates int (T - T~)^2 dOmega): a 1-D search over theta_bar
    (log grid, then bounded Brent) with linear least squares for f_t, c_t >= 0 inside, holding
    the fitted energy to the data's, sum(per_sr * solid_angles), so f_t + c_t = T_scattered up
    to the bin quadrature of G. (Where the unconstrained fit has c_t > 0 the two coincide; for
    thick slabs the lobe alone carries the energy, c_t = 0.)
    """
    theta = np.asarray(theta_centres, dtype=np.float64)
    y = np.asarray(per_sr, dtype=np.float64)
    wts = np.asarray(solid_angles, dtype=np.float64)
    total = float(np.sum(y * wts))
    if not total > 0.0:
        return 0.0, 0.0, 0.0
    lo, hi = math.log(max(0.5 * theta.min(), 1e-4)), math.log(0.5 * np.pi)

    def cost(log_tb: float) -> float:
        return _energy_fit(gaussian_lobe(theta, math.exp(log_tb)), y, wts, total)[2]

    grid = np.linspace(lo, hi, 121)
    costs = np.array([cost(t) for t in grid])
    k = int(np.argmin(costs))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    from scipy import optimize  # here, not at import: the extension's start-up need not load SciPy

    res = optimize.minimize_scalar(cost, bounds=(a, b), method="bounded", options={"xatol": 1e-10})
    log_tb = res.x if res.fun <= costs[k] else grid[k]
    theta_bar = math.exp(log_tb)
    f_t, c_t, _ = _energy_fit(gaussian_lobe(theta, theta_bar), y, wts, total)
    return float(f_t), float(theta_bar), float(c_t)


@dataclasses.dataclass(frozen=True)
class TransferTable:
    """Per-depth fit of the slab transfer functions (the paper's 1-D texture, Chan & Wang Sec. 4).

    Arrays over tau: unscattered = exp(-tau) (exact; the Monte Carlo estimate agrees), f_t,
    theta_bar [rad], c_t (transmitted lobe and uniform energy fractions) and c_r (total
    reflected energy fraction R, rendered as c_r * C_average).
    """

    g: float
    omega_0: float
    tau: np.ndarray
    unscattered: np.ndarray
    f_t: np.ndarray
    theta_bar: np.ndarray
    c_t: np.ndarray
    c_r: np.ndarray

    def at(self, tau: ArrayLike) -> tuple[np.ndarray | float, ...]:
        """(unscattered, f_t, theta_bar, c_t, c_r) at optical depths tau (arrays).

        f_t, theta_bar, c_t, c_r are interpolated linearly in tau and clamped beyond the table;
        unscattered is the exact exp(-tau). At tau = 0: 1, 0, theta_bar of the first depth, 0, 0.
        """
        t = np.maximum(np.asarray(tau, dtype=np.float64), 0.0)
        return (np.exp(-t),) + tuple(
            np.interp(t, self.tau, col) for col in (self.f_t, self.theta_bar, self.c_t, self.c_r))


def transfer_table(g: float, taus: ArrayLike | None = None, omega_0: float = 1.0, n_photons: int = 50_000,
                   seed: int = 0) -> TransferTable:
    """Simulate and fit the slab at each depth in taus (default ``DEFAULT_TAUS``).

    A tau = 0 row (unscattered 1, f_t = c_t = c_r = 0, theta_bar copied from the next depth)
    is put first if taus does not start with 0. Every depth uses the same seed (common random
    numbers keep the table smooth in tau). Measured with the defaults on a 2-core AMD EPYC
    (single-threaded NumPy): 1.0-1.2 s for g = 0.9 or 0.8, 1.2-1.3 s for g = 0.5, 1.3-1.5 s
    for g = 0; the cost follows the number of scatterings, dominated by the thickest slabs.
    """
    taus = np.array(DEFAULT_TAUS if taus is None else taus, dtype=np.float64)  # a copy
    if taus.ndim != 1 or taus.size == 0 or np.any(taus < 0) or np.any(np.diff(taus) <= 0):
        raise ValueError("taus must be a non-empty increasing sequence of depths >= 0")
    if taus[0] > 0.0:
        taus = np.concatenate([[0.0], taus])
    rows = []
    for tau in taus:
        if tau == 0.0:
            rows.append((0.0, np.nan, 0.0, 0.0))
            continue
        s = simulate_slab(tau, g, omega_0=omega_0, n_photons=n_photons, seed=seed)
        f_t, theta_bar, c_t = s.fit()
        rows.append((f_t, theta_bar, c_t, s.R))
    f_t, theta_bar, c_t, c_r = (np.array(col) for col in zip(*rows))
    if taus.size > 1:
        theta_bar[0] = theta_bar[1]
    else:
        theta_bar[0] = 0.0
    return TransferTable(g=float(g), omega_0=float(omega_0), tau=taus, unscattered=np.exp(-taus),
                         f_t=f_t, theta_bar=theta_bar, c_t=c_t, c_r=c_r)

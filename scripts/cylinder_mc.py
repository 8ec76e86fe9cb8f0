"""Where the surface methods' model leaves exact transport on curved parts: `python scripts/cylinder_mc.py`.

A back-lit infinite cylinder (radius R mm, the preset's medium, index-matched, isotropic scattering at the
reduced coefficients, a collimated beam across its axis) by Monte Carlo, against the model IMAGE_SPACE,
TEXTURE_SPACE and the dipole-model reference draw: B(x_o) = int R_d(|x_o - x|) C(h) E(x) dA with the exact
profile R_d, the thin-part factor C of x lying h below x_o's tangent plane (``physics.slab_through``) and E the
irradiance entering at x. Per radius and channel, the exitance ratio model / Monte Carlo (1 = right) in four
bands of the angle from the beam's entry side: the lit centre (0-45 degrees), the lit flank (45-80), the band
at the terminator (80-95, where a flat face's law gives the light a cosine near 0) and the dark side (100-180,
the light through the part), each the ratio of the band's summed exitance. A second row shifts every source
one mean free path along its refracted beam (Jensen's source on the beam, not below the entry point): the
model of light entering at an angle that IMAGE_SPACE's EXACT profile takes (``physics.oblique_entry``, there in
the upstream form, without the light that drifts past the terminator). ``--angular``: instead, how the light
leaving each band is spread over directions against the Lambertian law every method draws it with
(``exit_radiance``). ``--slab-laws``: instead, the dark side in finer bands under the thin-part factor as drawn
and under candidate per-pair laws for curved parts (``SLAB_LAWS``). No Blender; about two minutes a preset.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from translucent_addon.core.physics import angular_law, exit_lean, slab_through  # noqa: E402
from translucent_addon.core.physics.presets import load_presets  # noqa: E402
from translucent_addon.techniques.texture_space.throughput import Material  # noqa: E402

BANDS = {"lit centre": (0, 45), "lit flank": (45, 80), "terminator": (80, 95), "dark side": (100, 180)}
DARK_BANDS = ((80, 95), (95, 110), (110, 125), (125, 140), (140, 160), (160, 180))
# Candidate per-pair laws for the thin-part factor C on curved parts, measured against Monte Carlo (--slab-laws),
# none drawn by a method: each maps (n_i . n_o, h, R) to the depth C is read at and the share of its excess
# kept. "as drawn": C(h); "opposed": the excess weighed by -n_i . n_o; "half-opposed": by (1 - n_i . n_o) / 2,
# 1 on a flat slab's far face and 0 on the source's own face; "depth at R": C read at min(h, R), the radius of
# curvature (no cap on a flat slab).
SLAB_LAWS = {
    "as drawn": lambda c, h, R: (h, 1.0),
    "opposed": lambda c, h, R: (h, np.clip(-c, 0.0, 1.0)),
    "half-opposed": lambda c, h, R: (h, np.clip(0.5 - 0.5 * c, 0.0, 1.0)),
    "depth at R": lambda c, h, R: (np.minimum(h, R), 1.0),
}


def trace(R: float, sigma_a: float, sigma_s: float, photons: int = 100_000, seed: int = 1):
    """Every photon's escape: (phi in radians from the beam's exit side, +x; weight; direction (k, 3), z along
    the axis; scatterings before leaving). Weight 0 for photons absorbed (dropped below 1e-4)."""
    rng = np.random.default_rng(seed)
    sigma_t = sigma_a + sigma_s
    y = rng.uniform(-R, R, photons)
    p = np.stack([-np.sqrt(R * R - y * y) * (1 - 1e-9), y], 1)
    d = np.tile([1.0, 0.0, 0.0], (photons, 1))
    w = np.ones(photons)
    order = np.zeros(photons, int)
    exit_phi, exit_w, exit_n = np.zeros(photons), np.zeros(photons), np.zeros(photons, int)
    exit_d = np.zeros((photons, 3))
    alive = np.arange(photons)
    while len(alive):
        s = -np.log(rng.random(len(alive))) / sigma_t
        P, D = p[alive], d[alive, :2]
        a, b, c = (D**2).sum(1), 2 * (P * D).sum(1), (P**2).sum(1) - R * R
        t_out = (-b + np.sqrt(np.maximum(b * b - 4 * a * c, 0))) / (2 * np.maximum(a, 1e-15))
        out = (a > 1e-15) & (t_out < s)
        q = P + D * np.where(out, t_out, s)[:, None]
        gone = alive[out]
        exit_phi[gone], exit_w[gone], exit_d[gone], exit_n[gone] = np.arctan2(q[out, 1], q[out, 0]), w[gone], \
            d[gone], order[gone]
        keep = alive[~out]
        p[keep] = q[~out]
        w[keep] *= sigma_s / sigma_t
        order[keep] += 1
        mu, az = rng.random(len(keep)) * 2 - 1, rng.random(len(keep)) * 2 * np.pi
        d[keep] = np.stack([np.sqrt(1 - mu * mu) * np.cos(az), np.sqrt(1 - mu * mu) * np.sin(az), mu], 1)
        alive = keep[w[keep] > 1e-4]
    return exit_phi, exit_w, exit_d, exit_n


def monte_carlo(R: float, sigma_a: float, sigma_s: float, photons: int = 100_000, bins: int = 72, seed: int = 1):
    """(bin centres phi in radians from the beam's exit side, +x; exitance per unit incident irradiance).
    tests/test_oblique_entry.py measures the methods' model against it too."""
    exit_phi, exit_w, _, _ = trace(R, sigma_a, sigma_s, photons, seed)
    edges = np.linspace(-np.pi, np.pi, bins + 1)
    hist, _ = np.histogram(exit_phi, edges, weights=exit_w)
    return 0.5 * (edges[1:] + edges[:-1]), hist / photons * 2 * R / (R * (edges[1] - edges[0]))


def exit_radiance(R: float, sigma_a: float, sigma_s: float, photons: int = 300_000, cone_deg: float = 15.0,
                  mu_o: tuple[float, ...] = (0.2, 0.5)) -> dict:
    """How the light leaving each band is spread over directions: per band and view cosine mu_o in the
    cross-section, the radiance towards the dark side (the view's tangential part pointing away from the lit
    centre) and towards the lit side, each over the Lambertian radiance of the band's own exitance, E mu_o / pi
    (1 = Lambertian), counted in a cone of ``cone_deg``; and the share of single scattering in the first."""
    exit_phi, exit_w, exit_d, exit_n = trace(R, sigma_a, sigma_s, photons)
    normal = np.stack([np.cos(exit_phi), np.sin(exit_phi)], 1)
    mu = (exit_d[:, :2] * normal).sum(1)
    # the tangent towards the dark side (phi -> 0): -sign(phi) times d/dphi of the normal
    towards_dark = -np.sign(exit_phi) * (exit_d[:, :2] * np.stack([-np.sin(exit_phi), np.cos(exit_phi)], 1)).sum(1)
    angle = 180.0 - np.degrees(np.abs(exit_phi))
    cone = np.cos(np.radians(cone_deg))
    solid = 2.0 * np.pi * (1.0 - cone)
    table = {}
    for band, (lo, hi) in BANDS.items():
        inside = (angle >= lo) & (angle < hi) & (exit_w > 0)
        W = exit_w[inside]
        for m_o in mu_o:
            cells = []
            for side in (1.0, -1.0):
                seen = mu[inside] * m_o + towards_dark[inside] * side * np.sqrt(1.0 - m_o * m_o) > cone
                cells.append(W[seen].sum() / solid / (W.sum() * m_o / np.pi))
                if side > 0:
                    single = W[seen & (exit_n[inside] == 1)].sum() / max(W[seen].sum(), 1e-30)
            table[band, m_o] = (cells[0], cells[1], single)
    return table


def model(R: float, sigma_a: float, sigma_s: float, angles_deg: np.ndarray, shift_mfp: float, sources: int = 2000,
          view: tuple[float, float] | None = None, through_lean: bool = True, slab_law: str = "as drawn"):
    """The methods' B at receivers ``angles_deg`` (>= 0) from the entry side's centre; sources moved ``shift_mfp``
    mean free paths along the refracted beam (its tangential part, |sin theta_i| at eta 1). ``view`` (mu_o, side):
    instead, the radiance towards the view at cosine mu_o in the cross-section, towards the dark side (side 1) or
    the lit side (-1), over the Lambertian radiance of B, as IMAGE_SPACE draws it: the angular law a(mu_o), the
    diffusion mode's law M(mu_o) for pairs across the part (over the thin-part ramp), and each pair leaning away
    from its source (``physics.exit_lean``; ``through_lean`` False: only outside the ramp, as before)."""
    material = Material((sigma_a,) * 3, (sigma_s,) * 3, 1.0)
    slab = slab_through.constants(material.sigma_a, material.sigma_s_prime, 1.0)
    phi = np.linspace(-np.pi, np.pi, sources + 1)[:-1]  # from the entry side's centre
    E = np.maximum(np.cos(phi), 0.0)
    moved = phi + np.sign(phi) * shift_mfp / (sigma_a + sigma_s) * np.abs(np.sin(phi)) / R
    u = np.linspace(-1, 1, 401)
    z = np.sinh(u * np.arcsinh(60.0 / 0.003)) * 0.003  # along the axis, fine near the receiver
    wz = np.gradient(z)
    if view is not None:  # the angular laws at the view's cosine: a(mu_o), and M(mu_o) for pairs across the part
        a_o = angular_law.factor(sigma_s / (sigma_a + sigma_s), 1.0, view[0])
        M_o = angular_law.through_exit_ratio(material.sigma_a, material.sigma_s_prime, 1.0, view[0])[0]
    out = []
    for a in np.radians(angles_deg):
        dp = moved - a
        chord, h = 2 * R * np.abs(np.sin(dp / 2)), R * (1 - np.cos(dp))
        r = np.hypot(chord[:, None], z[None, :])
        R_d = material.R_d(r.ravel())[:, 0].reshape(r.shape)
        depth, kept = SLAB_LAWS[slab_law](np.cos(dp), h, R)  # n_i . n_o = cos(dp) on the circle
        C = 1.0 + (slab_through.factor(depth, *slab)[:, 0] - 1.0) * kept
        pairs = (E * C * R * (phi[1] - phi[0]))[:, None] * R_d * wz[None, :]
        if view is None:
            out.append(pairs.sum())
            continue
        # In 3-D (z along the axis): the receiver on the side of increasing angle, the view in its cross-section.
        n_o = np.array([-np.cos(a), np.sin(a), 0.0])
        towards_dark = np.array([np.sin(a), np.cos(a), 0.0])
        mu_o, side = view
        to_eye = mu_o * n_o + side * np.sqrt(1.0 - mu_o * mu_o) * towards_dark
        x_i = np.stack(np.broadcast_arrays(-R * np.cos(moved)[:, None], R * np.sin(moved)[:, None], z[None, :]), -1)
        ramp = slab_through.ramp(h, slab[1])[:, 0]
        beta = exit_lean.beta(r, material.sigma_a, material.sigma_s_prime, 1.0)[..., 0]
        if not through_lean:
            beta = beta * (1.0 - ramp[:, None])
        lean = exit_lean.pair_factor(beta[..., None], x_i, R * n_o, n_o, to_eye)[..., 0]
        law = a_o * (1.0 + (M_o - 1.0) * ramp)[:, None]
        out.append((pairs * law * lean).sum() / pairs.sum())
    return np.array(out)


def band_ratio(B: np.ndarray, M: np.ndarray, angle: np.ndarray, band: tuple[float, float]) -> str:
    """The model's summed exitance over Monte Carlo's in a band of angles, for the tables; '-' where no photon
    left through the band (the far side of a thick, absorbing part)."""
    inside = (angle >= band[0]) & (angle < band[1])
    return f"{B[inside].sum() / M[inside].sum():.2f}" if M[inside].sum() > 0 else "-"


def band_lean(R: float, sigma_a: float, sigma_s: float, band: tuple[float, float], view: tuple[float, float],
              shift_mfp: float = 1.0, angles: int = 4, through_lean: bool = True) -> float:
    """The model's radiance towards ``view`` over Lambertian across a band of angles, weighted by B (as
    ``exit_radiance`` weighs by the band's exitance): what IMAGE_SPACE's angular laws and lean give there."""
    a = np.linspace(*band, angles + 2)[1:-1]
    B = model(R, sigma_a, sigma_s, a, shift_mfp)
    return float((B * model(R, sigma_a, sigma_s, a, shift_mfp, view=view, through_lean=through_lean)).sum() / B.sum())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="marble")
    parser.add_argument("--radii", type=float, nargs="*", default=[3.0, 5.0, 10.0, 20.0])
    parser.add_argument("--photons", type=int, default=200_000)
    parser.add_argument("--angular", action="store_true",
                        help="instead: how each band's light is spread over directions (``exit_radiance``)")
    parser.add_argument("--slab-laws", action="store_true",
                        help="instead: the dark side in finer bands under each of SLAB_LAWS (sources shifted)")
    args = parser.parse_args()
    m = load_presets()[args.preset]
    if args.slab_laws:
        print(f"{args.preset}: model / Monte Carlo per band of the angle from the lit centre, per law of the "
              "thin-part factor (sources shifted one mean free path)")
        print("| R mm | channel | law | " + " | ".join(f"{lo}-{hi}" for lo, hi in DARK_BANDS) + " |")
        print("|---|---|---" + "|---" * len(DARK_BANDS) + "|")
        for R in args.radii:
            for c, name in enumerate("RGB"):
                phi, M = monte_carlo(R, m.sigma_a[c], m.sigma_s_prime[c], args.photons, 72)
                angle = 180.0 - np.degrees(np.abs(phi))
                for law in SLAB_LAWS:
                    B = model(R, m.sigma_a[c], m.sigma_s_prime[c], angle, 1.0, slab_law=law)
                    print(f"| {R:g} | {name} | {law} | " + " | ".join(band_ratio(B, M, angle, band)
                                                                        for band in DARK_BANDS) + " |", flush=True)
        return 0
    if args.angular:
        print(f"{args.preset}: radiance towards the dark side / towards the lit side over Lambertian, at mu_o "
              "(single scattering's share of the first); the model's, as IMAGE_SPACE draws it (angular laws, lean)")
        print("| R mm | channel | mu_o | " + " | ".join(BANDS) + " |")
        print("|---|---|---" + "|---" * len(BANDS) + "|")
        for R in args.radii:
            for c, name in enumerate("RGB"):
                table = exit_radiance(R, m.sigma_a[c], m.sigma_s_prime[c], args.photons)
                for m_o in (0.2, 0.5):
                    leans = {b: [band_lean(R, m.sigma_a[c], m.sigma_s_prime[c], BANDS[b], (m_o, side))
                                 for side in (1.0, -1.0)] for b in BANDS}
                    print(f"| {R:g} | {name} | {m_o:g} | " + " | ".join(
                        "{:.2f} / {:.2f} ({:.2f}); model {:.2f} / {:.2f}".format(*table[b, m_o], *leans[b])
                        for b in BANDS) + " |", flush=True)
        return 0
    print(f"{args.preset}: model / Monte Carlo per band (sources at the entry point; shifted one mean free path)")
    print("| R mm | channel | " + " | ".join(BANDS) + " |")
    print("|---|---" + "|---" * len(BANDS) + "|")
    for R in args.radii:
        for c, name in enumerate("RGB"):
            phi, M = monte_carlo(R, m.sigma_a[c], m.sigma_s_prime[c], args.photons, 72)
            angle = 180.0 - np.degrees(np.abs(phi))  # from the entry side's centre
            cells = []
            for shift in (0.0, 1.0):
                B = model(R, m.sigma_a[c], m.sigma_s_prime[c], angle, shift)
                cells.append([band_ratio(B, M, angle, band) for band in BANDS.values()])
            print(f"| {R:g} | {name} | " + " | ".join(f"{a} / {b}" for a, b in zip(*cells)) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

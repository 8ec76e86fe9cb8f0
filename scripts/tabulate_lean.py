"""Tabulate how the light leaving a half-space leans away from where it entered, beta(rho; alpha', eta), from Monte
Carlo (``core/physics/half_space_mc.py``, ``lean``) into ``translucent_addon/data/half_space_lean.npz``, which
``core/physics/exit_lean.py`` reads.

One unabsorbed run per eta gives every albedo of ``exact_profile.ALBEDOS`` by reweighting (alpha'^n). beta is a
ratio of two tallies over the same photons, so it needs far fewer than the profile: an annulus whose photons
count for fewer than ``MIN_PHOTONS`` (the weights' effective number) keeps the value of the one inside it.
Development only: about two minutes per eta per 200,000 photons on one core.

    python scripts/tabulate_lean.py [--photons 200000] [--jobs 2]
"""
from __future__ import annotations

import argparse
import concurrent.futures
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from translucent_addon.core.physics import half_space_mc  # noqa: E402
from translucent_addon.core.physics.exact_profile import ALBEDOS  # noqa: E402
from translucent_addon.core.physics.exit_lean import EDGES, ETAS, TABLE  # noqa: E402

MIN_PHOTONS = 400.0  # effective photons an annulus needs for its own beta
SCATTERINGS = 400_000  # as the profile's long runs: alpha'^n < e^-10 down to 1 - alpha' = 2.5e-5


def run(eta: float, photons: int, seed: int) -> np.ndarray:
    """(albedos, annuli) beta of one eta."""
    t0 = time.time()
    escapes = half_space_mc.trace(photons, eta, seed=seed, max_scatterings=SCATTERINGS)
    rows = []
    for a in ALBEDOS:
        w = half_space_mc.weights(escapes, a, per_albedo=True)  # at most 1: no underflow in w * w there
        power, _ = np.histogram(escapes.rho, bins=EDGES, weights=w)
        square, _ = np.histogram(escapes.rho, bins=EDGES, weights=w * w)
        # Clipped at 0: light leaving a half-space does not lean towards its entry point; the outermost annuli of
        # the conservative media (paths cut at SCATTERINGS) would say so.
        beta = np.maximum(half_space_mc.lean(escapes, EDGES, albedo=a, per_albedo=True), 0.0)
        enough = (square > 0) & (power * power >= MIN_PHOTONS * square)
        for k in range(1, len(beta)):  # outwards: a sparse annulus keeps its inner neighbour's value
            if not enough[k]:
                beta[k] = beta[k - 1]
        rows.append(beta)
    print(f"eta {eta:.2f}: {photons} photons, {escapes.truncated} truncated, {time.time() - t0:.0f} s", flush=True)
    return np.stack(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photons", type=int, default=200_000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=TABLE)
    args = parser.parse_args()
    with concurrent.futures.ProcessPoolExecutor(args.jobs) as pool:
        beta = np.stack(list(pool.map(run, ETAS, [args.photons] * len(ETAS), range(3000, 3000 + len(ETAS)))))
    np.savez_compressed(args.out, beta=beta.astype(np.float32), eta=np.asarray(ETAS), albedo=ALBEDOS, edges=EDGES,
                        photons=args.photons)
    print(f"wrote {args.out}: beta {beta.shape} (etas, albedos, annuli)")


if __name__ == "__main__":
    main()

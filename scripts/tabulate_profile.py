"""Tabulate the half-space profile R^(rho; alpha', eta) / alpha' from Monte Carlo (``core/physics/half_space_mc.py``)
into ``translucent_addon/data/half_space_profile.npz``, which ``core/physics/exact_profile.py`` reads.

Two unabsorbed runs per eta give every albedo by reweighting (alpha'^(n-1)): a short one (paths of at most
3,000 scatterings, plenty below alpha' = 0.9) for the low albedos and a long one (400,000) for the high
ones. Development only: the long runs take 4-13 minutes per eta on one core; ``--jobs`` runs etas in
parallel, and ``--long-from`` reuses the long runs' nodes of an earlier table with the same high albedos.

    python scripts/tabulate_profile.py [--photons 1000000] [--jobs 2] [--long-from old.npz]
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
from translucent_addon.core.physics.exact_profile import ALBEDOS, ETAS, LONG_RUN_FROM, RHO_EDGES, TABLE  # noqa: E402

LONG_SCATTERINGS = 400_000  # alpha'^n < e^-10 for 1 - alpha' >= 2.5e-5 (cream's red: 2.7e-5)
SHORT_SCATTERINGS = 3_000  # 0.9^3000 = 1e-137


def run(eta: float, photons: int, seed: int, long: bool) -> tuple[np.ndarray, int]:
    t0 = time.time()
    nodes = ALBEDOS[LONG_RUN_FROM:] if long else ALBEDOS[:LONG_RUN_FROM]
    escapes = half_space_mc.trace(photons, eta, seed=seed,
                                  max_scatterings=LONG_SCATTERINGS if long else SHORT_SCATTERINGS)
    R = np.stack([half_space_mc.profile(escapes, eta, RHO_EDGES, albedo=a, per_albedo=True) for a in nodes])
    print(f"eta {eta:.2f} {'long' if long else 'short'}: {photons} photons, {escapes.truncated} truncated, "
          f"{time.time() - t0:.0f} s", flush=True)
    return R, escapes.truncated


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photons", type=int, default=1_000_000, help="photons of each long run")
    parser.add_argument("--short-photons", type=int, default=2_000_000, help="photons of each short run")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--long-from", type=Path, default=None,
                        help="an earlier table whose high-albedo nodes (and their photons) to keep")
    parser.add_argument("--out", type=Path, default=TABLE)
    args = parser.parse_args()
    n = len(ETAS)
    with concurrent.futures.ProcessPoolExecutor(args.jobs) as pool:
        short = list(pool.map(run, ETAS, [args.short_photons] * n, range(2000, 2000 + n), [False] * n))
        if args.long_from is None:
            long = list(pool.map(run, ETAS, [args.photons] * n, range(1000, 1000 + n), [True] * n))
            long_R = np.stack([r[0] for r in long])
            truncated = np.asarray([r[1] for r in long])
            photons = args.photons
        else:
            with np.load(args.long_from) as old:
                assert np.allclose(old["albedo"][LONG_RUN_FROM:], ALBEDOS[LONG_RUN_FROM:])
                assert np.allclose(old["eta"], ETAS) and np.allclose(old["rho_edges"], RHO_EDGES)
                long_R = old["R_per_albedo"][:, LONG_RUN_FROM:].astype(np.float64)
                truncated, photons = old["truncated"], int(old["photons"])
    R = np.concatenate([np.stack([r[0] for r in short]), long_R], axis=1).astype(np.float32)
    np.savez_compressed(args.out, R_per_albedo=R, eta=np.asarray(ETAS), albedo=ALBEDOS, rho_edges=RHO_EDGES,
                        photons=photons, short_photons=args.short_photons, long_scatterings=LONG_SCATTERINGS,
                        short_scatterings=SHORT_SCATTERINGS, truncated=truncated)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} KB)")


if __name__ == "__main__":
    main()

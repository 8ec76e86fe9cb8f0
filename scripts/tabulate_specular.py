"""Tabulate the Principled specular layer's directional albedo E_s(mu_o, roughness, F_0) and the multiscatter energy
term into ``translucent_addon/data/specular_albedo.npz`` (``core/physics/microfacet.py`` reads it; a test
recomputes rows of it). Development only: about half a minute.

    python scripts/tabulate_specular.py
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from translucent_addon.core.physics import microfacet  # noqa: E402


def main() -> None:
    albedo, energy = microfacet.compute_tables()
    np.savez_compressed(microfacet.TABLE_FILE, albedo=albedo, energy=energy)
    print(f"wrote {microfacet.TABLE_FILE} ({microfacet.TABLE_FILE.stat().st_size} bytes)")


if __name__ == "__main__":
    main()

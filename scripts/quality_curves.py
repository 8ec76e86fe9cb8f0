"""Write translucent_addon/data/quality_curves.json, the measured curves AUTO quality reads.

From the benchmark's results (``make bench`` writes them), each method's error against its own model at
several resolutions, with what makes the resolution dimensionless:

* IMAGE_SPACE: relative RMSE against the CPU dipole model at splat overlap k (light-view samples per splat
  radius), ``bench/results/<scene>/discretisation/discretisation.json``;
* TEXTURE_SPACE: the same at atlas resolution and proxy spacing, with the proxy's mean edge h (mm) over the
  object's bounding-box diagonal D, ``bench/results/texture_space/discretisation.json``, and the bake's form
  factors and seconds (its cost; ``scripts/texture_space_costs.py`` re-measures the cost after this);
* QUADGRAPH: relative RMSE and median against exact transport at density K,
  ``bench/results/quadgraph/results.json`` (its discretisation is below its model's error there).

Run with the project's venv (it reads the scenes' sizes and materials from the bundled meshes and presets):
``.venv/bin/python scripts/quality_curves.py``.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from translucent_addon.core.geometry.mesh_io import load_npz  # noqa: E402
from translucent_addon.core.physics.dipole import dipole_parameters, r_max  # noqa: E402
from translucent_addon.core.physics.presets import load_presets  # noqa: E402
from translucent_addon.techniques.texture_space.proxy import ATLAS_FILL, surface_area  # noqa: E402

RESULTS = ROOT / "bench" / "results"
OUT = ROOT / "translucent_addon" / "data" / "quality_curves.json"
# The benchmark's scenes (translucent_addon/demo.py SCENES): mesh, preset, longest side in metres.
SCENES = {"bunny_backlit": ("bunny", "marble", 0.15), "bunny_frontlit": ("bunny", "marble", 0.15),
          "cow_backlit": ("cow", "skin1", 0.25), "spot_frontlit": ("spot", "potato", 0.15)}


def scene_measures(name: str) -> dict:
    mesh, preset, size = SCENES[name]
    v, t = load_npz(ROOT / "translucent_addon" / "data" / "meshes" / f"{mesh}.npz")
    v = v * (size * 1000.0 / np.ptp(v, axis=0).max())
    m = load_presets()[preset]
    sigma_tr = dipole_parameters(m.sigma_a, m.sigma_s_prime, m.eta)[1]
    return {"ell_min_mm": round(float(1.0 / sigma_tr.max()), 4),
            "ell_max_mm": round(float(1.0 / sigma_tr.min()), 4),
            "diagonal_mm": round(float(np.linalg.norm(np.ptp(v, axis=0))), 2),
            "area_mm2": round(surface_area(v, t), 1), "triangles": int(len(t)), "preset": preset,
            "r_max_mm": round(float(np.max(r_max(np.asarray(m.sigma_a), np.asarray(m.sigma_s_prime), m.eta))), 3)}


def write_curves(data: dict) -> None:
    """A row a line, so that a change of the curves reads well in a diff."""
    body = ",\n".join(f" {json.dumps(k)}: " + (json.dumps(v) if not isinstance(v, (list, dict)) or not v else
                       "[\n" + ",\n".join(f"  {json.dumps(r)}" for r in v) + "\n ]" if isinstance(v, list) else
                       "{\n" + ",\n".join(f"  {json.dumps(n)}: {json.dumps(r)}" for n, r in v.items()) + "\n }")
                       for k, v in data.items())
    OUT.write_text("{\n" + body + "\n}\n")


def main() -> None:
    scenes = {name: scene_measures(name) for name in SCENES}
    image_space = []
    for name in SCENES:
        path = RESULTS / name / "discretisation" / "discretisation.json"
        if not path.exists():
            continue
        data = json.loads(path.read_text())
        for r in data["rows"]:
            image_space.append({"scene": name, "size": data["size"], "k": r["overlap"],
                                "object_samples": r["object_samples"], "seconds": round(r["seconds"], 3),
                                "rel_rmse": round(r["rel_rmse_vs_model"], 5)})
    texture_space = []
    for r in json.loads((RESULTS / "texture_space" / "discretisation.json").read_text()):
        s = scenes[r["scene"]]
        h = r["proxy_spacing"] * r["texel_mm"]
        texture_space.append({"scene": r["scene"], "atlas": r["atlas"], "proxy_spacing": r["proxy_spacing"],
                              "h_mm": round(h, 4), "h_over_D": round(h / s["diagonal_mm"], 6),
                              "texel_over_ell": round(r["texel_mm"] / s["ell_min_mm"], 5),
                              "proxy_vertices": r["proxy_vertices"], "form_factors": r["form_factors"],
                              "bake_seconds": r["bake_seconds"], "frame_seconds": round(r["seconds"], 3),
                              "rel_rmse": round(r["rel_rmse_vs_model"], 5)})
    quadgraph = []
    for r in json.loads((RESULTS / "quadgraph" / "results.json").read_text())["exact_transport"]:
        if "K" in r:
            bake = next(b for b in json.loads((RESULTS / "quadgraph" / "results.json").read_text())["rows"]
                        if b["scene"] == r["scene"] and b.get("K") == r["K"])
            quadgraph.append({"scene": r["scene"], "K": r["K"], "surface_nodes": r["surface_nodes"],
                              "inner_nodes": r["inner_nodes"], "bake_seconds": bake["bake_seconds"],
                              "frame_seconds": round(r["seconds"], 3), "rel_rmse": round(r["rel_rmse"], 5),
                              "median": round(r["median"], 5)})
    data = {"source": "scripts/quality_curves.py from bench/results (make bench); machine: bench/results/machine.json",
            "atlas_fill": ATLAS_FILL, "profile": "EXACT", "scenes": scenes, "image_space": image_space,
            "texture_space": texture_space, "quadgraph": quadgraph}
    write_curves(data)
    print(f"wrote {OUT}: {len(image_space)} IMAGE_SPACE, {len(texture_space)} TEXTURE_SPACE, "
          f"{len(quadgraph)} QUADGRAPH rows")


if __name__ == "__main__":
    main()

"""Re-measure the cost of the TEXTURE_SPACE bakes that Auto's curves were measured on.

For each TEXTURE_SPACE row of translucent_addon/data/quality_curves.json (scene, atlas, proxy spacing) the
benchmark's scene is built and its subject baked as the add-on bakes it (Blender as a module, the decimated
proxy Blender makes), and the row's cost is rewritten: proxy vertices, form factors (near pairs and far-cluster
entries: what the run stores and walks) and seconds of bake on this machine. The rows' errors stay as the
benchmark measured them. ``.venv/bin/python scripts/texture_space_costs.py [--dry-run]``.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import blender_env  # noqa: E402
from quality_curves import OUT, write_curves  # noqa: E402


def bake_cost(mod, scene_name: str, atlas: int, spacing: float, profile: str) -> dict:
    import bpy

    demo, runner = mod("blender.demo"), mod("blender.compare_runner")
    bpy.ops.wm.read_homefile(use_empty=True)
    demo.build_scene(scene_name, bpy.context.scene)
    subject = bpy.data.objects[demo.SCENES[scene_name]["mesh"].capitalize()]
    t = subject.translucent
    t.quality, t.method, t.profile = "MANUAL", "TEXTURE_SPACE", profile
    t.atlas_resolution, t.proxy_spacing = atlas, spacing
    seconds, (meta,) = runner.bake_objects([subject], "TEXTURE_SPACE", lambda *a: None)
    return {"proxy_vertices": int(meta["proxy_vertices"]),
            "form_factors": int(meta["form_factors"] + meta["far_entries"]),
            "near_pairs": int(meta["form_factors"]), "far_entries": int(meta["far_entries"]),
            "clusters": int(meta["clusters"]), "bake_seconds": round(seconds, 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dry-run", action="store_true", help="print, do not rewrite the curves")
    args = parser.parse_args()
    package = blender_env.start()
    import importlib

    def mod(name):
        return importlib.import_module(f"{package}.translucent_addon.{name}")

    data = json.loads(OUT.read_text())
    profile = data.get("profile", "DIPOLE")  # the profile the rows' bakes were made with
    for row in data["texture_space"]:
        cost = bake_cost(mod, row["scene"], row["atlas"], row["proxy_spacing"], profile)
        print(row["scene"], row["atlas"], row["proxy_spacing"], cost, flush=True)
        row.update(cost)
    data["texture_space_costs"] = {"machine": f"{platform.machine()}, {platform.processor() or platform.system()}",
                                   "date": time.strftime("%Y-%m-%d"),
                                   "what": "proxy_vertices, form_factors (near pairs + far entries) and bake_seconds "
                                           "re-measured by scripts/texture_space_costs.py; errors as benchmarked"}
    if not args.dry_run:
        write_curves(data)


if __name__ == "__main__":
    main()

"""Measure the diffuse albedo that Cycles' random walk actually renders for a Base Color A.

    python scripts/calibrate_random_walk.py   (writes translucent_addon/data/cycles_random_walk_albedo.csv)

A thick slab with the Principled BSDF (random walk, roughness 0, IOR eta) under a uniform white
world, seen from above: rho_eff = (L - F_r(0)) / (1 - F_r(0)). ``compare.conversion`` inverts this
table; tests/test_cycles_conversion.py re-measures points of it against the Cycles in use.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
OUT = ROOT / "translucent_addon" / "data" / "cycles_random_walk_albedo.csv"
ETAS = (1.0, 1.3, 1.5)
ALBEDOS = np.round(np.concatenate([[0.02], np.linspace(0.05, 1.0, 20)]), 4)


def measure(A: float, eta: float, samples: int = 1024) -> float:
    import bpy

    from translucent_addon.blender import slab_scene
    from translucent_addon.blender.compare_runner import render_pixels
    from translucent_addon.core.physics.fresnel import fresnel_dielectric

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    mat = bpy.data.materials.new("rw")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.subsurface_method = "RANDOM_WALK"
    bsdf.inputs["Base Color"].default_value = (A, A, A, 1)
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Radius"].default_value = (0.002, 0.002, 0.002)  # 2 mm << the slab
    bsdf.inputs["Subsurface Scale"].default_value = 1.0
    bsdf.inputs["IOR"].default_value = eta
    bsdf.inputs["Roughness"].default_value = 0.0
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    slab_scene.build(scene, mat)
    slab_scene.configure_cycles(scene, samples, bounces=64)
    L = float(slab_scene.mean_radiance(render_pixels(scene, 8, 8)[0]).mean())
    F0 = float(fresnel_dielectric(1.0, eta))
    return (L - F0) / (1.0 - F0)


def main() -> None:
    import bpy

    rows = [f"# Cycles random-walk diffuse albedo rho_eff for Base Color A (bpy {bpy.app.version_string}, "
            "scripts/calibrate_random_walk.py)", "eta,A,rho_eff"]
    for eta in ETAS:
        for A in ALBEDOS:
            rho = measure(float(A), eta)
            rows.append(f"{eta},{A},{rho:.5f}")
            print(rows[-1], flush=True)
    OUT.write_text("\n".join(rows) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()

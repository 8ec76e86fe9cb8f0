"""Blender materials that render our medium in Cycles and EEVEE (bpy-facing, thin).

* ``brute_force``: a smooth dielectric boundary (Glass BSDF, roughness 0, IOR eta) around a
  homogeneous volume (Volume Scatter + Volume Absorption) with our sigma_s and sigma_a;
* ``random_walk``: the Principled BSDF with random-walk subsurface, inputs converted by
  ``compare.conversion.random_walk_inputs`` (also what EEVEE gets, as the real-time peer).
"""
from __future__ import annotations

import bpy

from .conversion import random_walk_inputs, volume_inputs


def _new_material(name: str):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    return mat, tree, out


def brute_force(name, sigma_a, sigma_s_prime, eta, g, mm_per_unit):
    v = volume_inputs(sigma_a, sigma_s_prime, eta, g, mm_per_unit)
    mat, tree, out = _new_material(name)
    glass = tree.nodes.new("ShaderNodeBsdfGlass")
    glass.distribution = "SHARP" if "SHARP" in {i.identifier for i in glass.bl_rna.properties["distribution"].enum_items} else "BECKMANN"
    glass.inputs["Roughness"].default_value = 0.0
    glass.inputs["IOR"].default_value = v.ior
    glass.inputs["Color"].default_value = (1, 1, 1, 1)
    scatter = tree.nodes.new("ShaderNodeVolumeScatter")
    scatter.inputs["Color"].default_value = (*v.scatter_color, 1)
    scatter.inputs["Density"].default_value = v.scatter_density
    scatter.inputs["Anisotropy"].default_value = v.anisotropy
    absorb = tree.nodes.new("ShaderNodeVolumeAbsorption")
    absorb.inputs["Color"].default_value = (*v.absorption_color, 1)
    absorb.inputs["Density"].default_value = v.absorption_density
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(scatter.outputs[0], add.inputs[0])
    tree.links.new(absorb.outputs[0], add.inputs[1])
    tree.links.new(glass.outputs[0], out.inputs["Surface"])
    tree.links.new(add.outputs[0], out.inputs["Volume"])
    return mat


def random_walk(name, sigma_a, sigma_s_prime, eta, g, mm_per_unit):
    rw = random_walk_inputs(sigma_a, sigma_s_prime, eta, g, mm_per_unit)
    mat, tree, out = _new_material(name)
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.subsurface_method = "RANDOM_WALK"
    bsdf.inputs["Base Color"].default_value = (*rw.base_color, 1)
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Radius"].default_value = rw.radius
    bsdf.inputs["Subsurface Scale"].default_value = 1.0
    bsdf.inputs["Subsurface Anisotropy"].default_value = rw.anisotropy
    bsdf.inputs["IOR"].default_value = rw.ior
    bsdf.inputs["Roughness"].default_value = 0.0
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return mat

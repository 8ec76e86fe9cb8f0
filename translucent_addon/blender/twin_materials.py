"""Blender materials that render our medium in Cycles and EEVEE (bpy-facing, thin).

* ``brute_force``: a smooth dielectric boundary (Glass BSDF, roughness 0, IOR eta) around a
  homogeneous volume (Volume Scatter + Volume Absorption) with our sigma_s and sigma_a. At eta = 1 the
  boundary is index-matched and has no surface shader: Cycles then samples the lights from inside the
  volume (next-event estimation), which a Glass boundary blocks, so the reference converges;
* ``random_walk``: the Principled BSDF with random-walk subsurface, inputs converted by
  ``compare.conversion.random_walk_inputs`` (also what EEVEE gets, as the real-time peer);
* ``leaf``: the grass blade of the BTF acquisition, for the blades drawn as geometry.
"""
from __future__ import annotations

import bpy

from ..core.physics.cycles_conversion import random_walk_inputs, volume_inputs

INDEX_MATCHED = 1.0 + 1e-6  # eta at or below this has no boundary to refract at


def _new_material(name: str):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    return mat, tree, out


def brute_force(name, sigma_a, sigma_s_prime, eta, g, mm_per_unit, surface_reflection: bool = True,
                self_interreflection: bool = True):
    """The volume behind a smooth boundary: exact transport, Cycles' ground truth for the diffusion methods.

    ``surface_reflection=False`` keeps the boundary's reflection from camera rays: the camera sees only the
    refracted part ((1 - F) of what leaves the medium), the translucency alone, as Wang 2010's ground truth
    (Fig. 11) is. ``self_interreflection=False`` makes the boundary black to rays arriving from outside
    other than camera rays: light that leaves the object and would enter it again elsewhere (from one ear
    into the other) is dropped, and the object still shadows itself. That is the transport every method
    here models (lights and world to the surface, through the medium, to the camera), so the difference
    that remains is the method's own. Inside, paths reflect and refract at the boundary with Fresnel's
    weights either way.

    With a surface shader Cycles logs "Maximum number of closures exceeded: 65 > 64" (measured on a sphere and
    the cow): its static count (``ShaderGraph::get_num_closures``) charges each volume closure the volume
    stack's size, 32, so the two volume closures alone count 64 and the boundary's BSDFs go past it; the
    kernel's limit of 64 is what it keeps. A shade here makes at most three closures: none is dropped."""
    v = volume_inputs(sigma_a, sigma_s_prime, eta, g, mm_per_unit)
    mat, tree, out = _new_material(name)
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
    tree.links.new(add.outputs[0], out.inputs["Volume"])
    index_matched = v.ior <= INDEX_MATCHED
    if index_matched and surface_reflection and self_interreflection:
        return mat  # no surface shader: light and camera rays cross the boundary unbent
    if index_matched:
        # Transparent: rays cross unbent, and shadow rays from inside reach the lights (next-event estimation).
        boundary = tree.nodes.new("ShaderNodeBsdfTransparent")
    else:
        boundary = tree.nodes.new("ShaderNodeBsdfGlass")
        boundary.distribution = "SHARP" if "SHARP" in {
            i.identifier for i in boundary.bl_rna.properties["distribution"].enum_items} else "BECKMANN"
        boundary.inputs["Roughness"].default_value = 0.0
        boundary.inputs["IOR"].default_value = v.ior
        boundary.inputs["Color"].default_value = (1, 1, 1, 1)
    camera_view = boundary
    if not index_matched and not surface_reflection:
        camera_view = tree.nodes.new("ShaderNodeBsdfRefraction")
        camera_view.distribution = boundary.distribution
        camera_view.inputs["Roughness"].default_value = 0.0
        camera_view.inputs["IOR"].default_value = v.ior
        fresnel = tree.nodes.new("ShaderNodeFresnel")
        fresnel.inputs["IOR"].default_value = v.ior
        transmitted = tree.nodes.new("ShaderNodeMath")
        transmitted.operation = "SUBTRACT"
        transmitted.inputs[0].default_value = 1.0
        tree.links.new(fresnel.outputs[0], transmitted.inputs[1])
        tree.links.new(transmitted.outputs[0], camera_view.inputs["Color"])
    others = boundary
    if not self_interreflection:
        # Rays that are not camera rays and hit the outside (front face) end there: a black boundary.
        geometry = tree.nodes.new("ShaderNodeNewGeometry")
        from_inside = tree.nodes.new("ShaderNodeMixShader")
        tree.links.new(geometry.outputs["Backfacing"], from_inside.inputs[0])
        tree.links.new(boundary.outputs[0], from_inside.inputs[2])  # input 1 left empty: no closure, black
        others = from_inside
    if camera_view is others:
        tree.links.new(others.outputs[0], out.inputs["Surface"])
        return mat
    path = tree.nodes.new("ShaderNodeLightPath")
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(path.outputs["Is Camera Ray"], mix.inputs[0])
    tree.links.new(others.outputs[0], mix.inputs[1])
    tree.links.new(camera_view.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
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


def leaf(name, specular: float, reflectance: str = "rho_r", transmittance: str = "rho_t"):
    """The grass blade of the BTF acquisition (``techniques/grass/acquire.py``) for Cycles and EEVEE: Lambert
    reflection with the vertex attribute ``rho_r``, diffuse transmission through the blade with ``rho_t``
    (Translucent BSDF), and the cuticle sheen as a GGX lobe of weight ``specular`` at roughness 0.5 (the
    Beckmann slope sqrt(2 / (e + 2)) = 0.25 of the acquisition's Blinn-Phong exponent e = 30, squared
    roughness as Blender takes it). Both sides of a blade shade alike, as in the acquisition."""
    mat, tree, out = _new_material(name)
    attr_r = tree.nodes.new("ShaderNodeAttribute")
    attr_r.attribute_name = reflectance
    attr_t = tree.nodes.new("ShaderNodeAttribute")
    attr_t.attribute_name = transmittance
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    translucent = tree.nodes.new("ShaderNodeBsdfTranslucent")
    glossy = tree.nodes.new("ShaderNodeBsdfGlossy")
    glossy.distribution = "GGX"
    glossy.inputs["Roughness"].default_value = 0.5
    glossy.inputs["Color"].default_value = (specular, specular, specular, 1.0)
    tree.links.new(attr_r.outputs["Color"], diffuse.inputs["Color"])
    tree.links.new(attr_t.outputs["Color"], translucent.inputs["Color"])
    add1 = tree.nodes.new("ShaderNodeAddShader")
    add2 = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(diffuse.outputs[0], add1.inputs[0])
    tree.links.new(translucent.outputs[0], add1.inputs[1])
    tree.links.new(add1.outputs[0], add2.inputs[0])
    tree.links.new(glossy.outputs[0], add2.inputs[1])
    tree.links.new(add2.outputs[0], out.inputs["Surface"])
    mat.diffuse_color = (0.08, 0.2, 0.04, 1.0)
    return mat

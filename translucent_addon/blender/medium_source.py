"""Where an object's medium comes from (bpy-facing, thin; the conversion is ``core.physics.cycles_conversion``'s).

A material's look lives on the Material, shared by every object that uses it: the object's medium is that of
its first material (``Material.translucent.source``):

* ``PRINCIPLED`` (the default): converted from the Principled BSDF's subsurface inputs, as Cycles' random walk
  renders them (``medium_from_random_walk``), so a Cycles material previews with nothing to set;
* ``MATERIAL``: a preset or coefficients set on the material;
* ``OBJECT``: each object's own coefficients (``Object.translucent``), how files from 0.1 keep their media.

An object with no material, or whose Principled BSDF has no subsurface (Subsurface Weight 0), or that has no
Principled BSDF at all, keeps its own coefficients: the panel says which holds.
"""
from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ..core.physics.cycles_conversion import medium_from_random_walk
from .material_surface import principled_bsdf, texture_base_color

ETA_RANGE = (1.0, 3.0)  # the medium settings' IOR range (``props`` takes it from here)
G_RANGE = (-0.99, 0.99)  # and their anisotropy's


@dataclasses.dataclass(frozen=True)
class ObjectMedium:
    """An object's medium as the frame and the bake use it."""

    sigma_a: tuple  # mm^-1, RGB
    sigma_s_prime: tuple  # mm^-1, RGB
    eta: float
    g: float
    profile: str  # the Profile setting: EXACT, DIPOLE or MULTIPOLE (a layer over a base)
    layer_thickness: float  # Blender units, MULTIPOLE
    base_sigma_a: tuple
    base_sigma_s_prime: tuple
    mm_per_unit: float  # the object's
    source: str  # PRINCIPLED, MATERIAL or OBJECT
    material: str  # the material's name ("": none)
    reason: str  # where the medium comes from, in one line for the panel
    notes: tuple = ()  # what of the material is not drawn as Cycles would (a texture on an input, ...)


def unit_mm(scene) -> float:
    """Millimetres per Blender unit in the scene's unit system (Unit Scale: 1 = metres)."""
    return 1000.0 * float(scene.unit_settings.scale_length)


def mm_per_unit(settings, scene=None) -> float:
    """Millimetres of the medium per Blender unit for an object's settings: the scene's unit over the object's
    scattering scale (2: light scatters twice as far, as Cycles' Subsurface Scale makes it)."""
    if scene is None:
        import bpy

        scene = bpy.context.scene
    scale = float(settings.scattering_scale)  # a file or a script can store 0 or NaN: inf, refused by its users
    return unit_mm(scene) / scale if scale > 0.0 else float("inf")


def medium_material(ob):
    """The material that holds the object's medium: its first slot with a material (None: no material)."""
    for slot in ob.material_slots:
        if slot.material is not None:
            return slot.material
    return None


def _value(node, name: str, notes: list):
    sock = node.inputs[name]
    if sock.is_linked:
        notes.append(f"{name} is linked to other nodes: its own value is used")
    value = sock.default_value
    return tuple(float(v) for v in value) if hasattr(value, "__len__") else float(value)


@dataclasses.dataclass(frozen=True)
class PrincipledInputs:
    """The Principled BSDF inputs that make its subsurface medium."""

    base_color: tuple
    radius: tuple  # Subsurface Radius x Subsurface Scale, Blender units
    ior: float
    anisotropy: float
    weight: float
    notes: tuple


def principled_inputs(node) -> PrincipledInputs:
    notes: list = []
    weight = _value(node, "Subsurface Weight", notes)
    base = _value(node, "Base Color", notes)[:3]
    radius = np.asarray(_value(node, "Subsurface Radius", notes), np.float64) * _value(node, "Subsurface Scale",
                                                                                          notes)
    ior = _value(node, "IOR", notes)
    anisotropy = _value(node, "Subsurface Anisotropy", notes)
    if 0.0 < weight < 1.0:
        notes.append(f"Subsurface Weight {weight:g} is drawn as 1: the engine does not mix in a diffuse part")
    if getattr(node, "subsurface_method", "RANDOM_WALK") != "RANDOM_WALK":
        notes.append(f"subsurface method {node.subsurface_method.replace('_', ' ').title()} is converted as "
                     f"Random Walk")
    eta = min(max(ior, ETA_RANGE[0]), ETA_RANGE[1])
    if eta != ior:
        notes.append(f"IOR {ior:g} is drawn as {eta:g}")
    return PrincipledInputs(tuple(base), tuple(float(r) for r in radius), eta,
                            min(max(anisotropy, G_RANGE[0]), G_RANGE[1]), float(weight), tuple(notes))


def principled_of(mat) -> tuple[PrincipledInputs | None, str]:
    """(the subsurface inputs of the material's Principled BSDF, "") or (None, why it has none to convert:
    "no Principled BSDF", "Subsurface Weight 0")."""
    node = principled_bsdf(mat)
    if node is None:
        return None, "no Principled BSDF"
    p = principled_inputs(node)
    return (p, "") if p.weight > 0.0 else (None, "Subsurface Weight 0")


@functools.lru_cache(maxsize=256)
def _converted(base_color: tuple, radius: tuple, ior: float, anisotropy: float, mm_per_unit: float):
    sigma_a, sigma_s_prime = medium_from_random_walk(base_color, radius, ior, anisotropy, mm_per_unit)
    return tuple(map(float, sigma_a)), tuple(map(float, sigma_s_prime))


def _own(ob, s, mm: float, reason: str, source: str = "OBJECT", material: str = "",
         notes: tuple = ()) -> ObjectMedium:
    """The medium of a property group that holds coefficients (the object's or the material's)."""
    return ObjectMedium(tuple(s.sigma_a), tuple(s.sigma_s_prime), float(s.eta), float(s.g), s.profile,
                        float(s.layer_thickness), tuple(s.base_sigma_a), tuple(s.base_sigma_s_prime), mm, source,
                        material, reason, notes)


def resolve(ob, scene=None) -> ObjectMedium:
    """The object's medium: from its material (converted from the Principled BSDF, or the material's
    coefficients) or its own, with the reason in one line. ``scene``: whose unit system measures it (None: the
    context's)."""
    mm = mm_per_unit(ob.translucent, scene)
    mat = medium_material(ob)
    if mat is None:
        return _own(ob, ob.translucent, mm, "The object's own: it has no material")
    m = mat.translucent
    if m.source == "MATERIAL":
        return _own(ob, m, mm, f"Material '{mat.name}': its coefficients", "MATERIAL", mat.name)
    if m.source == "OBJECT":
        return _own(ob, ob.translucent, mm, f"The object's own: material '{mat.name}' leaves it to each object",
                    material=mat.name)
    p, why = principled_of(mat)
    if p is None:
        return _own(ob, ob.translucent, mm, f"The object's own: material '{mat.name}' has {why}", material=mat.name)
    base = texture_base_color(ob, mat)  # a texture on Base Color: its mean over the surface
    notes = p.notes if base is None else tuple(n for n in p.notes if not n.startswith("Base Color "))
    p = p if base is None else dataclasses.replace(p, base_color=base, notes=notes)
    sigma_a, sigma_s_prime = _converted(p.base_color, p.radius, p.ior, p.anisotropy, mm)
    return ObjectMedium(sigma_a, sigma_s_prime, p.ior, p.anisotropy, "EXACT", 0.001, sigma_a, sigma_s_prime, mm,
                        "PRINCIPLED", mat.name, f"Material '{mat.name}': from its Principled BSDF",
                        p.notes + other_slots_notes(ob, mat, p))


def other_slots_notes(ob, mat, p: PrincipledInputs) -> tuple:
    """What the object's other material slots ask that one medium per object cannot draw: a subsurface radius,
    IOR or anisotropy of their own (their colour is drawn: ``core/surface.py``), or no subsurface at all."""
    notes = []
    for slot in ob.material_slots:
        other = slot.material
        if other is None or other == mat:
            continue
        q, why = principled_of(other)
        if q is None:
            notes.append(f"material '{other.name}' has {why}: its faces are drawn with the subsurface of "
                         f"'{mat.name}' in its colour")
        elif not (np.allclose(q.radius, p.radius, rtol=1e-4) and abs(q.ior - p.ior) < 1e-4
                  and abs(q.anisotropy - p.anisotropy) < 1e-4):
            notes.append(f"material '{other.name}': one medium per object: its radius, IOR and anisotropy are "
                         f"drawn as '{mat.name}''s, its colour as its own")
    return tuple(notes)


def editable(ob):
    """The property group whose coefficients the panel and the preset operators edit for this object: the
    material's (source MATERIAL), the object's (its own medium), or None (converted from a Principled BSDF:
    edited there)."""
    medium = resolve(ob)
    if medium.source == "MATERIAL":
        return medium_material(ob).translucent
    if medium.source == "OBJECT":
        return ob.translucent
    return None

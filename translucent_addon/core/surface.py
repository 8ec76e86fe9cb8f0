"""The artist's surface, per corner: colour textures, gloss and normal maps of the materials. Pure.

``blender/material_surface.py`` reads each material slot's Principled BSDF into a ``SlotSurface``; ``surface_of``
turns the slots and the mesh's UVs into the ``Surface`` a ``MeshInstance`` carries, which the surface layer
(``gpu_shaders/pipeline/surface_layer.glsl``) draws:

* **Colour.** Cycles' random walk takes the medium's albedo and radius from the closure where the path from the
  eye meets the surface and sets up a plain diffuse BSDF of weight one where it leaves the medium
  (``subsurface_bounce`` and ``subsurface_shader_data_setup`` in Cycles' ``kernel/integrator/subsurface.h``): in
  the light's direction, a texture colours the subsurface light where it *leaves* towards the eye, and the colour
  where it entered does not matter. The subsurface methods draw one medium per object, converted from a reference
  colour A_ref (the first slot's Base Color, or its texture's mean over the surface); the surface layer scales
  the light they leave at x by rho_eff(A(x)) / rho_eff(A_ref), rho_eff the albedo Cycles' walk renders for a Base
  Color (``cycles_conversion.random_walk_albedo``): the ``albedo`` factor per corner, or per texel of
  ``albedo_map``. Lambert (OFF) objects: the factor is the colour itself over the colour the base pass drew.
* **Gloss**: each corner's roughness, F_0 (IOR and IOR Level) and normal-map strength (``gloss``).
* **Normal maps**: a tangent-space map (``normal_map``) through per-corner tangents (``corner_tangents``).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .physics.cycles_conversion import random_walk_albedo
from .physics.microfacet import f0_of


@dataclasses.dataclass(frozen=True)
class ImageRef:
    """An image a slot reads through a UV map: its key (name and change stamp), pixels ((H, W, 4) float32, linear,
    row 0 at the bottom), the UV map's name ("": the active render map) and the 2D affine of a Mapping node
    ((2, 3): uv' = M [u, v, 1])."""

    key: str
    pixels: np.ndarray = dataclasses.field(compare=False, repr=False)
    uv_map: str = ""
    mapping: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    closest: bool = False  # the Image Texture's Closest interpolation (else Linear)
    extend: bool = False  # its EXTEND extension: the border texels continue (else REPEAT)

    @property
    def mode(self) -> int:
        """The surface layer's read mode: 1 closest, 2 extend (``sample_bilinear``'s)."""
        return int(self.closest) | 2 * int(self.extend)


@dataclasses.dataclass(frozen=True)
class SlotSurface:
    """One material slot's surface: its Base Color's own value (drawn where no texture is read), its texture,
    roughness, IOR, IOR Level, normal map and strength, whether it has a specular layer at all, and what of it is
    not drawn as Cycles draws it (one line each)."""

    base_color: tuple = (0.8, 0.8, 0.8)
    color_map: ImageRef | None = None
    roughness: float = 0.5
    ior: float = 1.5
    ior_level: float = 0.5
    normal_map: ImageRef | None = None
    normal_strength: float = 1.0
    specular: bool = True
    notes: tuple = ()


@dataclasses.dataclass
class Surface:
    """A mesh's surface per corner (3T corners, the MeshInstance's order) and the images the GPU reads.

    albedo (3T, 4): rgb the colour factor where the corner's slot has no texture, a: 1 where ``albedo_map`` gives
    it instead; gloss (3T, 4): roughness, F_0, normal-map strength (0: none), the specular layer's weight (1 drawn,
    0 not; a medium's own boundary takes the painted translucency mask);
    uv (3T, 2) and tangent (3T, 4: xyz, handedness) in object space; the images hold factors ready to multiply
    (``albedo_map``: rho_eff ratios or Lambert colours) and unit tangent-space normals."""

    albedo: np.ndarray
    gloss: np.ndarray
    uv: np.ndarray
    tangent: np.ndarray
    albedo_map: ImageRef | None = None
    normal_map: ImageRef | None = None
    key: str = ""  # what the GPU batch and images are made of: equal keys, equal arrays
    notes: tuple = ()

    def __post_init__(self) -> None:
        n = len(self.albedo)
        if self.albedo.shape != (n, 4) or self.gloss.shape != (n, 4) or self.uv.shape != (n, 2) \
                or self.tangent.shape != (n, 4):
            raise ValueError("surface arrays must be (3T, 4), (3T, 4), (3T, 2) and (3T, 4)")

    @property
    def textured(self) -> bool:
        """Whether any corner's colour differs from what the methods draw (a texture or a factor other than 1)."""
        return bool((self.albedo[:, 3] > 0.0).any() or np.abs(self.albedo[:, :3] - 1.0).max(initial=0.0) > 1e-6)

    @property
    def glossy(self) -> bool:
        """Whether any corner has a specular layer that reflects (on, F_0 > 0)."""
        return bool(((self.gloss[:, 3] > 0.0) & (self.gloss[:, 1] > 0.0)).any())


def plain(n: int, roughness: float = 0.0, f0: float = 0.0, specular: bool = False) -> Surface:
    """A surface that changes nothing the methods draw: factor 1, no texture; a specular layer of one roughness
    and F_0 when ``specular`` (a medium's smooth boundary, as drawn before materials had gloss)."""
    gloss = np.tile(np.array([roughness, f0, 0.0, float(specular)], np.float32), (n, 1))
    return Surface(np.tile(np.array([1, 1, 1, 0], np.float32), (n, 1)), gloss, np.zeros((n, 2), np.float32),
                   np.tile(np.array([1, 0, 0, 1], np.float32), (n, 1)), key=f"plain:{n}:{roughness}:{f0}:{specular}")


def apply_mapping(uv: np.ndarray, mapping: tuple) -> np.ndarray:
    """uv' = M [u, v, 1] for a Mapping node's 2D affine (``ImageRef.mapping``)."""
    M = np.asarray(mapping, np.float64)
    return (np.asarray(uv, np.float64) @ M[:, :2].T + M[:, 2]).astype(np.float32)


def mapping_affine(location: tuple, rotation_z: float, scale: tuple, kind: str = "POINT") -> tuple:
    """The 2D affine of a Mapping node on UVs (z rotation only): POINT uv' = R (S uv) + T; TEXTURE is its inverse
    (the texture moves, not the point); VECTOR drops T; NORMAL is not a UV transform (identity)."""
    c, s = np.cos(rotation_z), np.sin(rotation_z)
    R = np.array([[c, -s], [s, c]])
    S = np.diag([scale[0], scale[1]])
    A = R @ S
    t = np.array(location[:2], np.float64)
    if kind == "VECTOR":
        t = np.zeros(2)
    elif kind == "TEXTURE":
        A = np.linalg.inv(A)
        t = -A @ t
    elif kind == "NORMAL":
        A, t = np.eye(2), np.zeros(2)
    return tuple(tuple(float(x) for x in row) for row in np.hstack([A, t[:, None]]))


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """The sRGB transfer function inverted (IEC 61966-2-1)."""
    c = np.asarray(c, np.float32)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def sample_bilinear(pixels: np.ndarray, uv: np.ndarray, mode: int = 0) -> np.ndarray:
    """(N, C) an image read at uv (texel centres at (i + 0.5) / W) as the surface layer reads it: bilinear or the
    closest texel (mode & 1), repeating or continuing the border texels (mode & 2)."""
    h, w = pixels.shape[:2]
    x = np.asarray(uv[:, 0], np.float64) * w - 0.5
    y = np.asarray(uv[:, 1], np.float64) * h - 0.5
    if mode & 1:
        x, y = np.floor(x + 0.5), np.floor(y + 0.5)
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    if mode & 2:
        xa, xb, ya, yb = (np.clip(a, 0, n - 1) for a, n in ((x0, w), (x0 + 1, w), (y0, h), (y0 + 1, h)))
    else:
        xa, xb, ya, yb = x0 % w, (x0 + 1) % w, y0 % h, (y0 + 1) % h
    top = pixels[ya, xa] * (1 - fx) + pixels[ya, xb] * fx
    bottom = pixels[yb, xa] * (1 - fx) + pixels[yb, xb] * fx
    return top * (1 - fy) + bottom * fy


def surface_mean(pixels: np.ndarray, uv: np.ndarray, positions: np.ndarray, mode: int = 0) -> np.ndarray:
    """(3,) an image's mean colour over a surface: read at each triangle's centroid in UV, weighed by its area."""
    p = np.asarray(positions, np.float64).reshape(-1, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    centre = np.asarray(uv, np.float64).reshape(-1, 3, 2).mean(axis=1)
    colour = sample_bilinear(pixels[..., :3], centre, mode)
    total = float(area.sum())
    return colour.mean(axis=0) if total <= 0.0 else (colour * area[:, None]).sum(axis=0) / total


def corner_tangents(positions: np.ndarray, normals: np.ndarray, uv: np.ndarray, corner_vert: np.ndarray) -> np.ndarray:
    """(3T, 4) per-corner tangents for tangent-space normal maps: each triangle's dP/du (Lengyel's method), summed
    over the corners of a vertex that share its UV, made orthogonal to the corner's normal (Gram-Schmidt), and
    w = +-1, the side of the bitangent (n x t) on which dP/dv lies. Degenerate UVs: any unit vector normal to n."""
    p = np.asarray(positions, np.float64).reshape(-1, 3, 3)
    t = np.asarray(uv, np.float64).reshape(-1, 3, 2)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.where(np.abs(det) > 1e-20, 1.0 / np.where(det == 0.0, 1.0, det), 0.0)[:, None]
    dPdu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r
    dPdv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    n_corners = len(corner_vert)
    # Corners of one vertex with the same UV share their tangent (a UV seam keeps two).
    key = np.column_stack([np.asarray(corner_vert, np.int64), np.round(np.asarray(uv, np.float64) * 1e6)])
    _, group = np.unique(key, axis=0, return_inverse=True)
    group = group.ravel()
    su = np.zeros((group.max() + 1 if n_corners else 0, 3))
    sv = np.zeros_like(su)
    np.add.at(su, group, np.repeat(dPdu, 3, axis=0))
    np.add.at(sv, group, np.repeat(dPdv, 3, axis=0))
    n = np.asarray(normals, np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)
    tu = su[group] - n * np.sum(n * su[group], axis=1, keepdims=True)
    length = np.linalg.norm(tu, axis=1, keepdims=True)
    fallback = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    tu = np.where(length > 1e-12, tu / np.maximum(length, 1e-300), fallback / np.linalg.norm(fallback, axis=1,
                                                                                            keepdims=True))
    w = np.where(np.sum(np.cross(n, tu) * sv[group], axis=1) < 0.0, -1.0, 1.0)
    return np.column_stack([tu, w]).astype(np.float32)


def surface_of(slots: list[SlotSurface], palette: np.ndarray, material_index: np.ndarray, uv_maps: dict,
               positions: np.ndarray, normals: np.ndarray, corner_vert: np.ndarray, *, eta: float | None,
               reference: tuple | None, key: str = "") -> Surface:
    """A mesh's ``Surface`` from its material slots (``material_index`` per triangle), the colour each slot's
    faces are drawn with (``palette``, (slots, 3): a texture's mean where one is on Base Color) and its UV maps
    (name -> (3T, 2) corners; "" the active render map, absent when the mesh has none).

    ``eta`` and ``reference``: a subsurface object's IOR and the Base Color its medium was converted from (colour
    factors are rho_eff ratios, module doc); None: a Lambert object (factors are colours over the palette's, which
    the base pass drew). One colour texture and one normal map per object, the first slots' that have one; the
    others' are drawn by their mean colour or not at all, said in ``notes``."""
    n = len(positions)
    slots = slots or [SlotSurface(specular=False)]
    index = np.clip(np.asarray(material_index, np.int64), 0, len(slots) - 1).repeat(3)
    notes: list[str] = []
    colour_slot = next((k for k, s in enumerate(slots) if s.color_map is not None), None)
    normal_slot = next((k for k, s in enumerate(slots) if s.normal_map is not None), None)

    def uv_for(ref: ImageRef) -> np.ndarray | None:
        uv = uv_maps.get(ref.uv_map) if ref.uv_map else uv_maps.get("")
        return None if uv is None else apply_mapping(uv, ref.mapping)

    uv = np.zeros((n, 2), np.float32)
    albedo_map = normal_map = None
    if colour_slot is not None:
        ref = slots[colour_slot].color_map
        mapped = uv_for(ref)
        if mapped is None:
            notes.append(f"no UV map '{ref.uv_map or 'active'}': the colour texture is drawn by its mean colour")
            colour_slot = None
        else:
            uv[:] = mapped
            albedo_map = ref
    if normal_slot is not None:
        ref = slots[normal_slot].normal_map
        mapped = uv_for(ref)
        if mapped is None:
            notes.append(f"no UV map '{ref.uv_map or 'active'}': the normal map is not drawn")
            normal_slot = None
        elif albedo_map is not None and (ref.uv_map, ref.mapping) != (albedo_map.uv_map, albedo_map.mapping):
            notes.append("the normal map reads other UVs than the colour texture: drawn through the colour's")
            normal_map = ref
        else:
            uv[:] = mapped
            normal_map = ref
    others = [k for k, s in enumerate(slots) if s.color_map is not None and k != colour_slot]
    if others:
        notes.append("one colour texture per object: slot " + ", ".join(str(k + 1) for k in others)
                     + " drawn by its texture's mean colour")

    palette = np.asarray(palette, np.float64).reshape(-1, 3)
    palette = np.vstack([palette, np.tile(palette[-1:], (max(len(slots) - len(palette), 0), 1))])

    def factor(colour: np.ndarray, k: int) -> np.ndarray:
        c = np.asarray(colour, np.float64)
        if eta is None:  # Lambert: over the colour the base pass drew
            return c / np.maximum(palette[k], 1e-4)
        ref = np.maximum(random_walk_albedo(np.clip(reference, 0.0, 1.0), eta), 1e-4)
        return random_walk_albedo(np.clip(c, 0.0, 1.0), eta) / ref

    table = np.array([[*factor(palette[k], k), 0.0] for k in range(len(slots))], np.float32)
    if albedo_map is not None:
        table[colour_slot] = (1.0, 1.0, 1.0, 1.0)
        px = albedo_map.pixels
        rgb = factor(px[..., :3].reshape(-1, 3), colour_slot).reshape(*px.shape[:2], 3)
        albedo_map = dataclasses.replace(albedo_map, key=f"{albedo_map.key}|{eta}|{reference}",
                                         pixels=np.dstack([rgb, np.ones(px.shape[:2])]).astype(np.float32))
    albedo = table[index]
    gloss_table = np.array([[s.roughness, f0_for(s), s.normal_strength if k == normal_slot else 0.0,
                             float(s.specular)] for k, s in enumerate(slots)], np.float32)
    gloss = gloss_table[index]
    if normal_map is not None:
        tangent = corner_tangents(positions, normals, uv, corner_vert)
    else:
        tangent = np.tile(np.array([1, 0, 0, 1], np.float32), (n, 1))
    for s in slots:
        notes.extend(s.notes)
    return Surface(albedo, gloss, uv, tangent, albedo_map, normal_map, key=key, notes=tuple(dict.fromkeys(notes)))


def f0_for(slot: SlotSurface) -> float:
    """F_0 of a slot's specular layer (``microfacet.f0_of``)."""
    return f0_of(slot.ior, slot.ior_level)

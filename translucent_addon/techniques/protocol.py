"""One technique's contract with the pipeline, the registry and the Blender layer.

A technique is a folder under ``techniques/`` (``model.py``, ``bake.py``, ``passes.py``, ``quality.py``) whose
``passes.py`` holds a ``Technique`` subclass; one line in ``techniques/__init__.py`` registers it. The pipeline
names no technique: each frame it asks every registered technique, in registry order,

1. ``prepare(ctx)``: what it will draw this frame (``None``: nothing; its other hooks are skipped);
2. in the world pass, after the base: ``world(ctx, state, light_ubo)`` (a placeholder light block);
3. per emitter, into the bound target with additive blending, after the base: ``emitter_surface``; then, with
   that emitter's shadow atlas, ``emitter`` (maps lit in texture space, caustics);
4. after every emitter: ``finish(ctx, state)`` (what it draws over the base), timed under ``timing``.

``replaces_base`` names meshes the technique draws instead of the base pass (height fields);
``base_lighting`` lets one technique give the base pass its near-field inputs (IMAGE_SPACE's materials and
LUT); ``unfitted_shadow`` asks for a shadow map over the whole scene sphere (caustics need the receivers).
Its own properties (``object_props``, ``scene_props``, ``light_props``) join ``Object``, ``Scene`` and
``Light.translucent``. The Blender layer reads the ``scene_properties`` a technique names from
``Scene.translucent`` and hands them to ``settings``, whose result travels in the frame
(``FrameInputs.settings``); ``shader_specs`` joins the shader table; ``bake`` runs its ``bake_stages``
(``registry.run``); ``auto_quality`` is its Auto quality (``quality_auto.choose``); ``clear_caches`` runs when
the extension is disabled.

What an object of its method carries it declares too, so that no other layer names it: the Object.translucent
properties its medium reads (``medium_properties`` -> ``medium_extras``, the frame's ``Medium.extras``), its bake
reads (``bake_properties`` -> ``bake_parameters``, the bake's ``BakeInputs.params``; ``make_proxies``,
``hash_parts``, ``bake_summary``), and its object panel (``panel``, ``panel_notes``). ``frame_settings`` adjusts
its settings to the frame about to be drawn (IMAGE_SPACE's Auto splat overlap) and leaves what the panel says
in the frame's results (``blender.session.Session.results``).
"""
from __future__ import annotations

import dataclasses

from ..gpu.frame_context import FrameContext


@dataclasses.dataclass(frozen=True)
class Variant:
    """One way Compare with Cycles draws an object of a method: a label, the Object.translucent and
    Scene.translucent values it is drawn with, and what the report records of it besides the label."""

    label: str
    object_values: dict = dataclasses.field(default_factory=dict)
    scene_values: dict = dataclasses.field(default_factory=dict)
    record: dict = dataclasses.field(default_factory=dict)


class Technique:
    """Defaults: a technique that declares nothing and draws nothing."""

    id: str = ""
    label: str = ""
    description: str = ""
    method_number: int | None = None  # its stable value in Object.translucent.method; None: not a method
    scene_properties: tuple[str, ...] = ()  # the Scene.translucent properties its ``settings`` reads
    # Its own properties (``core.properties.Prop``), joined to Object/Scene/Light.translucent by the Blender layer.
    object_props: tuple = ()
    scene_props: tuple = ()
    light_props: tuple = ()
    shader_specs: dict = {}
    timing: str | None = None  # the key of the last frame's timings its ``finish`` is counted under
    bake_stages: tuple[str, ...] = ()  # named steps of its bake (none: it needs no bake)
    bake_errors: tuple[type, ...] = ()  # its bake's refusals, shown as one line (BakeInputError)
    no_bake_reason: str = ""  # why Bake does nothing for it, where it needs none
    emitter_timing: str = "lights"  # the key its ``emitter`` hook is counted under
    # -- an object of its method -------------------------------------------------------------------------------
    medium_properties: tuple[str, ...] = ()  # the Object.translucent properties ``medium_extras`` reads
    draws_layers: bool = False  # draws a medium that is a layer over a base (multipole); others draw the top alone
    draws_paint: bool = False  # draws the painted layers (blur, glow, mask, tint: Shah ch. 7)
    base_entry_shift: bool = False  # the base pass shifts light entering at an angle (``physics.oblique_entry``)
    surface_layer: bool = True  # the materials' surface layer (gloss, colour textures) goes over what it draws
    owns_surface: bool = False  # as an extra on an object (grass, a height field) it draws that surface itself
    panel: tuple[tuple[str, ...], ...] = ()  # its Object.translucent properties in the object panel, by column
    auto_note: str = ""  # what the Auto summary adds for it
    scene_panel: tuple[tuple[str, ...], ...] = ()  # its Scene.translucent properties in its scene section, by column
    scene_panel_label: str = ""  # that section's title ("": its label)
    # Quality tiers: its Object.translucent and Scene.translucent values at Draft, Standard and High (tier -> values).
    object_tiers: dict = {}
    scene_tiers: dict = {}
    # Compare with Cycles: what ``compare_variants`` draws by default, in a full comparison and a quick one.
    compare_defaults: tuple = ()
    compare_quick: tuple = ()
    # The CPU dipole model (light diffusing below the surface) models what it draws, so the comparison renders the
    # model beside it; glass it does not model.
    dipole_modelled: bool = True
    # -- its bake -----------------------------------------------------------------------------------------------
    bake_properties: tuple[str, ...] = ()  # the Object.translucent properties ``bake_parameters`` reads
    bake_corner_normals: bool = False  # its bake lights with the display's corner normals (BakeInputs.corner_normals)

    def settings(self, values: dict):
        """This technique's frame settings from its ``scene_properties`` values (name -> value)."""
        return None

    def bake(self, inputs, stage: str):
        """Generator for one of its ``bake_stages``: yields (fraction, text); returns (arrays, meta) to store
        (``registry.run``)."""
        raise NotImplementedError(f"{self.id} has no bake")

    @property
    def has_auto_quality(self) -> bool:
        """Whether it answers ``auto_quality`` (it overrides the default, which has none)."""
        return type(self).auto_quality is not Technique.auto_quality

    def bake_parameters(self, values: dict):
        """Its part of a bake's inputs (``BakeInputs.params``) from its ``bake_properties`` values (name -> value;
        a name left out takes its default)."""
        return None

    def needs_screen_pixels(self, params) -> bool:
        """Whether its bake needs the object's size on the camera's image (``BakeInputs.screen_pixels``)."""
        return False

    def make_proxies(self, inputs, decimate):
        """Generator of (fraction, text): what only its bake needs made by Blender before it runs, written into
        ``inputs.params``; ``decimate(vertices, triangles, target)`` is Blender's collapse decimation."""
        yield from ()

    def hash_parts(self, inputs, geometry: dict, material: dict) -> tuple[dict, dict]:
        """(geometry arrays, parameters) its bake depends on, from the common ones (``BakeInputs.hash_parts``):
        by default the geometry and the material."""
        return geometry, material

    def bake_summary(self, meta: dict) -> list[str]:
        """Lines saying what a bake of its holds, from the bake's metadata (the object panel)."""
        return []

    def medium_extras(self, values: dict, mm_per_unit: float):
        """Its own part of an object's medium (``Medium.extras``: frozen and hashable) from its
        ``medium_properties`` values, or None."""
        return None

    def compare_variants(self, values: tuple) -> list[Variant]:
        """Compare with Cycles: the ways to draw its objects, one image each, from a series of values (its
        resolutions, densities or overlaps; ``compare_defaults``); none: it is drawn as the objects are set."""
        return [Variant("as set")]

    def object_extras(self, reader):
        """What it draws of one object whatever the object's method (``MeshInstance.extras[id]``: a caustics
        caster, a grass field, a height field), or None. ``reader`` (``blender.extract.ObjectReader``) gives the
        object's ``name``, ``values(names)`` of Object.translucent, its drawn ``positions``, ``uv_corners()``,
        ``image_data(image, derive)``, ``stored_bake(key, digest)`` and ``warn(text)`` for the frame."""
        return None

    def frame_settings(self, frame, settings, results: dict, cache: dict):
        """Its settings for this frame (``FrameInputs``), from those of the scene; what the object panel should
        say of the frame goes into ``results``; ``cache`` is its own, kept across frames (both the session's)."""
        return settings

    def scene_panel_notes(self, results: dict) -> list[str]:
        """Lines for its scene section from the last frame's ``results`` of this technique."""
        return []

    def panel_notes(self, results: dict, object_name: str) -> list[str]:
        """Lines for an object's panel from the last frame's ``results`` of this technique."""
        return []

    def auto_quality(self, view, target: float, curves: str):
        """Auto quality (``quality_auto.choose``): the resolutions that reach ``target`` at the least cost for
        ``view`` (``core.quality_model.ObjectView``), as a ``Choice``; None where it has none."""
        return None

    def prepare(self, ctx: FrameContext):
        return None

    def replaces_base(self, state) -> set[int]:
        return set()

    def base_lighting(self, state):
        """(materials block, near-field LUT, {mesh index: its subsurface tag}) for the base pass, or None."""
        return None

    def unfitted_shadow(self, state, emitter) -> bool:
        return False

    def world(self, ctx: FrameContext, state, light_ubo) -> None:
        pass

    def emitter_surface(self, ctx: FrameContext, state, light_ubo) -> None:
        pass

    def emitter(self, ctx: FrameContext, state, emitter, light_ubo) -> None:
        pass

    def finish(self, ctx: FrameContext, state) -> dict | None:
        """Draw over the base; seconds per step, or None when it drew nothing."""
        return None

    def clear_caches(self) -> None:
        pass

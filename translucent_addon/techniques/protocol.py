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
"""
from __future__ import annotations

from ..gpu.frame_context import FrameContext


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

    def settings(self, values: dict):
        """This technique's frame settings from its ``scene_properties`` values (name -> value)."""
        return None

    def bake(self, inputs, stage: str):
        """Generator for one of its ``bake_stages``: yields (fraction, text); returns (arrays, meta) to store
        (``registry.run``)."""
        raise NotImplementedError(f"{self.id} has no bake")

    def auto_quality(self, view, target: float, curves: str):
        """Auto quality (``quality_auto.choose``): the resolutions that reach ``target`` at the least cost for
        ``view`` (``core.quality_model.ObjectView``), as a ``Choice``; None where it has none."""
        return None

    def prepare(self, ctx: FrameContext):
        return None

    def replaces_base(self, state) -> set[int]:
        return set()

    def base_lighting(self, state):
        """(materials block, near-field LUT) for the base pass, or None."""
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

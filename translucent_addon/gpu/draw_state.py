"""The one place a pass sets GPU state: the framebuffer it draws into, its blending, depth test and depth writes.

``draw_pass`` states all of them for the pass and restores what was set before on the way out, also when the pass
raises, so nothing a pass sets leaks into the next one (a pass that left depth writes off kept the next frame's
depth clear from clearing; one that left additive blending on doubled the next pass). ``tests/test_backend_rules.py``
refuses a state setter anywhere else, and the pipeline compares the state around each technique hook
(``Pipeline._guarded``). Blender-facing (``gpu``), used only inside a GPU context.
"""
from __future__ import annotations

import contextlib


def current() -> tuple[str, str, bool]:
    """(blend, depth test, depth write) as Blender's GPU state holds them now."""
    import gpu

    return gpu.state.blend_get(), gpu.state.depth_test_get(), bool(gpu.state.depth_mask_get())


def apply(blend: str, depth_test: str, depth_write: bool) -> None:
    """Set the three (``draw_pass`` and the pipeline's guard only)."""
    import gpu

    gpu.state.blend_set(blend)
    gpu.state.depth_test_set(depth_test)
    gpu.state.depth_mask_set(bool(depth_write))


@contextlib.contextmanager
def draw_pass(target=None, *, blend: str = "NONE", depth_test: str = "NONE", depth_write: bool = False):
    """Draw a pass into ``target`` (a GPUFrameBuffer bound for the pass; None: the one bound now) with ``blend``,
    ``depth_test`` and ``depth_write``; on exit the framebuffer and the three are what they were before."""
    before = current()
    binding = target.bind() if target is not None else contextlib.nullcontext()
    with binding:
        apply(blend, depth_test, depth_write)
        try:
            yield
        finally:
            apply(*before)


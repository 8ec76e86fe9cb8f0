"""The one owner of what the GPU layer keeps between frames: the shader table and its compiled programs, the
bakes' GPU data, the world's environment chain and each technique's own GPU caches.

Blender draws F12, every viewport and the overlay in one GPU context, so a texture or a program made for one
pipeline serves every other (a bake is uploaded once, not once per viewport): these live for the process, on
the ``GpuResources`` that ``current()`` returns, the one documented piece of mutable module state of this layer.
``clear`` drops every cache (the extension is disabled) and keeps the shader table, which the registry fills
at import. A test can make its own ``GpuResources`` and hand it to ``use`` for a block.
"""
from __future__ import annotations

import contextlib


class GpuResources:
    """The GPU layer's tables and caches."""

    def __init__(self, specs: dict | None = None):
        self.specs: dict = dict(specs or {})  # pass name -> shaders.ShaderSpec (the pipeline's and each technique's)
        self.programs: dict = {}  # pass name -> compiled GPUShader, built on first use
        self.bakes: dict = {}  # bake key -> a technique's GPU data built from it (bake_cache)
        self.damaged: dict = {}  # bake key -> why it was refused (not read again every frame)
        self.bake_users: dict = {}  # object (or object/stored bake) -> the bake key it draws (bake_cache)
        self.environments: dict = {}  # world key -> (EnvironmentChain, atlas texture)
        self.techniques: dict = {}  # cache name -> a technique's own cache (``cache``)

    def cache(self, name: str) -> dict:
        """A technique's own cache by name (``"relief/heights"``): made empty on first use."""
        return self.techniques.setdefault(name, {})

    def clear(self) -> None:
        """Every cache; the shader table stays."""
        for d in (self.programs, self.bakes, self.damaged, self.bake_users, self.environments, self.techniques):
            d.clear()


_current = GpuResources()  # the process's (``use`` swaps it for a block)


def current() -> GpuResources:
    return _current


@contextlib.contextmanager
def use(resources: GpuResources):
    """Draw with ``resources`` for a block (tests: two side by side), then the previous ones again."""
    global _current
    previous, _current = _current, resources
    try:
        yield resources
    finally:
        _current = previous

"""GPU data of bakes by key, object name '#' inputs hash (gpu/bake_cache.py): forgetting one object's bake leaves
the others', also where a name holds '#'. Pure: the GPU data are stood in for."""
from __future__ import annotations

import types

from translucent_addon.gpu import bake_cache, resources


def test_forgetting_an_object_s_bake_leaves_objects_whose_names_share_its_prefix():
    with resources.use(resources.GpuResources()) as held:  # its own, empty caches
        for name in ("Leaf", "Leaf#2", "Leaf#2#b"):
            handle = types.SimpleNamespace(key=f"{name}#0123abcd", load=lambda: {})
            bake_cache.get(handle, lambda arrays, name=name: name)
        bake_cache.forget("Leaf#2")
        assert sorted(held.bakes) == ["Leaf#0123abcd", "Leaf#2#b#0123abcd"]
        # A new bake of an object replaces its previous one only.
        bake_cache.get(types.SimpleNamespace(key="Leaf#ffff0000", load=lambda: {}), lambda arrays: "new")
        assert sorted(held.bakes) == ["Leaf#2#b#0123abcd", "Leaf#ffff0000"]
    assert "Leaf#ffff0000" not in resources.current().bakes

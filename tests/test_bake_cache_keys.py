"""GPU data of bakes by content (gpu/bake_cache.py): objects drawing one bake (linked duplicates, instances) share one
entry; an object drawing a new bake leaves its old one, dropped when no object draws it; forgetting one object
leaves the others', also where a name holds '#' or '/'. Pure: the GPU data are stood in for."""
from __future__ import annotations

import types

from translucent_addon.gpu import bake_cache, resources


def _handle(key, owner, loads):
    return types.SimpleNamespace(key=key, owner=owner, load=lambda: loads.append(key) or {})


def test_objects_drawing_one_bake_share_one_entry_built_once():
    with resources.use(resources.GpuResources()) as held:
        loads, built = [], []
        for name in ("Grape", "Grape.001", "Grape.002"):
            handle = _handle("TEXTURE_SPACE#d1@f.npz", name, loads)
            res = bake_cache.get(handle, lambda arrays: built.append(1) or "gpu")
            assert res == "gpu"
        assert loads == ["TEXTURE_SPACE#d1@f.npz"] and len(built) == 1 and list(held.bakes) == loads
        # One of them re-baked: the old entry stays while the others draw it, and goes with the last of them.
        bake_cache.get(_handle("TEXTURE_SPACE#d2@g.npz", "Grape", loads), lambda arrays: "new")
        assert sorted(held.bakes) == ["TEXTURE_SPACE#d1@f.npz", "TEXTURE_SPACE#d2@g.npz"]
        for name in ("Grape.001", "Grape.002"):
            bake_cache.get(_handle("TEXTURE_SPACE#d2@g.npz", name, loads), lambda arrays: "never")
        assert list(held.bakes) == ["TEXTURE_SPACE#d2@g.npz"] and held.bakes["TEXTURE_SPACE#d2@g.npz"] == "new"
    assert "TEXTURE_SPACE#d2@g.npz" not in resources.current().bakes


def test_forgetting_an_object_s_bake_leaves_objects_whose_names_share_its_prefix():
    with resources.use(resources.GpuResources()) as held:  # its own, empty caches
        loads = []
        for name in ("Leaf", "Leaf#2", "Leaf#2#b", "Leaf#2/grass"):
            bake_cache.get(_handle(f"key of {name}", name, loads), lambda arrays, name=name: name)
        bake_cache.forget("Leaf#2")  # its stored bakes ("Leaf#2/grass") go with it
        assert sorted(held.bakes) == ["key of Leaf", "key of Leaf#2#b"]
        held.damaged["key of Leaf"] = "its file is missing"
        bake_cache.forget("Leaf")  # a new bake is read again, not refused
        assert sorted(held.bakes) == ["key of Leaf#2#b"] and not held.damaged


def test_a_frame_numbers_the_instances_of_one_bake_and_tells_variants_apart():
    """``Active.slot`` numbers the instances drawing one entry (each keeps its own light maps); a technique whose
    data follow the mesh (``variant``) gets one entry per distinct variant in the frame."""
    def mesh(name, key, pose):
        return types.SimpleNamespace(name=name, method="M", medium="m", key=key, pose=pose,
                                     bake=types.SimpleNamespace(key="M#d@f", owner=name, load=lambda: {}))

    with resources.use(resources.GpuResources()) as held:
        frame = types.SimpleNamespace(warnings=[], meshes=[mesh("A", "k", 0), mesh("B", "k", 0), mesh("C", "k2", 1),
                                                           mesh("D", "k", 0)])
        plain = bake_cache.prepare(frame, "M", lambda arrays, m: object(), lambda res, m: True)
        assert [a.slot for a in plain] == [0, 1, 2, 3] and len({id(a.resources) for a in plain}) == 1
        held.bakes.clear()
        posed = bake_cache.prepare(frame, "M", lambda arrays, m: object(), lambda res, m: True,
                                   variant=lambda m: m.pose)
        assert [a.slot for a in posed] == [0, 1, 0, 2] and sorted(held.bakes) == ["M#d@f", "M#d@f|1"]
        assert posed[0].resources is posed[1].resources is posed[3].resources is not posed[2].resources

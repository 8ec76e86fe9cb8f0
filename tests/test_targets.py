"""Render targets kept across frames (gpu/targets.py): the last SIZES_KEPT sizes of a name, not every size a
viewport was dragged through. Pure: the GPU objects are stood in for."""
from __future__ import annotations

import types

from translucent_addon.gpu import targets


def test_a_named_target_keeps_its_last_sizes_only(monkeypatch):
    made = []
    monkeypatch.setattr(targets, "new_target", lambda size, depth, attachments: made.append(size) or (size,))
    pipeline = types.SimpleNamespace(targets={("screen_quad", "x"): "quad"})
    sizes = [(100 + k, 80) for k in range(6)]
    for size in sizes:
        assert targets.cached_target(pipeline, "gbuffer", size, True, 2) == (size,)
    kept = sorted(k[1] for k in pipeline.targets if k[0] == "gbuffer")
    assert kept == sizes[-targets.SIZES_KEPT:] and pipeline.targets[("screen_quad", "x")] == "quad"
    # A size in use is found again, not made again, and counts as used last.
    targets.cached_target(pipeline, "gbuffer", sizes[2], True, 2)
    targets.cached_target(pipeline, "gbuffer", (50, 50), True, 2)
    assert made == [*sizes, (50, 50)]
    assert sorted(k[1] for k in pipeline.targets if k[0] == "gbuffer") == sorted([sizes[2], sizes[4], sizes[5],
                                                                                  (50, 50)])
    targets.cached_target(pipeline, "scatter", (100, 80))  # another name leaves these alone
    assert sum(k[0] == "gbuffer" for k in pipeline.targets) == targets.SIZES_KEPT

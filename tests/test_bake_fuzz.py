"""Seeded fuzz of the bake reader (issue 37, point 5): random damage to every kind of stored array never
crashes Blender, hangs it or draws non-finite pixels; each case ends drawn or refused with a message naming
the object. In a child Blender (``fuzz_bakes.py``): a crash there is this test's failure, not pytest's end."""
from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

pytest.importorskip("bpy")

HERE = Path(__file__).resolve().parent
SEED, CASES_PER_METHOD = 37, 70


def test_random_damage_to_stored_bakes_is_drawn_or_refused_never_a_crash():
    try:
        proc = subprocess.run([sys.executable, str(HERE / "fuzz_bakes.py"), str(HERE.parent / "scripts"), str(SEED),
                               str(CASES_PER_METHOD)], capture_output=True, text=True, timeout=900)
    except subprocess.TimeoutExpired as err:
        last = [line for line in (err.stdout or b"").decode().splitlines() if line.startswith("{")][-1:]
        pytest.fail(f"the fuzz hung; the last case started: {last}")
    lines = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    started = [d for d in lines if "case" in d and "result" not in d]
    ended = [d for d in lines if "result" in d]
    assert proc.returncode == 0 and lines and lines[-1] == {"done": True}, (
        f"exit code {proc.returncode}; the case it died in: {started[len(ended):][:1]}\n{proc.stderr[-3000:]}")
    assert len(ended) == 3 * CASES_PER_METHOD
    outcome = Counter((d["method"], d["result"]) for d in ended)
    print("fuzz outcomes:", dict(outcome))
    for d in ended:
        assert d["result"] in ("drawn", "refused"), d
        if d["result"] == "refused":  # one line naming the object and why
            assert f"lost 1 object(s): '{d['method']}': " in d["message"], d
    for method in ("TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE"):  # the checks were reached, not only the hash
        refused = [d for d in ended if d["method"] == method and d["result"] == "refused"]
        assert any("hash rewritten" in d["damage"] and "bake is damaged: its array" in d["message"]
                   for d in refused), method
        assert outcome[(method, "drawn")] > 0, method

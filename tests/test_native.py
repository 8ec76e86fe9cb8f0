"""Compiled bake steps run in a child process (``core/native.py``, issue 37): a crash, a hang or an exception
there ends in one-line ``NativeStepError``, Esc (closing the generator) stops the child, and a real xatlas and
fTetWild run give what they give in-process. Pure: no Blender needed."""
from __future__ import annotations

import os
import time

import numpy as np
import pytest
from native_targets import crash, hang, refuse, scaled

from translucent_addon.core import native
from translucent_addon.techniques.quadgraph import tetra
from translucent_addon.techniques.texture_space import atlas


def drain(job):
    """Step a generator to its end; (its steps, its value)."""
    steps = []
    try:
        while True:
            steps.append(next(job))
    except StopIteration as done:
        return steps, done.value


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except OSError:
        return False
    return True


def test_arrays_and_numbers_come_back_as_returned():
    values = np.arange(12, dtype=np.float32).reshape(3, 4)
    _, (array, size, factor) = drain(native.run(scaled, {"values": values}, {"factor": 2.5}, what="test", timeout=60))
    np.testing.assert_array_equal(array, values * 2.5)
    assert array.dtype == np.float32 and (size, factor) == (12, 2.5)
    assert isinstance(size, int) and isinstance(factor, float)


@pytest.mark.skipif(os.name == "nt", reason="a crash reads as an exit code on Windows, not a signal")
def test_a_crash_in_the_child_is_a_one_line_error():
    with pytest.raises(native.NativeStepError, match=r"^xatlas crashed \(SIGSEGV\) on this mesh; nothing"):
        drain(native.run(crash, {}, {}, what="xatlas", timeout=60))


def test_a_refusal_in_the_child_keeps_its_words_and_a_failure_says_where():
    with pytest.raises(native.NativeStepError, match=r"^5 values are not a surface$"):
        drain(native.run(refuse, {"values": np.zeros(5)}, {}, what="fTetWild", timeout=60))
    with pytest.raises(native.NativeStepError, match=r"^fTetWild failed: TypeError: .*unexpected keyword"):
        drain(native.run(refuse, {"values": np.zeros(5)}, {"extra": 1}, what="fTetWild", timeout=60))


def test_a_hang_is_stopped_at_its_time_limit_with_progress_meanwhile(tmp_path):
    pid_file = tmp_path / "pid"
    t0 = time.perf_counter()
    job = native.run(hang, {}, {"pid_file": str(pid_file)}, what="xatlas", timeout=2.0, fraction=0.3, text="atlas")
    steps = []
    with pytest.raises(native.NativeStepError, match=r"^xatlas did not finish in 2 s and was stopped"):
        while True:
            steps.append(next(job))
    assert time.perf_counter() - t0 < 10.0
    assert steps and all(f == 0.3 and t.startswith("atlas (") for f, t in steps)
    assert not alive(int(pid_file.read_text())), "the child was left running"


def test_closing_the_generator_stops_the_child(tmp_path):
    """What Esc does in the bake's modal operator."""
    pid_file = tmp_path / "pid"
    job = native.run(hang, {}, {"pid_file": str(pid_file)}, what="fTetWild", timeout=600)
    for _ in range(400):  # until the child has started and said who it is
        next(job)
        if pid_file.exists() and pid_file.read_text():
            break
    pid = int(pid_file.read_text())
    assert alive(pid)
    job.close()
    assert not alive(pid), "Esc left the child running"


def test_xatlas_in_the_child_equals_xatlas_here():
    v = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]], float)
    t = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    _, charts = drain(native.run(atlas.parametrize, {"vertices_mm": v, "triangles": t}, {"resolution": 32},
                                 what="xatlas", timeout=60))
    here = atlas.parametrize(v, t, 32)
    np.testing.assert_array_equal(charts[0], here[0])
    np.testing.assert_array_equal(charts[1], here[1])
    assert charts[2:] == here[2:]


def test_ftetwild_in_the_child_fills_the_volume():
    pytest.importorskip("pytetwild")
    v = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]], float)
    t = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    _, (points, tets) = drain(native.run(tetra.tetrahedralize, {"vertices_mm": v, "triangles": t},
                                         {"edge_fraction": 0.2}, what="fTetWild", timeout=120))
    assert tets.shape[1] == 4 and len(tets) > 0
    # fTetWild meshes the tetrahedron's volume (1000/6 mm^3) to within its envelope.
    assert tetra.signed_volumes(points, tets).sum() == pytest.approx(1000.0 / 6.0, rel=0.02)

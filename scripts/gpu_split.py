"""Split a frame's wall time into the CPU work outside GPU calls and the time spent inside them.

Blender's ``gpu`` module offers no timer queries, so a profile hook times every call into a C function of
``gpu`` / ``gpu_extras`` (draws, dispatches, uploads, read-backs): on a real GPU those return once the
driver has taken the commands, on llvmpipe once the software rasteriser has drawn them; the frame ends with
a read-back (``render_offscreen``), so the sum is the finished pipeline's time. The rest of the wall time is
the Python and NumPy work per frame that no GPU can shorten. The hook's own overhead falls on the outside
share, so that figure is an upper bound.
"""
from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable

GPU_MODULES = ("gpu", "gpu_extras", "_gpu")


def _is_gpu(func) -> bool:
    """A C function of the ``gpu`` modules (``gpu.state.*``) or a method of one of their types (``GPUBatch.draw``:
    Blender registers them in ``builtins``, named GPU*)."""
    if isinstance(func, type):  # a constructor: GPUTexture(data=...) uploads, GPUOffScreen allocates
        return func.__name__.startswith("GPU")
    objclass = getattr(func, "__objclass__", None)  # an unbound method: what sys.monitoring reports
    if objclass is not None:
        return objclass.__name__.startswith("GPU")
    owner = getattr(func, "__self__", None)
    if isinstance(owner, type(sys)):
        return owner.__name__.split(".")[0] in GPU_MODULES
    return owner is not None and type(owner).__name__.startswith("GPU")


def split(run: Callable[[], object]) -> dict[str, float]:
    """Run ``run()`` once, timing its GPU calls: {'wall', 'gpu_calls', 'outside'} in seconds.

    Python 3.12+ (Blender 5.x): ``sys.monitoring``, whose call sites that are not GPU calls stop reporting
    after their first call, so the hook costs almost nothing per frame. Older Pythons: ``sys.setprofile``,
    whose overhead on every call falls on the outside share (an upper bound there)."""
    timer = _Timer()
    if hasattr(sys, "monitoring"):
        return _monitored(run, timer)
    return _profiled(run, timer)


class _Timer:
    def __init__(self):
        self.inside = 0.0
        self.calls = 0
        self.depth = 0
        self.started = 0.0

    def enter(self) -> None:
        self.calls += 1
        if self.depth == 0:
            self.started = time.perf_counter()
        self.depth += 1

    def leave(self) -> None:
        if self.depth:
            self.depth -= 1
            if self.depth == 0:
                self.inside += time.perf_counter() - self.started


def _result(wall: float, timer: _Timer) -> dict[str, float]:
    return {"wall": wall, "gpu_calls": timer.inside, "outside": wall - timer.inside, "calls": timer.calls}


def _monitored(run, timer: _Timer) -> dict[str, float]:
    mon = sys.monitoring
    tool = mon.PROFILER_ID
    mon.use_tool_id(tool, "gpu_split")
    events = mon.events
    known: dict = {}  # callable -> is a GPU call (a dict lookup per event, not the attribute checks)
    seen = []

    def gpu_call(func) -> bool:
        try:
            return known[func]
        except (KeyError, TypeError):
            flag = _is_gpu(func)
            with contextlib.suppress(TypeError):  # unhashable callables are asked every time
                known[func] = flag
            if flag and not seen:
                seen.append(func)
            return flag

    def on_call(code, offset, func, arg0):
        if gpu_call(func):
            timer.enter()
            return None
        return mon.DISABLE  # this call site calls something else: stop reporting it

    def on_return(code, offset, func, arg0):
        if gpu_call(func):
            timer.leave()

    mon.register_callback(tool, events.CALL, on_call)
    mon.register_callback(tool, events.C_RETURN, on_return)
    mon.register_callback(tool, events.C_RAISE, on_return)
    mon.set_events(tool, events.CALL | events.C_RETURN | events.C_RAISE)
    t0 = time.perf_counter()
    try:
        run()
    finally:
        wall = time.perf_counter() - t0
        mon.set_events(tool, 0)
        for event in (events.CALL, events.C_RETURN, events.C_RAISE):
            mon.register_callback(tool, event, None)
        mon.free_tool_id(tool)
    result = _result(wall, timer)
    if seen and timer.calls:
        # The hook's own cost per GPU call (both callbacks, timed here on a dummy timer) fell on the outside share
        # in a frame of thousands of GPU calls (QUADGRAPH's relaxation: 3,100): taken out again.
        dummy, n = _Timer(), 2000
        t1 = time.perf_counter()
        for _ in range(n):
            if gpu_call(seen[0]):
                dummy.enter()
            if gpu_call(seen[0]):
                dummy.leave()
        per_call = (time.perf_counter() - t1) / n
        result["hook"] = per_call * timer.calls
        result["outside"] = max(result["outside"] - result["hook"], 0.0)
    # Bound methods of GPU objects (fb.read_color) are keys here: kept, they outlived Blender's GPU context and
    # crashed the interpreter's exit.
    known.clear()
    seen.clear()
    return result


def _profiled(run, timer: _Timer) -> dict[str, float]:
    def hook(frame, event, arg):
        if event == "c_call" and _is_gpu(arg):
            timer.enter()
        elif event in ("c_return", "c_exception") and _is_gpu(arg):
            timer.leave()

    t0 = time.perf_counter()
    sys.setprofile(hook)
    try:
        run()
    finally:
        sys.setprofile(None)
    return _result(time.perf_counter() - t0, timer)

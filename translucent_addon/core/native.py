"""Compiled bake steps (xatlas, fTetWild) in a child process: a crash or a hang there costs a message, not Blender.

Pure (subprocess, NumPy). xatlas spins for ever on coordinates of 1e30 and fTetWild crashed on a surface scaled
to zero (issue 37); inside Blender either takes the artist's unsaved work with it. ``run`` starts the step in
Blender's own Python (``sys.executable``, the same interpreter and site-packages, so the extension's wheels
load there too), passes arrays through a scratch folder and waits without blocking: it is a generator that
yields (fraction, text) while the child works, so the bake's modal operator keeps its progress bar and Esc
(closing the generator kills the child). A child that crashes, overruns its time or raises ends in
``NativeStepError`` with one line. Costs about 0.3 s a call (a Python start and NumPy's import).
"""
from __future__ import annotations

import inspect
import json
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Generator
from pathlib import Path

import numpy as np

WORKER = Path(__file__).with_name("native_worker.py")
PACKAGE_PARENT = Path(__file__).resolve().parents[2]  # the folder holding ``translucent_addon``
POLL_SECONDS = 0.05  # how long one step of the generator waits for the child


class NativeStepError(ValueError):
    """A compiled step crashed, ran past its time or failed; the message says which and why in one line."""


def time_limit(base_s: float, triangles: int, per_triangle_s: float) -> float:
    """A step's time limit: generous (a real mesh never meets it), but finite so that a batch bake cannot hang."""
    return float(base_s + per_triangle_s * max(int(triangles), 0))


def run(function: Callable, arrays: dict[str, np.ndarray], params: dict, *, what: str, timeout: float,
        fraction: float = 0.0, text: str = "") -> Generator[tuple[float, str], None, tuple]:
    """Call a module-level ``function`` in a child process with ``**arrays, **params``; yields (fraction, text
    with the seconds so far) while it runs; returns what it returned as a tuple (arrays, and 0-d arrays back as
    Python numbers). ``what`` names the step in messages ("xatlas", "fTetWild")."""
    module = _module_name(function)
    function = function.__name__
    with tempfile.TemporaryDirectory(prefix="translucent_native_") as scratch:
        job = Path(scratch)
        np.savez(job / "in.npz", **{k: np.asarray(v) for k, v in arrays.items()})
        (job / "request.json").write_text(json.dumps({
            "module": module, "function": function, "params": params,
            "sys_path": [str(PACKAGE_PARENT)] + [p for p in sys.path if p],
        }))
        with open(job / "log.txt", "wb") as log:
            # -I: no user site, no PYTHON* variables, no working folder on the path; the worker is given
            # this interpreter's path instead. Its working folder is the scratch one (fTetWild writes files).
            # Its standard input stays open while this process lives: the child ends itself when it closes
            # (Blender crashed or was killed), rather than meshing on for up to its time limit.
            child = subprocess.Popen([sys.executable, "-I", str(WORKER), str(job)], cwd=scratch,
                                     stdin=subprocess.PIPE, stdout=log, stderr=subprocess.STDOUT)
        t0 = time.perf_counter()
        try:
            while True:
                try:
                    code = child.wait(timeout=POLL_SECONDS)
                    break
                except subprocess.TimeoutExpired:
                    elapsed = time.perf_counter() - t0
                    if elapsed > timeout:
                        raise NativeStepError(f"{what} did not finish in {timeout:.0f} s and was stopped; the "
                                              "mesh is probably degenerate (check its scale and mm per unit)")
                    yield fraction, f"{text} ({elapsed:.0f} s)"
        finally:
            if child.poll() is None:  # stopped: Esc (the generator closed), the time limit, or an error here
                child.kill()
                child.wait()
            child.stdin.close()
        error = job / "error.json"
        if error.exists():  # the step raised: a refusal (ValueError) keeps its own words
            try:
                reason = json.loads(error.read_text())
                text = reason["text"] if reason["refusal"] else f"{what} {reason['text']}"
            except (ValueError, KeyError, TypeError):
                text = f"{what} failed and its reason cannot be read"
            raise NativeStepError(text)
        if code != 0:
            raise NativeStepError(f"{what} {_failure(code, job)}")
        with np.load(job / "out.npz") as out:
            values = [out[f"r{i}"] for i in range(len(out.files))]
        return tuple(v.item() if v.ndim == 0 else v for v in values)


def _module_name(function: Callable) -> str:
    """The function's module as the child imports it: a project module by its path below ``PACKAGE_PARENT``
    (inside Blender the package is ``bl_ext.<repository>.translucent``, which the child does not have)."""
    path = Path(inspect.getfile(function)).resolve()
    if PACKAGE_PARENT in path.parents:
        return ".".join(path.relative_to(PACKAGE_PARENT).with_suffix("").parts)
    return function.__module__


def _failure(code: int, job: Path) -> str:
    """How the child ended, in words: the signal that ended it, or its exit code and last line of output."""
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return f"crashed ({name}) on this mesh; nothing was changed"
    tail = (job / "log.txt").read_text(errors="replace").strip().splitlines()[-1:] if (job / "log.txt").exists() else []
    return f"stopped with exit code {code}{': ' + tail[0] if tail else ''}; nothing was changed"


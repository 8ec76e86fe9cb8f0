"""Functions the tests of ``core/native.py`` run in a child process: one that crashes, one that hangs, one
that raises and one that answers. Importable by name there (this folder is on the tests' ``sys.path``)."""
import ctypes
import os
import time
from pathlib import Path

import numpy as np


def crash() -> None:
    """A segmentation fault, as xatlas or fTetWild would have one."""
    ctypes.string_at(0)


def hang(pid_file: str) -> None:
    """Says who it is, then spins for ever (xatlas on coordinates of 1e30)."""
    Path(pid_file).write_text(str(os.getpid()))
    while True:
        time.sleep(0.01)


def refuse(values: np.ndarray) -> None:
    raise ValueError(f"{len(values)} values are not a surface")


def scaled(values: np.ndarray, factor: float) -> tuple:
    return values * factor, int(values.size), float(factor)

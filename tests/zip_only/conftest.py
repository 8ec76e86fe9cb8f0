"""The zip-only tests run in a venv that holds nothing but bpy and pytest (``make test-zip``): whatever the
extension needs beyond Blender's own Python and NumPy must come from the zip's wheels.

In any other environment they are skipped; with TRANSLUCENT_ZIP_ONLY=1 (set by ``make test-zip``) an
environment that holds one of the bundled libraries is an error, not a skip.
"""
from __future__ import annotations

import importlib.util
import os

import pytest

BUNDLED = ("scipy", "xatlas", "moderngl", "glcontext", "pytetwild", "wildmeshing", "matplotlib")


def _present() -> list[str]:
    return [name for name in BUNDLED if importlib.util.find_spec(name) is not None]


def pytest_collection_modifyitems(config, items):
    present = _present()
    if not present:
        return
    if os.environ.get("TRANSLUCENT_ZIP_ONLY") == "1":
        pytest.exit(f"the zip-only venv holds {present}: it must hold only bpy and pytest", returncode=3)
    skip = pytest.mark.skip(reason=f"this environment holds {present}; `make test-zip` runs these in a venv "
                                   "holding only bpy")
    for item in items:
        if "zip_only" in str(item.fspath):
            item.add_marker(skip)

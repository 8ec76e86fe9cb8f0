"""Test harness: pure tests need nothing; Blender tests install the built zip.

Runs in two forms:
* ``pytest tests`` with the bpy module (what ``make test`` and CI run);
* ``blender -b --factory-startup --python tests/run.py`` inside a Blender binary.

Blender tests install ``dist/translucent-*-linux_x64.zip`` (``make extension``) with
Blender's own extension installer into a temporary extensions repository, so nothing
leaks into the user's configuration, and every test starts from an empty scene.
"""
from __future__ import annotations

import atexit
import glob
import importlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # pure modules: ``import translucent_addon...``

if "bpy" not in sys.modules:
    # bpy as a module: point Blender's user folders at a temporary place before it starts (removed at exit).
    _USER = tempfile.mkdtemp(prefix="translucent-blender-user-")
    atexit.register(shutil.rmtree, _USER, True)
    for var in ("BLENDER_USER_CONFIG", "BLENDER_USER_SCRIPTS", "BLENDER_USER_DATAFILES", "BLENDER_USER_EXTENSIONS"):
        os.environ[var] = os.path.join(_USER, var.split("_")[-1].lower())

REPO_MODULE = "translucent_test_repo"


def built_zip() -> Path:
    plat = {"linux": "linux_x64", "win32": "windows_x64", "darwin": "macos_arm64"}.get(sys.platform, "linux_x64")
    zips = sorted(glob.glob(str(ROOT / "dist" / f"translucent-*-{plat}.zip")))
    if not zips:
        pytest.exit("no extension zip in dist/: run `make extension` first", returncode=2)
    return Path(zips[-1])


@pytest.fixture(scope="session")
def bpy_module():
    import bpy

    return bpy


@pytest.fixture(scope="session")
def installed(bpy_module):
    """Install the zip into a temporary repository and enable it; yields the package name."""
    bpy = bpy_module
    repo_dir = tempfile.mkdtemp(prefix="translucent-ext-repo-")
    repos = bpy.context.preferences.extensions.repos
    repo = repos.new(name="Translucent tests", module=REPO_MODULE, custom_directory=repo_dir)
    repo.use_custom_directory = True
    result = bpy.ops.extensions.package_install_files(
        filepath=str(built_zip()), repo=REPO_MODULE, enable_on_install=True
    )
    assert result == {"FINISHED"}, result
    package = f"bl_ext.{REPO_MODULE}.translucent"
    assert package in bpy.context.preferences.addons, "the extension did not enable"
    yield package
    if package in bpy.context.preferences.addons:
        bpy.ops.preferences.addon_disable(module=package)
    repos.remove(repo)
    shutil.rmtree(repo_dir, ignore_errors=True)  # the installed extension: 79 MB a session


@pytest.fixture
def tr(installed):
    """The installed extension package (its sub-modules as attributes)."""
    return importlib.import_module(installed)


@pytest.fixture
def scene(installed, bpy_module):
    """An empty scene, reset before every test (the extension stays enabled)."""
    bpy = bpy_module
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "TRANSLUCENT_RT"
    sc.render.resolution_percentage = 100
    yield sc
    # Every pass sets and restores its GPU state (gpu/draw_state.py): one a technique hook left changed fails the
    # test that drew it (the pipeline puts it back and records it).
    engine = sys.modules.get(f"{installed}.translucent_addon.blender.engine")
    pipeline = engine.final_pipeline() if engine is not None else None
    leaks = list(pipeline.state_leaks) if pipeline is not None else []
    if leaks:
        pipeline.state_leaks.clear()
        pytest.fail(f"GPU state left changed by a technique hook: {leaks}")


def ext_module(package, name: str):
    """A sub-module of the installed extension (package name or module object)."""
    base = package if isinstance(package, str) else package.__name__
    return importlib.import_module(f"{base}.{name}")

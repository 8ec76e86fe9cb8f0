"""Start Blender (the bpy module) with this checkout enabled as an extension, isolated.

Blender's user folders point at a temporary directory, so nothing touches ~/.config; the
checkout is linked into a temporary local extensions repository and enabled. Import this
before anything imports bpy.
"""
from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REPO_MODULE = "checkout_repo"
PACKAGE = f"bl_ext.{REPO_MODULE}.translucent"


def start() -> str:
    """Enable the extension from this checkout; returns its package name."""
    user = tempfile.mkdtemp(prefix="translucent-user-")
    atexit.register(shutil.rmtree, user, True)
    for var in ("BLENDER_USER_CONFIG", "BLENDER_USER_SCRIPTS", "BLENDER_USER_EXTENSIONS"):
        os.environ[var] = os.path.join(user, var.split("_")[-1].lower())
    import bpy

    repo_dir = Path(user) / "repo"
    repo_dir.mkdir()
    (repo_dir / "translucent").symlink_to(ROOT, target_is_directory=True)
    repo = bpy.context.preferences.extensions.repos.new(name="checkout", module=REPO_MODULE,
                                                        custom_directory=str(repo_dir))
    repo.use_custom_directory = True
    bpy.ops.preferences.addon_enable(module=PACKAGE)
    return PACKAGE

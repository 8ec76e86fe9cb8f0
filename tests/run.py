"""Run the test suite inside a Blender binary:

    blender -b --factory-startup --python tests/run.py [-- pytest arguments]

Blender's user folders are pointed at a temporary directory first (Blender is
started again with them set), so installing the extension under test never
touches your own configuration. pytest comes from Blender's Python if it has
it, else from this checkout's .venv (make venv).
"""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MARK = "TRANSLUCENT_TESTS_ISOLATED"


def _pytest_args():
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def main():
    import bpy

    if not os.environ.get(MARK):
        user = tempfile.mkdtemp(prefix="translucent-blender-user-")
        env = dict(os.environ, **{MARK: "1"})
        for var in ("BLENDER_USER_CONFIG", "BLENDER_USER_SCRIPTS", "BLENDER_USER_DATAFILES", "BLENDER_USER_EXTENSIONS"):
            env[var] = os.path.join(user, var.split("_")[-1].lower())
        cmd = [bpy.app.binary_path, "-b", "--factory-startup", "--python", __file__, "--", *_pytest_args()]
        sys.exit(subprocess.call(cmd, env=env))
    try:
        import pytest
    except ImportError:
        venv = sorted((ROOT / ".venv" / "lib").glob("python3*/site-packages"))
        sys.path.extend(str(p) for p in venv)  # appended: Blender's own NumPy stays first
        import pytest
    sys.exit(pytest.main([str(ROOT / "tests"), *_pytest_args()]))


main()

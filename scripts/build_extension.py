"""Download the bundled wheels and build the extension zips with Blender's own builder.

    python scripts/build_extension.py wheels   # fetch wheels for every platform
    python scripts/build_extension.py build    # per-platform zips into dist/

The builder is ``blender_ext.py`` from the bpy package (the same code as
``blender --command extension build``); ``--split-platforms`` gives one zip per
platform with only that platform's wheels.
"""
from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLATFORM_TAGS = {
    "linux-x64": ["manylinux2014_x86_64", "manylinux_2_17_x86_64", "manylinux1_x86_64"],
    "windows-x64": ["win_amd64"],
    "macos-arm64": ["macosx_11_0_arm64", "macosx_12_0_arm64"],  # scipy 1.14.1: 12.0
    # xatlas 0.0.11 has no 10.9 build for Intel macOS, only 10.14 (Blender 4.2 needs macOS 11.2+).
    "macos-x64": ["macosx_10_9_x86_64", "macosx_10_13_x86_64", "macosx_10_14_x86_64"],
}
PYTHON_VERSION = "3.11"  # Blender 4.2 to 5.0
# Requirements with no wheel for a platform: the extension works there without the method that needs
# it and says so (pytetwild 0.2.3, for QUADGRAPH, has Linux and Windows wheels only; 0.4 imports
# pyvista, which it does not declare).
PLATFORM_SKIP = {"macos-arm64": {"pytetwild"}, "macos-x64": {"pytetwild"}}


def requirements() -> list[str]:
    lines = (ROOT / "requirements-extension.txt").read_text().splitlines()
    return [ln.strip() for ln in lines if ln.strip() and not ln.startswith("#")]


def manifest_wheels() -> list[Path]:
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    return [ROOT / w for w in manifest.get("wheels", [])]


def download_wheels() -> None:
    out = ROOT / "wheels"
    out.mkdir(exist_ok=True)
    for platform, tags in PLATFORM_TAGS.items():
        cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary=:all:",
               "--python-version", PYTHON_VERSION, "--dest", str(out)]
        for tag in tags:
            cmd += ["--platform", tag]
        skip = PLATFORM_SKIP.get(platform, set())
        wanted = [r for r in requirements() if r.split("==")[0].lower() not in skip]
        subprocess.run(cmd + wanted, check=True)
        print(f"wheels for {platform}: ok")
    missing = [w.name for w in manifest_wheels() if not w.exists()]
    if missing:
        sys.exit(f"blender_manifest.toml lists wheels that pip did not fetch: {missing}")
    pinned = {re.split("==", r)[0].lower(): r.split("==")[1] for r in requirements()}
    for w in manifest_wheels():
        name, version = w.name.split("-")[:2]
        if pinned.get(name.lower()) != version:
            sys.exit(f"{w.name} does not match the pin in requirements-extension.txt")


def blender_ext() -> Path:
    import importlib.util

    # The bpy wheel carries the builder: site-packages/bpy/<version>/scripts/addons_core/...
    # (found without importing bpy, which would start Blender).
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        sys.exit("the bpy package is not installed: run `make venv`")
    base = Path(list(spec.submodule_search_locations)[0])
    found = sorted(base.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        sys.exit("blender_ext.py not found in the bpy package")
    return found[-1]


def build() -> None:
    missing = [w.name for w in manifest_wheels() if not w.exists()]
    if missing:
        sys.exit(f"missing wheels {missing}: run `make wheels` first")
    dist = ROOT / "dist"
    dist.mkdir(exist_ok=True)
    subprocess.run([sys.executable, str(blender_ext()), "build", "--source-dir", str(ROOT),
                    "--output-dir", str(dist), "--split-platforms"], check=True)


if __name__ == "__main__":
    {"wheels": download_wheels, "build": build}[sys.argv[1]]()

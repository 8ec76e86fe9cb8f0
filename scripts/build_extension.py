"""Download the bundled wheels and build the extension zips with Blender's own builder.

    python scripts/build_extension.py wheels   # fetch wheels for every platform and Python; list them in the manifest
    python scripts/build_extension.py build    # per-platform zips into dist/ (fetches missing wheels first)
    python scripts/build_extension.py sizes    # what takes the space in each zip (the README's table)

One zip per platform holds the wheels of every Blender Python it serves side by side: cp313 for
Blender 5.2 LTS and 5.3, cp311 for 4.5 LTS. Blender installs only the wheels of its own Python
(``_extensions_wheel_filter_for_this_system`` in its ``bl_pkg``). The builder is ``blender_ext.py``
from the bpy package (the same code as ``blender --command extension build``); ``--split-platforms``
gives one zip per platform with only that platform's wheels.
"""
from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "blender_manifest.toml"
WHEELS = ROOT / "wheels"


@dataclasses.dataclass(frozen=True)
class Target:
    """One platform of the manifest: the pip platform tags it accepts and the Blender Pythons it serves."""

    tags: tuple[str, ...]
    pythons: tuple[str, ...]


TARGETS = {
    "linux-x64": Target(("manylinux2014_x86_64", "manylinux_2_17_x86_64", "manylinux1_x86_64"), ("3.11", "3.13")),
    "windows-x64": Target(("win_amd64",), ("3.11", "3.13")),
    # Listed oldest first: pip takes scipy's macOS 12 (OpenBLAS) build; wildmeshing has only macOS 14.
    "macos-arm64": Target(("macosx_11_0_arm64", "macosx_12_0_arm64", "macosx_13_0_arm64", "macosx_14_0_arm64"),
                          ("3.11", "3.13")),
    # Blender 5.0 dropped Intel Macs: this zip serves Blender 4.5 LTS (Python 3.11) only.
    "macos-x64": Target(("macosx_10_9_x86_64", "macosx_10_13_x86_64", "macosx_10_14_x86_64", "macosx_10_15_x86_64",
                         "macosx_11_0_x86_64", "macosx_12_0_x86_64", "macosx_13_0_x86_64"), ("3.11",)),
}
# The tetrahedral mesher of QUADGRAPH: fTetWild through pytetwild (Linux, Windows) or through wildmeshing, its
# authors' own binding (macOS, where pytetwild 0.2.3 has no wheel and 0.4 imports the undeclared pyvista).
ONLY_ON = {
    "pytetwild": {"linux-x64", "windows-x64"},
    "wildmeshing": {"macos-arm64", "macos-x64"},
}
WHEELS_BLOCK = re.compile(r"^wheels = \[\n.*?^\]\n", re.S | re.M)


def requirements() -> list[str]:
    lines = (ROOT / "requirements-extension.txt").read_text().splitlines()
    return [ln.split("#")[0].strip() for ln in lines if ln.split("#")[0].strip()]


def requirement_name(req: str) -> str:
    return req.split("==")[0].strip().lower()


def manifest_wheels() -> list[Path]:
    manifest = tomllib.loads(MANIFEST.read_text())
    return [ROOT / w for w in manifest.get("wheels", [])]


def wanted_for(platform: str) -> list[str]:
    return [r for r in requirements() if platform in ONLY_ON.get(requirement_name(r), {platform})]


def download_wheels() -> None:
    """Fetch every pinned wheel per platform and Python into wheels/ (stale ones removed) and write the
    manifest's ``wheels`` list from what was fetched."""
    with tempfile.TemporaryDirectory(prefix="translucent-wheels-") as scratch:
        fetched = Path(scratch)
        for platform, target in TARGETS.items():
            for python in target.pythons:
                cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary=:all:",
                       "--python-version", python, "--dest", str(fetched)]
                for tag in target.tags:
                    cmd += ["--platform", tag]
                subprocess.run(cmd + wanted_for(platform), check=True)
                print(f"wheels for {platform}, Python {python}: ok")
        WHEELS.mkdir(exist_ok=True)
        names = sorted(p.name for p in fetched.glob("*.whl"))
        for old in WHEELS.glob("*.whl"):
            if old.name not in names:
                old.unlink()
        for name in names:
            if not (WHEELS / name).exists():
                shutil.copy2(fetched / name, WHEELS / name)
    check_pins(names)
    block = "wheels = [\n" + "".join(f'  "./wheels/{n}",\n' for n in names) + "]\n"
    text = MANIFEST.read_text()
    if not WHEELS_BLOCK.search(text):
        sys.exit("blender_manifest.toml has no `wheels = [...]` block to rewrite")
    MANIFEST.write_text(WHEELS_BLOCK.sub(block, text))
    print(f"{len(names)} wheels listed in {MANIFEST.name}")


def check_pins(names) -> None:
    pinned = {requirement_name(r): r.split("==")[1].strip() for r in requirements()}
    for name in names:
        dist, version = name.split("-")[:2]
        if pinned.get(dist.lower()) != version:
            sys.exit(f"{name} does not match a pin in requirements-extension.txt")


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
    if not all(w.exists() for w in manifest_wheels()):
        download_wheels()  # a fresh clone: the wheels folder is not in git
    check_pins([w.name for w in manifest_wheels()])
    dist = ROOT / "dist"
    dist.mkdir(exist_ok=True)
    for old in dist.glob("translucent-*.zip"):
        old.unlink()
    subprocess.run([sys.executable, str(blender_ext()), "build", "--source-dir", str(ROOT),
                    "--output-dir", str(dist), "--split-platforms"], check=True)


def sizes() -> None:
    """Each zip's size and its largest parts: the README's table."""
    for path in sorted((ROOT / "dist").glob("translucent-*.zip")):
        with zipfile.ZipFile(path) as z:
            parts: dict[str, int] = {}
            for info in z.infolist():
                key = info.filename.split("/")[1] if info.filename.startswith("wheels/") else "extension code"
                if key != "extension code":
                    key = key.split("-")[0] + " (" + key.split("-")[2] + ")"
                parts[key] = parts.get(key, 0) + info.compress_size
        print(f"{path.name}: {path.stat().st_size / 2**20:.1f} MiB")
        for key, size in sorted(parts.items(), key=lambda kv: -kv[1]):
            print(f"    {key:32s} {size / 2**20:6.1f} MiB")


if __name__ == "__main__":
    {"wheels": download_wheels, "build": build, "sizes": sizes}[sys.argv[1]]()

"""The zips' wheels: every platform the manifest lists gets, for every Blender Python it serves, a wheel of
each runtime dependency, the OpenGL backend grass acquisition uses there and an fTetWild binding for
QUADGRAPH. Pure: reads wheels/, the manifest and dist/ (``make extension``); no Blender needed."""
from __future__ import annotations

import re
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import build_extension  # noqa: E402

from translucent_addon.gpu import gl_context  # noqa: E402
from translucent_addon.techniques.quadgraph import tetra  # noqa: E402

MANIFEST = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
# Manifest platform -> sys.platform of Blender there.
SYS_PLATFORM = {"linux-x64": "linux", "windows-x64": "win32", "macos-arm64": "darwin", "macos-x64": "darwin"}
RUNTIME = ("scipy", "xatlas", "moderngl", "glcontext")


def wheel_platform(tag: str) -> str:
    if tag.startswith("manylinux") and tag.endswith("x86_64"):
        return "linux-x64"
    if tag == "win_amd64":
        return "windows-x64"
    if tag.startswith("macosx_"):
        return "macos-arm64" if tag.endswith("arm64") else "macos-x64"
    raise AssertionError(f"a wheel for no listed platform: {tag}")


def serves(python_tag: str, abi_tag: str, python: str) -> bool:
    """Would Blender with this Python install the wheel (its rule: the same cpXY, or abi3 from cpXY on)?"""
    want = tuple(int(x) for x in python.split("."))
    have = (int(python_tag[2]), int(python_tag[3:]))
    return have == want or (abi_tag == "abi3" and want >= have)


def listed_wheels() -> list[dict]:
    out = []
    for path in MANIFEST["wheels"]:
        name = Path(path).name
        dist, version, python_tag, abi, platform_tag = name[:-4].split("-")
        out.append({"path": ROOT / path, "name": name, "dist": dist.lower(), "python": python_tag, "abi": abi,
                    "platform": wheel_platform(platform_tag.split(".")[0])})
    return out


def wheels_for(platform: str, python: str) -> dict[str, dict]:
    return {w["dist"]: w for w in listed_wheels()
            if w["platform"] == platform and serves(w["python"], w["abi"], python)}


def test_the_manifest_serves_the_tested_blenders_on_every_listed_platform():
    assert MANIFEST["blender_version_min"] == "4.5.0"
    assert sorted(MANIFEST["platforms"]) == sorted(build_extension.TARGETS)
    assert build_extension.TARGETS["linux-x64"].pythons == ("3.11", "3.13")  # Blender 4.5 LTS; 5.2 LTS, 5.3
    assert build_extension.TARGETS["macos-x64"].pythons == ("3.11",)  # Blender 5.0 dropped Intel Macs


@pytest.mark.parametrize("platform", sorted(build_extension.TARGETS))
def test_each_platform_and_python_has_every_runtime_dependency_and_a_mesher(platform):
    for python in build_extension.TARGETS[platform].pythons:
        have = wheels_for(platform, python)
        for dist in RUNTIME:
            assert dist in have, f"{platform}, Python {python}: no {dist} wheel"
        meshers = [b for b in tetra.BINDINGS if b in have]
        assert len(meshers) == 1, f"{platform}, Python {python}: fTetWild bindings {meshers}"
        assert "matplotlib" not in have  # the report draws its own charts (compare.raster_chart)


@pytest.mark.parametrize("platform", sorted(build_extension.TARGETS))
def test_each_platform_wheel_carries_the_backend_and_binding_it_will_import(platform):
    """What Blender on that platform will import, looked up inside the wheels (they cannot be imported on
    this machine): glcontext's module for ``gl_context.standalone_backend`` there, the mesher's compiled
    module, moderngl's and SciPy's compiled cores."""
    suffix = {"linux-x64": ".so", "windows-x64": ".pyd", "macos-arm64": ".so", "macos-x64": ".so"}[platform]
    backend = gl_context.standalone_backend(SYS_PLATFORM[platform]) or gl_context.STANDALONE_BACKENDS[
        SYS_PLATFORM[platform]]
    needed = {"glcontext": rf"^glcontext/{backend}\.[^/]*{re.escape(suffix)}$",
              "moderngl": rf"^moderngl/mgl\.[^/]*{re.escape(suffix)}$|^_moderngl[^/]*{re.escape(suffix)}$",
              "scipy": rf"^scipy/sparse/_sparsetools\.[^/]*{re.escape(suffix)}$",
              "pytetwild": rf"^pytetwild/[^/]*{re.escape(suffix)}$",
              "wildmeshing": rf"^wildmeshing/[^/]*{re.escape(suffix)}$|^wildmeshing[^/]*{re.escape(suffix)}$"}
    for python in build_extension.TARGETS[platform].pythons:
        for dist, wheel in wheels_for(platform, python).items():
            if dist not in needed:
                continue
            assert wheel["path"].exists(), f"{wheel['name']}: run `make wheels`"
            names = zipfile.ZipFile(wheel["path"]).namelist()
            assert any(re.search(needed[dist], n) for n in names), f"{wheel['name']} has no {needed[dist]}"


def test_the_wheels_match_the_pins_and_no_wheel_serves_nobody():
    pins = {build_extension.requirement_name(r): r.split("==")[1] for r in build_extension.requirements()}
    for w in listed_wheels():
        assert pins[w["dist"]] == w["name"].split("-")[1], w["name"]
        target = build_extension.TARGETS[w["platform"]]
        assert any(serves(w["python"], w["abi"], p) for p in target.pythons), f"{w['name']} serves no Blender"
    # wildmeshing only where pytetwild has no wheel: one mesher per platform.
    assert build_extension.ONLY_ON["pytetwild"].isdisjoint(build_extension.ONLY_ON["wildmeshing"])


def test_each_zip_holds_its_platform_wheels_and_no_development_files():
    zips = sorted((ROOT / "dist").glob("translucent-*.zip"))
    if not zips:
        pytest.skip("no zips in dist/: `make extension` builds them")
    assert len(zips) == len(build_extension.TARGETS)
    for path in zips:
        platform = re.search(r"-(linux_x64|windows_x64|macos_arm64|macos_x64)\.zip$", path.name).group(1)
        platform = platform.replace("_", "-")
        names = zipfile.ZipFile(path).namelist()
        wheels = sorted(n.split("/")[-1] for n in names if n.startswith("wheels/"))
        assert wheels == sorted(w["name"] for w in listed_wheels() if w["platform"] == platform), path.name
        for dev in ("pytest.ini", "pyproject.toml", "Makefile", "requirements.txt"):
            assert dev not in names, f"{path.name} ships {dev}"
        assert not [n for n in names if n.startswith(("tests/", "scripts/", "bench/", "docs/", ".venv"))]


def test_each_zip_carries_the_licence_and_passes_blenders_own_validation():
    """The manifest says GPL-3.0-or-later, but no licence text was in the repository or the zip. Every zip now
    holds the GPL's text as LICENSE, and Blender's own extension validator (``blender --command extension
    validate``; here the copy of ``blender_ext.py`` the bpy package carries) accepts it."""
    import subprocess

    zips = sorted((ROOT / "dist").glob("translucent-*.zip"))
    if not zips:
        pytest.skip("no zips in dist/: `make extension` builds them")
    licence = (ROOT / "LICENSE").read_text()
    assert licence.lstrip().startswith("GNU GENERAL PUBLIC LICENSE") and "Version 3, 29 June 2007" in licence
    assert "SPDX:GPL-3.0-or-later" in tomllib.loads((ROOT / "blender_manifest.toml").read_text())["license"]
    for path in zips:
        with zipfile.ZipFile(path) as z:
            assert z.read("LICENSE").decode() == licence, path.name
        proc = subprocess.run([sys.executable, str(build_extension.blender_ext()), "validate", str(path)],
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0 and "Success" in proc.stdout, (path.name, proc.stdout, proc.stderr)


def test_the_development_suite_runs_on_numpy_2():
    """The pure suite runs on Blender 5.2's NumPy (2.x) in `make test`; NumPy 1.26 (Blender 4.5) is run by
    the zip-only tests. Names NumPy 2 removed are kept out by ruff's NPY201 (pyproject.toml)."""
    import numpy as np

    assert int(np.__version__.split(".")[0]) >= 2, np.__version__
    assert "NPY" in tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]["lint"]["select"]

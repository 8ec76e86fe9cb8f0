"""Pack the shared test meshes into the compact NPZ files the extension ships.

Usage: python scripts/pack_meshes.py ../shared/data/meshes
Writes translucent_addon/data/meshes/<name>.npz (vertices float32, triangles int32), with the holes of a
scan closed (``geometry.mesh_repair``: the bunny's base), so that every bundled mesh bounds a volume.
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from translucent_addon.core.geometry.mesh_io import load_obj, load_obj_uv, save_npz  # noqa: E402
from translucent_addon.core.geometry.mesh_repair import boundary_loops, close_holes  # noqa: E402

src = Path(sys.argv[1] if len(sys.argv) > 1 else ROOT.parent / "shared" / "data" / "meshes")
dst = ROOT / "translucent_addon" / "data" / "meshes"
dst.mkdir(parents=True, exist_ok=True)
for obj in sorted(src.glob("*.obj")):
    v, t = load_obj(obj)
    uv = load_obj_uv(obj)
    name = obj.stem.replace("stanford-", "")
    try:
        loops = boundary_loops(t)
        n = len(t)
        v, t = close_holes(v, t)
        closed = f", {len(loops)} holes closed" if loops else ""
        if uv is not None and len(t) > n:  # the closing faces have no UVs: those of their first corner's face
            uv = None
            closed += " (its UVs dropped)"
    except ValueError as err:
        closed = f", left open ({err})"
    save_npz(dst / f"{name}.npz", v, t, uv)
    print(f"{obj.name}: {len(v)} vertices, {len(t)} triangles{closed}{', UVs' if uv is not None else ''} -> "
          f"{name}.npz")

"""Reading a bake's arrays: OpenEXR image files (core/bake_exr.py) against the ``.npz`` files they replaced (issue 58:
"reading as fast as today's, measured"). Pure NumPy, no Blender.

    python scripts/bench_bake_files.py [MB]

Arrays shaped as a TEXTURE_SPACE bake's (float32 kernels and maps, int32 indices, float16 tables kept two to an
int32), ``MB`` in all (default 125, the demo bunny's bake). Each read is timed warm (the file in the page cache, as
on a second F12), median of 7, the file read and its arrays made usable; a packed image is decoded from bytes held
in memory. Writes ``bench/results/bake_files/read.md``.
"""
from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from translucent_addon.core import bake_exr  # noqa: E402


def _arrays(mb: float) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(58)
    words = int(mb * 2**20 / 4)
    shares = {"kernels": 0.55, "factors": 0.25, "blend": 0.1, "cluster_index": 0.05, "half_tables": 0.05}
    out = {}
    for name, share in shares.items():
        n = int(words * share)
        if name == "cluster_index":
            out[name] = rng.integers(0, 1 << 20, n, dtype=np.int32)
        elif name == "half_tables":
            out[name] = rng.random(2 * n, dtype=np.float32).astype(np.float16).view(np.int32)
        else:
            out[name] = rng.random(n, dtype=np.float32)
    return out


def _median_seconds(read, repeats: int = 7) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        arrays = read()
        _ = sum(int(a.size) for a in arrays.values())
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _read_npz(path):
    with np.load(path, allow_pickle=False) as data:
        return {name: data[name] for name in data.files}


def main() -> None:
    mb = float(sys.argv[1]) if len(sys.argv) > 1 else 125.0
    arrays = _arrays(mb)
    with tempfile.TemporaryDirectory() as tmp:
        npz, exr = Path(tmp) / "bake.npz", Path(tmp) / "bake.exr"
        np.savez(npz, **arrays)
        bake_exr.write(exr, arrays)
        back = bake_exr.read(exr)
        assert all(back[k].tobytes() == a.tobytes() for k, a in arrays.items())  # lossless, every word
        packed = exr.read_bytes()
        rows = [("`.npz` file (before)", npz.stat().st_size, _median_seconds(lambda: _read_npz(npz))),
                ("OpenEXR file (now)", exr.stat().st_size, _median_seconds(lambda: bake_exr.read(exr))),
                ("OpenEXR packed in the .blend (bytes in memory)", len(packed),
                 _median_seconds(lambda: bake_exr.decode(packed)))]
    base = rows[0][2]
    lines = [f"# Reading a {mb:g} MB bake (warm, median of 7; `python scripts/bench_bake_files.py {mb:g}`)", "",
             "| storage | file size (MB) | read (s) | vs `.npz` |", "|---|---|---|---|"]
    lines += [f"| {name} | {size / 2**20:.1f} | {seconds:.3f} | {seconds / base:.2f}x |"
              for name, size, seconds in rows]
    text = "\n".join(lines) + "\n"
    out = ROOT / "bench" / "results" / "bake_files" / "read.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()

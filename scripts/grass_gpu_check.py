"""The grass BTF acquisition (Shah ch. 4) on whatever GPU moderngl's standalone context finds: the renderer's
name, seconds per acquisition and the images, to compare a real GPU with llvmpipe (the bake renders 81 views x
21 lights of the patch in a moderngl context of its own, outside Blender's).

    python scripts/grass_gpu_check.py OUT_FOLDER [RESOLUTION]

Writes OUT_FOLDER/grass_<renderer>.npz (images, depth, seconds, renderer) and prints one line of JSON.
"""
from __future__ import annotations

import json
import re
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import moderngl  # noqa: E402
import numpy as np  # noqa: E402

from translucent_addon.gpu.gl_context import standalone_backend  # noqa: E402
from translucent_addon.techniques.grass import acquire  # noqa: E402
from translucent_addon.techniques.grass.patch import GrassParams, build_patch  # noqa: E402


def main(out: Path, resolution: int) -> dict:
    ctx = moderngl.create_standalone_context(require=430, backend=standalone_backend())
    renderer = ctx.info["GL_RENDERER"]
    ctx.release()
    patch = build_patch(GrassParams())
    t0 = time.perf_counter()
    first = acquire.run(acquire.acquire(patch, resolution))  # the first includes shader compilation
    cold = time.perf_counter() - t0
    t0 = time.perf_counter()
    images = acquire.run(acquire.acquire(patch, resolution))
    warm = time.perf_counter() - t0
    same = float(np.abs(images.images - first.images).max())
    slug = re.sub(r"[^A-Za-z0-9]+", "_", renderer).strip("_")[:40]
    out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out / f"grass_{slug}.npz", images=images.images.astype(np.float16), depth=images.depth,
                        seconds=np.array([cold, warm]), renderer=np.array(renderer))
    return {"renderer": renderer, "resolution": resolution, "images": int(np.prod(images.images.shape[:2])),
            "seconds_cold": round(cold, 2), "seconds_warm": round(warm, 2), "repeat_max_difference": same}


if __name__ == "__main__":
    print(json.dumps(main(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 128)), flush=True)

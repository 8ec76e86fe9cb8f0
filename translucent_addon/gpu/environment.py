"""The world's prefiltered environment chain on the GPU (``core/environment.py``, Chan & Wang Table 1):
the background behind everything where the world is an image, and what GEOCUBE refracts."""
from __future__ import annotations

import numpy as np

from ..core import environment as env_chain
from . import resources
from .targets import texture_from_array

ENV_RES_RANGE = (16, 256)


def environment(frame):
    """(EnvironmentChain, atlas texture) of the frame's world, built once per world image."""
    env = frame.environment
    key = env.key if env is not None else "uniform:" + ",".join(f"{c:.6g}" for c in frame.world_color)
    held = resources.current().environments
    cached = held.get(key)
    if cached is None:
        if env is None:
            chain = env_chain.EnvironmentChain.uniform(np.asarray(frame.world_color, np.float64))
        else:
            w = env.image.shape[1]
            res = int(np.clip(2 ** int(np.round(np.log2(max(w, 4) / 4))), *ENV_RES_RANGE))
            chain = env_chain.EnvironmentChain.from_equirect(env.image, res)
        held.clear()
        cached = held[key] = (chain, texture_from_array(chain.atlas))
    return cached


def clear_cache() -> None:
    resources.current().environments.clear()

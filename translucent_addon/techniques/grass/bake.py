"""The grass BTF bake: patch, acquisition, compression, and its stored form (Shah 4.3).

Stored on the ground object under the key ``GRASS`` (``core/bake_store.py``): the eigen-textures in half
floats, coefficients, depth maps and the sampled directions; the hash covers the patch parameters,
the resolution and the target error, never the ground mesh (the BTF is the same on any ground).
"""
from __future__ import annotations

import json
import time

import numpy as np

from ...core import bake_store as store
from ...core.bake_checks import count, shaped
from . import acquire as btf_acquire
from . import compress as btf_compress
from .patch import GrassParams, build_patch

BAKE_KEY = "GRASS"
CHANNELS = ("Y", "Cb", "Cr")
DEFAULT_RESOLUTION = 128
DEFAULT_TARGET_ERROR = 0.5


class GrassSettingsError(ValueError):
    """Grass settings that cannot make a patch; the message says which and why."""


def params_from_settings(tile: float, blade_height: float, blades: int, seed: int) -> GrassParams:
    """GrassParams (tile units) from the object's settings (scene units)."""
    if not tile > 0.0:
        raise GrassSettingsError(f"grass tile must be larger than 0 (is {tile})")
    ratio = blade_height / tile
    if not 0.05 <= ratio <= 0.6:
        raise GrassSettingsError(f"blade height must be 5-60 % of the tile (is {100 * ratio:.0f} %): "
                                 f"taller blades reach beyond the tiles the BTF renders around each tile")
    if not 1 <= blades <= 5000:
        raise GrassSettingsError(f"blades per tile must be 1-5000 (is {blades})")
    # Rounded: the settings are single floats, and 0.045 / 0.1 must name the same BTF as 0.09 / 0.2.
    return GrassParams(blades=int(blades), height=round(float(ratio), 4), seed=int(seed))


SHADING_VERSION = 2  # 2: the sheen energy-normalised (btf_acquire.sheen_normalisation); BTFs before it are stale


def settings_hash(params: GrassParams, resolution: int, target_error: float) -> str:
    return store.inputs_hash({}, {"grass": params.as_dict(), "resolution": int(resolution),
                                  "target_error": round(float(target_error), 6), "shading": SHADING_VERSION})


# The Object.translucent settings a grass field is made of (``settings_digest``).
SETTINGS = ("grass_tile", "grass_blade_height", "grass_blades", "grass_seed", "grass_resolution", "grass_target_error")


def settings_digest(values: dict) -> tuple[str | None, str]:
    """(the hash of its BTF's settings, "") of a grass field's ``SETTINGS`` values, or (None, why) when they
    describe no grass a BTF can be baked of."""
    try:
        params = params_from_settings(values["grass_tile"], values["grass_blade_height"], values["grass_blades"],
                                      values["grass_seed"])
    except GrassSettingsError as err:
        return None, str(err)
    return settings_hash(params, int(values["grass_resolution"]), values["grass_target_error"]), ""


def bake(params: GrassParams = GrassParams(), resolution: int = DEFAULT_RESOLUTION,
         target_error: float = DEFAULT_TARGET_ERROR):
    """Generator: yields (fraction, text); returns (arrays, meta) to store. Acquisition is about 90 %
    of the time; the SVD the rest."""
    t0 = time.perf_counter()
    patch = build_patch(params)
    acquisition = btf_acquire.acquire(patch, resolution)
    while True:
        try:
            fraction, text = next(acquisition)
        except StopIteration as stop:
            images = stop.value
            break
        yield 0.9 * fraction, text
    yield 0.92, "grass BTF: SVD of the luminance and chroma matrices"
    F = btf_compress.btf_matrices(images)
    spectra = []
    for c in range(3):
        spectra.append(btf_compress.spectrum(F[c]))
        yield 0.92 + 0.025 * (c + 1), f"grass BTF: SVD of {CHANNELS[c]}"
    return package(images, spectra, params, resolution, target_error, time.perf_counter() - t0)


def package(images, spectra, params: GrassParams, resolution: int, target_error: float, seconds: float):
    """(arrays, meta) to store, from acquired images and their channels' spectra."""
    cb = btf_compress.compress(images, target_error, spectra=spectra)
    curves = btf_compress.error_curve(spectra)
    arrays = {f"basis_{n}": cb.basis[c].astype(np.float16) for c, n in enumerate(CHANNELS)}
    arrays.update({f"coeffs_{n}": cb.coeffs[c] for c, n in enumerate(CHANNELS)})
    arrays.update({"depth": cb.depth.astype(np.float32), "views": cb.views.astype(np.float32),
                   "lights": cb.lights.astype(np.float32), "error_curves": curves[:, :401].astype(np.float32)})
    total = btf_compress.total_error(curves, *cb.counts)
    meta = {"params": params.as_dict(), "resolution": int(resolution), "target_error": float(target_error),
            "height": float(cb.height), "counts": list(cb.counts), "errors": cb.errors,
            "total_error": total, "storage": cb.storage_bytes(), "target_met": total <= target_error,
            "uncompressed_bytes": int(images.images.size * 2), "acquisition_s": images.seconds,
            "bake_s": seconds, "blades": int(params.blades),
            "images": int(images.images.shape[0] * images.images.shape[1])}
    return arrays, meta


# The largest BTF image side a bake makes is 256 (GRASS_CHOICES); a stored shape past this is damage.
MAX_RESOLUTION = 2048


def check(arrays: dict) -> None:
    """DamagedBakeError unless a stored BTF's arrays fit together: the shader's loops over eigen-textures and
    its fetches follow these shapes (``core/bake_checks``)."""
    depth = shaped(arrays, "depth", (None, None, None))
    n_v, R = depth.shape[0], count(depth.shape[1], "BTF resolution", 1, MAX_RESOLUTION)
    shaped(arrays, "depth", (n_v, R, R))
    shaped(arrays, "views", (n_v, 3))
    n_l = len(shaped(arrays, "lights", (None, 3)))
    for n in CHANNELS:
        k = shaped(arrays, f"basis_{n}", (R, R, None)).shape[2]
        count(k, f"{n} eigen-texture count", 1, R * R)
        shaped(arrays, f"coeffs_{n}", (k, n_v, n_l + 1))


def from_arrays(arrays: dict, meta: dict) -> btf_compress.CompressedBTF:
    """The CompressedBTF of a stored bake, checked (``check``)."""
    check(arrays)
    if isinstance(meta, str):
        meta = json.loads(meta)
    return btf_compress.CompressedBTF(
        basis=[np.asarray(arrays[f"basis_{n}"], np.float32) for n in CHANNELS],
        coeffs=[np.asarray(arrays[f"coeffs_{n}"], np.float32) for n in CHANNELS],
        depth=np.asarray(arrays["depth"], np.float32),
        views=np.asarray(arrays["views"], np.float64), lights=np.asarray(arrays["lights"], np.float64),
        height=float(meta["height"]), counts=tuple(meta["counts"]), errors=dict(meta["errors"]))

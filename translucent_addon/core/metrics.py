"""Image error metrics over an object's pixels, in linear radiance. Pure NumPy/SciPy."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike


def _rgb(img):
    return np.asarray(img, dtype=np.float64)[..., :3]


def relative_rmse(image: np.ndarray, reference: np.ndarray, mask: np.ndarray) -> float:
    """sqrt(mean |I - R|^2) / sqrt(mean |R|^2) over the masked pixels and the three channels."""
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        raise ValueError("the mask selects no pixel: the object is not in view")
    diff = _rgb(image)[mask] - _rgb(reference)[mask]
    norm = np.sqrt(np.mean(_rgb(reference)[mask] ** 2))
    if norm == 0:
        raise ValueError("the reference is black over the object")
    return float(np.sqrt(np.mean(diff**2)) / norm)


def block_relative_rmse(image: np.ndarray, reference: np.ndarray, mask: np.ndarray, block: int = 8) -> float:
    """relative_rmse of the means over the masked pixels of each block x block tile (tiles with no masked
    pixel skipped; a partial tile at the image's edge dropped): the error in what a texture of blades
    looks like from further away, blind to where each blade lies within its tile."""
    mask = np.asarray(mask, dtype=bool)
    if block < 1:
        raise ValueError("a block needs at least one pixel")
    h, w = (mask.shape[0] // block) * block, (mask.shape[1] // block) * block
    if h == 0 or w == 0:
        raise ValueError(f"the image is smaller than one {block} x {block} block")

    def tiles(x: np.ndarray) -> np.ndarray:
        return x[:h, :w].reshape(h // block, block, w // block, block, *x.shape[2:]).sum(axis=(1, 3))

    m = mask[:h, :w].astype(np.float64)
    n = tiles(m)
    keep = n > 0
    means = [tiles(_rgb(x)[:h, :w] * m[..., None]) / np.maximum(n, 1)[..., None] for x in (image, reference)]
    return relative_rmse(means[0], means[1], keep)


def mean_noise(samples: ArrayLike, mask: np.ndarray) -> float:
    """The relative RMSE that the mean of n independent renders (n, h, w, c) keeps from their noise:
    sqrt(mean over the masked pixels and channels of s^2 / n) / sqrt(mean of the mean's square), s^2 the
    unbiased variance across the renders (for two, half the relative RMSE between them)."""
    samples = np.asarray(samples, np.float64)[..., :3]
    n = len(samples)
    if n < 2:
        raise ValueError("the noise of a mean needs at least two renders")
    mask = np.asarray(mask, dtype=bool)
    var = samples.var(axis=0, ddof=1)[mask]
    norm = np.sqrt(np.mean(samples.mean(axis=0)[mask] ** 2))
    return float(np.sqrt(np.mean(var / n)) / norm)


def median_relative_error(image: np.ndarray, reference: np.ndarray, mask: np.ndarray) -> float:
    """Median over the masked pixels of |I - R| / mean(R) (luminance): robust to fireflies."""
    return float(np.median(relative_error_image(image, reference, mask)[np.asarray(mask, bool)]))


def luminance(img: np.ndarray) -> np.ndarray:
    rgb = _rgb(img)
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def ssim(image: np.ndarray, reference: np.ndarray, mask: np.ndarray, sigma: float = 1.5) -> float:
    """Mean SSIM (Wang et al. 2004, Gaussian window) of linear luminance over the masked pixels.

    The dynamic range L is the reference's maximum over the mask (linear HDR has no fixed range).
    """
    from scipy.ndimage import gaussian_filter

    mask = np.asarray(mask, dtype=bool)
    x, y = luminance(image), luminance(reference)
    L = float(y[mask].max()) if mask.any() else 1.0
    c1, c2 = (0.01 * L) ** 2, (0.03 * L) ** 2
    mu_x, mu_y = gaussian_filter(x, sigma), gaussian_filter(y, sigma)
    sxx = gaussian_filter(x * x, sigma) - mu_x**2
    syy = gaussian_filter(y * y, sigma) - mu_y**2
    sxy = gaussian_filter(x * y, sigma) - mu_x * mu_y
    s = ((2 * mu_x * mu_y + c1) * (2 * sxy + c2)) / ((mu_x**2 + mu_y**2 + c1) * (sxx + syy + c2))
    return float(s[mask].mean())


def relative_error_image(image: np.ndarray, reference: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per-pixel |I - R| / mean(R) (luminance), zero outside the mask."""
    mask = np.asarray(mask, dtype=bool)
    err = np.abs(luminance(image) - luminance(reference))
    scale = max(float(luminance(reference)[mask].mean()), 1e-12) if mask.any() else 1.0
    return np.where(mask, err / scale, 0.0)


def display(img: np.ndarray, exposure: float = 1.0) -> np.ndarray:
    """Linear radiance to 8-bit sRGB for looking (Reinhard on luminance-free RGB, then sRGB)."""
    x = np.clip(_rgb(img) * exposure, 0.0, None)
    x = x / (1.0 + x)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (np.clip(srgb, 0, 1) * 255 + 0.5).astype(np.uint8)


def flicker(frames: Sequence[np.ndarray], masks: Sequence[np.ndarray]) -> float:
    """Temporal noise of an animation: mean over t of sum |I_t - (I_{t-1} + I_{t+1}) / 2| / sum I_t
    (luminance), over the pixels inside the object in all three frames.

    The second difference cancels smooth change (an object turning at constant speed changes its
    pixels almost linearly in time) and keeps frame-to-frame sampling noise: Shah 6.5.2's flicker.
    """
    values = []
    for t in range(1, len(frames) - 1):
        m = np.asarray(masks[t - 1], bool) & np.asarray(masks[t], bool) & np.asarray(masks[t + 1], bool)
        if m.any():
            prev, cur, nxt = (luminance(frames[k])[m] for k in (t - 1, t, t + 1))
            values.append(float(np.abs(cur - 0.5 * (prev + nxt)).sum() / max(cur.sum(), 1e-12)))
    if not values:
        raise ValueError("no pixel stays on the object over three frames")
    return float(np.mean(values))

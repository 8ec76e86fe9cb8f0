"""Matplotlib's inferno colormap and its tab10 / tab20 categorical palettes as embedded tables, for the
report's false-colour error images and charts without matplotlib (not bundled with the extension). Pure."""
from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import ArrayLike

# matplotlib's inferno (256 entries, van der Walt and Smith, CC0) at every fifth entry, 0 to 255: 52 stops
# at x = 0, 1/51, ..., 1. Linear interpolation is within 1/255 of matplotlib's 256 colours.
_INFERNO = np.array([
    (0.0015, 0.0005, 0.0139), (0.0077, 0.0061, 0.0468), (0.0194, 0.0151, 0.0888), (0.0377, 0.0259, 0.1322),
    (0.0613, 0.0366, 0.1776), (0.0874, 0.0446, 0.2248), (0.1167, 0.0476, 0.2723), (0.1491, 0.0455, 0.3171),
    (0.1834, 0.0403, 0.3550), (0.2179, 0.0366, 0.3835), (0.2516, 0.0377, 0.4034), (0.2843, 0.0439, 0.4166),
    (0.3163, 0.0535, 0.4251), (0.3478, 0.0646, 0.4302), (0.3790, 0.0763, 0.4327), (0.4101, 0.0879, 0.4331),
    (0.4412, 0.0993, 0.4316), (0.4723, 0.1105, 0.4283), (0.5035, 0.1216, 0.4234), (0.5347, 0.1325, 0.4167),
    (0.5659, 0.1436, 0.4083), (0.5969, 0.1548, 0.3981), (0.6278, 0.1666, 0.3863), (0.6585, 0.1790, 0.3727),
    (0.6887, 0.1922, 0.3576), (0.7183, 0.2066, 0.3409), (0.7471, 0.2224, 0.3229), (0.7751, 0.2397, 0.3035),
    (0.8019, 0.2587, 0.2831), (0.8274, 0.2795, 0.2617), (0.8514, 0.3023, 0.2396), (0.8737, 0.3269, 0.2169),
    (0.8943, 0.3534, 0.1936), (0.9130, 0.3816, 0.1698), (0.9296, 0.4115, 0.1454), (0.9443, 0.4428, 0.1204),
    (0.9569, 0.4754, 0.0947), (0.9673, 0.5091, 0.0687), (0.9757, 0.5438, 0.0436), (0.9819, 0.5794, 0.0262),
    (0.9860, 0.6158, 0.0256), (0.9878, 0.6528, 0.0456), (0.9875, 0.6904, 0.0800), (0.9849, 0.7284, 0.1208),
    (0.9800, 0.7668, 0.1664), (0.9731, 0.8054, 0.2169), (0.9644, 0.8438, 0.2734), (0.9550, 0.8816, 0.3375),
    (0.9476, 0.9174, 0.4107), (0.9479, 0.9493, 0.4914), (0.9618, 0.9759, 0.5719), (0.9884, 0.9984, 0.6449),
])

# matplotlib's tab10 (its default line colours C0..C9) and tab20 (tab10's hues, each with a light partner).
TAB10 = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
)
TAB20 = (
    "#1f77b4", "#aec7e8", "#ff7f0e", "#ffbb78", "#2ca02c", "#98df8a", "#d62728", "#ff9896", "#9467bd",
    "#c5b0d5", "#8c564b", "#c49c94", "#e377c2", "#f7b6d2", "#7f7f7f", "#c7c7c7", "#bcbd22", "#dbdb8d",
    "#17becf", "#9edae5",
)


def inferno(x: ArrayLike) -> np.ndarray:
    """The inferno colour of each value in [0, 1] (clipped; NaN as 0): shape (..., 3), floats in [0, 1]."""
    x = np.nan_to_num(np.clip(np.asarray(x, np.float64), 0.0, 1.0), nan=0.0)
    stops = np.linspace(0.0, 1.0, len(_INFERNO))
    return np.stack([np.interp(x, stops, _INFERNO[:, k]) for k in range(3)], axis=-1)


def hex_rgb(colour: str) -> tuple:
    """'#rrggbb' as an (r, g, b) tuple of floats in [0, 1]."""
    return tuple(int(colour[k:k + 2], 16) / 255.0 for k in (1, 3, 5))


def series_colours(names: Iterable[str]) -> dict:
    """One (r, g, b) colour per distinct name, in sorted order: tab10 (matplotlib's default colours) for up
    to ten names, tab20 past that, so that no two series look alike in any chart."""
    names = sorted(set(names))
    palette = TAB10 if len(names) <= 10 else TAB20
    return {name: hex_rgb(palette[k % len(palette)]) for k, name in enumerate(names)}

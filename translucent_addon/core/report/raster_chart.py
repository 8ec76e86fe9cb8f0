"""A small rasteriser for the report's log-log charts, in NumPy only: the extension bundles no matplotlib.

Panels (Axes) hold series, step lines, horizontal lines and point labels in data space; a Figure lays them
out in a grid with a title and a legend outside the panels and rasterises everything at SUPERSAMPLE times
the output size (edges with analytic coverage), then box-downsamples, for anti-aliased lines and text.
Coordinates are output pixels, x to the right, y down, top-left corner at (0, 0). Pure.

Text uses chart_font.npz, an atlas of DejaVu Sans (printable ASCII) made by scripts/make_chart_font.py.
DejaVu Sans derives from Bitstream Vera: (c) 2003 Bitstream, Inc., DejaVu changes in the public domain; a
permissive licence, whose text is in chart_font_LICENSE.txt beside the atlas.
"""
from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from .png import write_png

SUPERSAMPLE = 2  # canvas pixels per output pixel, each way; the font atlas is drawn for this
TEXT = (0.1, 0.1, 0.1)
FRAME = (0.2, 0.2, 0.2)
GRID_MAJOR = (0.85, 0.85, 0.85)
GRID_MINOR = (0.94, 0.94, 0.94)
LEGEND_EDGE = (0.8, 0.8, 0.8)
WHITE = (1.0, 1.0, 1.0)
# Output pixels per em: the figure title, panel titles and axis labels, tick labels and legend, point labels.
TITLE_SIZE, LABEL_SIZE, TICK_SIZE, NOTE_SIZE = 13.0, 12.0, 11.0, 10.0
TEXT_GAMMA = 0.7  # coverage to this power: thin strokes darker after the downsample, as hinted text looks
SUP_RISE = 0.35  # an exponent's baseline below the top of its base's line, over the ascent
MARKERS = "osD^v<>ph"  # circle, square, diamond, triangles up/down/left/right, pentagon, hexagon
DASH = (5.0, 3.0)  # on, off (output pixels)
# Polygon markers: sides, angle of the first vertex (degrees), vertex distance over the marker's radius.
_POLYGONS = {"s": (4, 45, 1.15), "D": (4, 0, 1.2), "^": (3, 90, 1.25), "v": (3, 270, 1.25), "<": (3, 180, 1.25),
             ">": (3, 0, 1.25), "p": (5, 90, 1.1), "h": (6, 90, 1.05)}
_SUBSTITUTES = str.maketrans({"\u2212": "-", "\u2013": "-", "\u2014": "-", "\u00d7": "x", "\u00b5": "u",
                              "\u2018": "'", "\u2019": "'", "\u201c": '"', "\u201d": '"', "\u00b2": "2"})

@functools.cache
def _font() -> dict:
    """The glyph atlas and metrics (loaded once; no pickles)."""
    with np.load(Path(__file__).with_name("chart_font.npz"), allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def _glyph_indices(text: str) -> np.ndarray:
    f = _font()
    codes = np.frombuffer(str(text).translate(_SUBSTITUTES).encode("ascii", "replace"), np.uint8).astype(np.int64)
    codes = np.where((codes < 32) | (codes > 126), ord("?"), codes)
    return codes - int(f["first"])


def text_width(text: str, size: float) -> float:
    """The advance width of a line of text at ``size`` output pixels per em."""
    f = _font()
    return float(f["advance"][_glyph_indices(text)].sum()) * size / float(f["size"])


def line_height(size: float) -> float:
    f = _font()
    return (float(f["ascent"]) + float(f["descent"])) * size / float(f["size"])


def ascent(size: float) -> float:
    f = _font()
    return float(f["ascent"]) * size / float(f["size"])


def _resample_matrix(n_in: int, n_out: int, scale: float) -> np.ndarray:
    """(n_out, n_in) weights that resample a row of n_in samples by ``scale`` with a tent filter as wide as
    the larger pixel: antialiased when shrinking, bilinear when enlarging."""
    centres = (np.arange(n_out) + 0.5) / scale
    support = max(1.0, 1.0 / scale)
    w = np.maximum(0.0, 1.0 - np.abs(np.arange(n_in)[None, :] + 0.5 - centres[:, None]) / support)
    total = w.sum(axis=1, keepdims=True)
    return w / np.where(total > 0, total, 1.0)


def _text_coverage(text: str, size_canvas: float) -> tuple[np.ndarray, float, float]:
    """Coverage (0..1) of a line of text at ``size_canvas`` canvas pixels per em, its baseline row and the
    column of the pen's start (right of 0 when a glyph reaches left of it)."""
    f = _font()
    idx = _glyph_indices(text)
    asc, desc = int(f["ascent"]), int(f["descent"])
    pens = np.concatenate([[0.0], np.cumsum(f["advance"][idx])])
    lefts = np.round(pens[:-1]).astype(int) + f["left"][idx]
    shift = max(0, -int(lefts.min()))
    width = max(int(math.ceil(pens[-1])), int((lefts + f["width"][idx]).max())) + shift + 2
    block = np.zeros((asc + desc, width), np.uint8)
    for i, x in zip(idx, lefts + shift):
        w, h, top = int(f["width"][i]), int(f["height"][i]), asc + int(f["top"][i])
        if w and h:
            y0, y1 = max(top, 0), min(top + h, block.shape[0])
            glyph = f["atlas"][y0 - top:y1 - top, int(f["x"][i]):int(f["x"][i]) + w]
            np.maximum(block[y0:y1, x:x + w], glyph, out=block[y0:y1, x:x + w])
    scale = size_canvas / float(f["size"])
    rows = _resample_matrix(block.shape[0], max(1, int(math.ceil(block.shape[0] * scale))), scale)
    cols = _resample_matrix(block.shape[1], max(1, int(math.ceil(block.shape[1] * scale))), scale)
    cov = np.clip(rows @ (block.astype(np.float32) / 255.0) @ cols.T, 0.0, 1.0)
    return cov ** TEXT_GAMMA, asc * scale, shift * scale


def wrap(text: str, size: float, width: float) -> list[str]:
    """Greedy word wrap of one line of text to ``width`` output pixels."""
    lines: list[str] = []
    for word in str(text).split():
        if lines and text_width(lines[-1] + " " + word, size) <= width:
            lines[-1] += " " + word
        else:
            lines.append(word)
    return lines or [""]


class Canvas:
    """An RGB uint8 image at SUPERSAMPLE times the output size, drawn on with coverage-blended shapes."""

    def __init__(self, width: int, height: int, background: Sequence[float] = WHITE):
        self.width, self.height = int(width), int(height)
        s = SUPERSAMPLE
        self.px = np.empty((self.height * s, self.width * s, 3), np.uint8)
        self.px[:] = np.round(np.asarray(background) * 255).astype(np.uint8)

    def _box(self, x0, y0, x1, y1, clip) -> tuple[int, int, int, int] | None:
        """Canvas-pixel bounds of a box in canvas coordinates, within the canvas and the clip box."""
        cx0, cy0, cx1, cy1 = (0, 0, self.px.shape[1], self.px.shape[0]) if clip is None else \
            tuple(int(round(v * SUPERSAMPLE)) for v in clip)
        bx0, by0 = max(int(math.floor(x0)), cx0, 0), max(int(math.floor(y0)), cy0, 0)
        bx1 = min(int(math.ceil(x1)), cx1, self.px.shape[1])
        by1 = min(int(math.ceil(y1)), cy1, self.px.shape[0])
        return (bx0, by0, bx1, by1) if bx1 > bx0 and by1 > by0 else None

    def _blend(self, box, alpha: np.ndarray, colour) -> None:
        bx0, by0, bx1, by1 = box
        region = self.px[by0:by1, bx0:bx1].astype(np.float32)
        region += alpha[..., None].astype(np.float32) * (np.asarray(colour, np.float32) * 255.0 - region)
        self.px[by0:by1, bx0:bx1] = np.clip(np.round(region), 0, 255).astype(np.uint8)

    def _grid(self, box):
        bx0, by0, bx1, by1 = box
        return np.arange(bx0, bx1)[None, :] + 0.5, np.arange(by0, by1)[:, None] + 0.5

    def rect(self, x0: float, y0: float, x1: float, y1: float, colour: Sequence[float],
             clip: tuple[float, float, float, float] | None = None) -> None:
        """Fill a box (output pixels)."""
        s = SUPERSAMPLE
        box = self._box(x0 * s, y0 * s, x1 * s, y1 * s, clip)
        if box:
            self._blend(box, np.ones((box[3] - box[1], box[2] - box[0]), np.float32), colour)

    def segment(self, p: Sequence[float] | np.ndarray, q: Sequence[float] | np.ndarray, width: float,
                colour: Sequence[float], clip: tuple[float, float, float, float] | None = None) -> None:
        """A straight line of ``width`` output pixels with round caps, from p to q. A long slanted line goes
        in strips along its longer axis, each only as wide as the line there: little memory, each pixel once."""
        s = SUPERSAMPLE
        (x0, y0), (x1, y1) = (p[0] * s, p[1] * s), (q[0] * s, q[1] * s)
        half = width * s / 2.0
        box = self._box(min(x0, x1) - half - 1, min(y0, y1) - half - 1, max(x0, x1) + half + 1,
                        max(y0, y1) + half + 1, clip)
        if not box:
            return
        dx, dy = x1 - x0, y1 - y0
        length2 = dx * dx + dy * dy
        along_x = abs(dx) >= abs(dy)
        lo, hi = (box[0], box[2]) if along_x else (box[1], box[3])
        for start in range(lo, hi, 64):
            end = min(start + 64, hi)
            if length2 > 0:  # the line's span across the strip, from where it enters to where it leaves
                a, b = ((start - x0) / dx, (end - x0) / dx) if along_x else ((start - y0) / dy, (end - y0) / dy)
                ta, tb = np.clip((a, b), 0.0, 1.0)
                across = (y0 + ta * dy, y0 + tb * dy) if along_x else (x0 + ta * dx, x0 + tb * dx)
            else:
                across = (y0, y0) if along_x else (x0, x0)
            c0, c1 = math.floor(min(across) - half - 1), math.ceil(max(across) + half + 1)
            sub = (start, max(c0, box[1]), end, min(c1, box[3])) if along_x else \
                (max(c0, box[0]), start, min(c1, box[2]), end)
            if sub[2] <= sub[0] or sub[3] <= sub[1]:
                continue
            gx, gy = self._grid(sub)
            t = np.clip(((gx - x0) * dx + (gy - y0) * dy) / length2, 0.0, 1.0) if length2 > 0 else 0.0
            dist = np.hypot(gx - x0 - t * dx, gy - y0 - t * dy)
            self._blend(sub, np.clip(half + 0.5 - dist, 0.0, 1.0), colour)

    def polyline(self, points: ArrayLike, width: float, colour: Sequence[float], dashed: bool = False,
                 clip: tuple[float, float, float, float] | None = None) -> None:
        """Segments joining the points; dashed: DASH on and off along the length, continuing round corners."""
        pts = np.asarray(points, np.float64).reshape(-1, 2)
        if len(pts) == 1:
            self.segment(pts[0], pts[0], width, colour, clip)
        along = 0.0
        period = DASH[0] + DASH[1]
        for p, q in zip(pts[:-1], pts[1:]):
            length = float(np.hypot(*(q - p)))
            if not dashed:
                self.segment(p, q, width, colour, clip)
                continue
            start = -(along % period)  # where the current dash began, relative to p
            while start < length:
                a, b = max(start, 0.0), min(start + DASH[0], length)
                if b > a and length > 0:
                    self.segment(p + (q - p) * (a / length), p + (q - p) * (b / length), width, colour, clip)
                start += period
            along += length

    def marker(self, x: float, y: float, shape: str, size: float, colour: Sequence[float],
               clip: tuple[float, float, float, float] | None = None) -> None:
        """A filled marker of ``size`` output pixels across, centred on (x, y): see MARKERS."""
        s = SUPERSAMPLE
        cx, cy, r = x * s, y * s, size * s / 2.0
        box = self._box(cx - r - 2, cy - r - 2, cx + r + 2, cy + r + 2, clip)
        if not box:
            return
        gx, gy = self._grid(box)
        if shape == "o":
            dist = np.hypot(gx - cx, gy - cy) - r
        else:
            # A convex polygon: the largest signed distance to its edges' lines (exact inside, close outside).
            sides, turn, reach = _POLYGONS.get(shape, _POLYGONS["s"])
            angles = np.radians(turn + 360.0 * np.arange(sides) / sides)
            vx, vy = r * reach * np.cos(angles), -r * reach * np.sin(angles)
            dist = np.full(np.broadcast(gx, gy).shape, -np.inf)
            for k in range(sides):
                ex, ey = vx[(k + 1) % sides] - vx[k], vy[(k + 1) % sides] - vy[k]
                nx, ny = ey / math.hypot(ex, ey), -ex / math.hypot(ex, ey)
                if vx[k] * nx + vy[k] * ny < 0:  # make the normal point away from the centre
                    nx, ny = -nx, -ny
                dist = np.maximum(dist, (gx - cx - vx[k]) * nx + (gy - cy - vy[k]) * ny)
        self._blend(box, np.clip(0.5 - dist, 0.0, 1.0), colour)

    def text(self, x: float, y: float, text: str, size: float, colour: Sequence[float] = TEXT, ha: str = "left",
             va: str = "baseline", rotate: bool = False,
             clip: tuple[float, float, float, float] | None = None) -> tuple[float, float]:
        """A line of text at ``size`` output pixels per em, anchored at (x, y) by ha (left, center, right) and
        va (baseline, top, center, bottom); rotate: reading upwards, centred on (x, y). Returns its size."""
        if not str(text):
            return 0.0, 0.0
        s = SUPERSAMPLE
        cov, baseline, origin = _text_coverage(text, size * s)
        advance = text_width(text, size) * s
        if rotate:
            cov = np.rot90(cov)
            x0, y0 = x * s - cov.shape[1] / 2.0, y * s - (cov.shape[0] - origin - advance / 2.0)
        else:
            x0 = x * s - origin - {"left": 0.0, "center": advance / 2.0, "right": advance}[ha]
            height = line_height(size) * s
            y0 = y * s - {"baseline": baseline, "top": 0.0, "center": height / 2.0, "bottom": height}[va]
        x0, y0 = int(round(x0)), int(round(y0))
        box = self._box(x0, y0, x0 + cov.shape[1], y0 + cov.shape[0], clip)
        if box:
            self._blend(box, cov[box[1] - y0:box[3] - y0, box[0] - x0:box[2] - x0], colour)
        return advance / s, line_height(size)

    def ink(self, x0: float, y0: float, x1: float, y1: float) -> float:
        """Mean darkness (0 white .. 1 black, over the channels) in a box (output pixels): what is drawn there."""
        box = self._box(x0 * SUPERSAMPLE, y0 * SUPERSAMPLE, x1 * SUPERSAMPLE, y1 * SUPERSAMPLE, None)
        if not box:
            return 0.0
        return 1.0 - float(self.px[box[1]:box[3], box[0]:box[2]].mean()) / 255.0

    def image(self) -> np.ndarray:
        """The output image: each SUPERSAMPLE x SUPERSAMPLE block averaged, (H, W, 3) uint8."""
        s = SUPERSAMPLE
        total = np.full((self.height, self.width, 3), s * s // 2, np.uint16)  # rounds the mean to nearest
        for i in range(s):
            for j in range(s):
                total += self.px[i::s, j::s]
        return (total // (s * s)).astype(np.uint8)


def _pow10_label(k: int, plain: bool) -> tuple[str, str]:
    """A decade's tick label as (base, superscript): '0.01' plainly, or 10 to the power k."""
    if plain:
        return (f"{10.0 ** k:g}" if k < 0 else f"{10 ** k:d}"), ""
    return "10", str(k)


def _log_ticks(lo: float, hi: float, pixels: float, label_px: float):
    """Ticks of a log axis spanning log10 values lo..hi over ``pixels``: (major log10 values, their labels
    as (base, superscript), minor log10 values, labelled minor values with labels). Decades are labelled,
    thinned when labels ``label_px`` apart would crowd; on an axis shorter than two decades the 2x, 3x and
    5x ticks too (and the rest if that makes fewer than three labels), where they do not crowd; on one too
    short for any of those, two round values inside it."""
    eps = 1e-9
    decades = list(range(math.ceil(lo - eps), math.floor(hi + eps) + 1))
    plain = all(-3 <= k <= 4 for k in range(math.floor(lo), math.ceil(hi) + 1))
    minor = [k + math.log10(m) for k in range(math.floor(lo), math.ceil(hi) + 1) for m in range(2, 10)]
    minor = [v for v in minor if lo - eps <= v <= hi + eps]
    step = 1
    while len(decades) / step * label_px > pixels * 0.8 and step < len(decades):
        step += 1
    labelled = [k for k in decades if k % step == 0]
    minor_labelled: list = []
    if len(decades) < 2:
        per_unit = pixels / max(hi - lo, eps)
        for multiples in ((2, 3, 5), (4, 6, 7, 8, 9)):
            if multiples[0] == 4 and len(labelled) + len(minor_labelled) >= 3:
                break
            for v in minor:
                taken = labelled + [u for u, _ in minor_labelled]
                if round(10 ** (v - math.floor(v + eps))) in multiples and \
                        all(abs(v - u) * per_unit >= label_px for u in taken):
                    minor_labelled.append((v, (f"{round(10 ** v, 12):g}", "")))
    if not labelled and len(minor_labelled) < 2:
        minor_labelled = []
        for v in (lo + 0.15 * (hi - lo), hi - 0.15 * (hi - lo)):
            value = float(f"{10 ** v:.2g}")
            if not lo <= math.log10(value) <= hi:
                value = float(f"{10 ** v:.3g}")
            minor.append(math.log10(value))
            minor_labelled.append((math.log10(value), (f"{value:g}", "")))
    return decades, [(k, _pow10_label(k, plain)) for k in labelled], minor, sorted(minor_labelled)


class Axes:
    """One log-log panel: what to draw, in data coordinates; the figure gives it its place (``rect``)."""

    def __init__(self):
        self.lines: list[dict] = []
        self.notes: list[tuple] = []
        self.hlines: list[dict] = []
        self.title = self.xlabel = self.ylabel = ""
        self.rect = None  # (x0, y0, x1, y1) of the plot area in output pixels, once laid out
        self.xlim = self.ylim = None  # log10 limits, once laid out

    def plot(self, xs: ArrayLike, ys: ArrayLike, colour: Sequence[float], marker: str | None = "o",
             label: str | None = None, width: float = 2.0, dashed: bool = False, step: bool = False,
             marker_size: float = 8.0) -> None:
        """A series (only positive, finite points: the axes are logarithmic); step: a 'post' staircase."""
        xs, ys = np.asarray(xs, np.float64).ravel(), np.asarray(ys, np.float64).ravel()
        keep = np.isfinite(xs) & np.isfinite(ys) & (xs > 0) & (ys > 0)
        self.lines.append(dict(x=xs[keep], y=ys[keep], colour=tuple(colour), marker=marker, label=label,
                               width=width, dashed=dashed, step=step, marker_size=marker_size))

    def axhline(self, y: float, colour: Sequence[float], width: float = 1.0, dashed: bool = True) -> None:
        if np.isfinite(y) and y > 0:
            self.hlines.append(dict(y=float(y), colour=tuple(colour), width=width, dashed=dashed))

    def annotate(self, text: str, x: float, y: float, offset: tuple[float, float] = (5.0, -5.0),
                 size: float = NOTE_SIZE) -> None:
        """A small label beside a data point (offset in output pixels; baseline at the offset)."""
        if np.isfinite(x) and np.isfinite(y) and x > 0 and y > 0:
            self.notes.append((str(text), float(x), float(y), offset, size))

    def set(self, title: str = "", xlabel: str = "", ylabel: str = "") -> None:
        self.title, self.xlabel, self.ylabel = title, xlabel, ylabel

    def limits(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """log10 limits holding every point with a 5 % margin each side (a lone value: half a decade)."""
        xs = np.concatenate([line["x"] for line in self.lines] + [np.array([n[1] for n in self.notes])])
        ys = np.concatenate([line["y"] for line in self.lines] + [np.array([n[2] for n in self.notes])]
                            + [np.array([h["y"] for h in self.hlines])])

        def span(values: np.ndarray) -> tuple[float, float]:
            if values.size == 0:
                return -1.0, 1.0
            lo, hi = float(np.log10(values.min())), float(np.log10(values.max()))
            if hi - lo < 1e-9:
                return lo - 0.5, hi + 0.5
            margin = 0.05 * (hi - lo)
            return lo - margin, hi + margin

        return span(xs), span(ys)

    def to_pixel(self, x: ArrayLike, y: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Output-pixel coordinates of data points, once the figure is laid out."""
        (x0, y0, x1, y1), (xl, xh), (yl, yh) = self.rect, self.xlim, self.ylim
        px = x0 + (np.log10(np.asarray(x, np.float64)) - xl) / (xh - xl) * (x1 - x0)
        py = y1 - (np.log10(np.asarray(y, np.float64)) - yl) / (yh - yl) * (y1 - y0)
        return px, py

    def legend_entries(self) -> list[dict]:
        return [line for line in self.lines if line["label"]]

    def _tick_label_width(self, labels, size) -> float:
        return max([text_width(b, size) + text_width(e, size * 0.7) for _, (b, e) in labels] + [0.0])

    def margins(self) -> tuple[float, float, float, float]:
        """Room the panel needs round its plot area (left, top, right, bottom), for titles, labels and ticks."""
        (xl, xh), (yl, yh) = self.limits()
        _, ylab, _, yminor = _log_ticks(yl, yh, 300.0, line_height(TICK_SIZE))
        width = self._tick_label_width(ylab + yminor, TICK_SIZE)
        left = 4 + width + 6 + (line_height(LABEL_SIZE) + 6 if self.ylabel else 0)
        top = line_height(LABEL_SIZE) + 8 if self.title else 8
        bottom = 4 + line_height(TICK_SIZE) + 4 + (line_height(LABEL_SIZE) + 2 if self.xlabel else 0)
        return left, top, 16.0, bottom

    def draw(self, canvas: Canvas) -> None:
        """Grid, data, labels, frame and ticks, within self.rect."""
        x0, y0, x1, y1 = self.rect
        (xl, xh), (yl, yh) = self.xlim, self.ylim
        clip = (x0, y0, x1, y1)
        xmajor, xlab, xminor, xminlab = _log_ticks(xl, xh, x1 - x0, 0)
        xlab_px = self._tick_label_width(xlab + xminlab, TICK_SIZE) + 12
        xmajor, xlab, xminor, xminlab = _log_ticks(xl, xh, x1 - x0, xlab_px)
        ymajor, ylab, yminor, yminlab = _log_ticks(yl, yh, y1 - y0, line_height(TICK_SIZE) + 4)

        def xpix(v: float) -> float:
            return math.floor(x0 + (v - xl) / (xh - xl) * (x1 - x0)) + 0.5  # on a pixel's centre: crisp

        def ypix(v: float) -> float:
            return math.floor(y1 - (v - yl) / (yh - yl) * (y1 - y0)) + 0.5

        for values, colour in ((xminor, GRID_MINOR), (xmajor, GRID_MAJOR)):
            for v in values:
                canvas.segment((xpix(v), y0), (xpix(v), y1), 1.0, colour, clip)
        for values, colour in ((yminor, GRID_MINOR), (ymajor, GRID_MAJOR)):
            for v in values:
                canvas.segment((x0, ypix(v)), (x1, ypix(v)), 1.0, colour, clip)
        for h in self.hlines:
            py = math.floor(float(self.to_pixel(10 ** xl, h["y"])[1])) + 0.5
            canvas.polyline([(x0, py), (x1, py)], h["width"], h["colour"], h["dashed"], clip)
        for line in self.lines:
            if not line["x"].size:
                continue
            px, py = self.to_pixel(line["x"], line["y"])
            if line["step"]:  # 'post': level until the next point's time, on pixel centres (crisp)
                px, py = np.floor(np.repeat(px, 2)[1:]) + 0.5, np.floor(np.repeat(py, 2)[:-1]) + 0.5
            canvas.polyline(np.stack([px, py], -1), line["width"], line["colour"], line["dashed"], clip)
            if line["marker"]:
                for a, b in zip(px, py):
                    canvas.marker(a, b, line["marker"], line["marker_size"], line["colour"], clip)
        for text, x, y, (dx, dy), size in self.notes:
            px, py = (float(v) for v in self.to_pixel(x, y))
            w, asc, desc = text_width(text, size), ascent(size), line_height(size) - ascent(size)
            # Up and right of the point as asked, or whichever corner of it covers the least already drawn
            # (lines, markers, other labels), staying inside the panel where it can.
            below = py + abs(dy) + 0.75 * asc
            best = None
            for k, (bx, base) in enumerate(((px + dx, py + dy), (px + dx, below), (px - dx - w, py + dy),
                                            (px - dx - w, below))):
                box = (bx, base - asc, bx + w, base + desc)
                outside = box[0] < x0 or box[2] > x1 or box[1] < y0 or box[3] > y1
                score = (outside, round(canvas.ink(*box) / 0.02), k)  # grid lines: below the step
                best = min(best, (score, bx, base)) if best else (score, bx, base)
            canvas.text(best[1], best[2], text, size, TEXT)
        # The frame, then ticks and labels outside it.
        fx0, fy0, fx1, fy1 = x0 + 0.5, y0 + 0.5, x1 - 0.5, y1 - 0.5  # on pixel centres: crisp
        for p, q in (((fx0, fy0), (fx1, fy0)), ((fx1, fy0), (fx1, fy1)), ((fx1, fy1), (fx0, fy1)),
                     ((fx0, fy1), (fx0, fy0))):
            canvas.segment(p, q, 1.0, FRAME)
        for values, length in ((xminor, 2.5), (xmajor, 4.5)):
            for v in values:
                canvas.segment((xpix(v), y1), (xpix(v), y1 + length), 1.0, FRAME)
        for values, length in ((yminor, 2.5), (ymajor, 4.5)):
            for v in values:
                canvas.segment((x0 - length, ypix(v)), (x0, ypix(v)), 1.0, FRAME)
        tick_top = y1 + 6
        for v, (base, sup) in xlab + xminlab:
            w = text_width(base, TICK_SIZE) + text_width(sup, TICK_SIZE * 0.7)
            left = xpix(v) - w / 2
            canvas.text(left, tick_top, base, TICK_SIZE, TEXT, va="top")
            if sup:
                canvas.text(left + text_width(base, TICK_SIZE), tick_top + ascent(TICK_SIZE) * SUP_RISE, sup,
                            TICK_SIZE * 0.7, TEXT, va="baseline")
        for v, (base, sup) in ylab + yminlab:
            right = x0 - 7
            sup_w = text_width(sup, TICK_SIZE * 0.7)
            canvas.text(right - sup_w, ypix(v), base, TICK_SIZE, TEXT, ha="right", va="center")
            if sup:
                canvas.text(right - sup_w, ypix(v) - line_height(TICK_SIZE) / 2 + ascent(TICK_SIZE) * SUP_RISE, sup,
                            TICK_SIZE * 0.7, TEXT)
        if self.xlabel:
            canvas.text((x0 + x1) / 2, tick_top + line_height(TICK_SIZE) + 2, self.xlabel, LABEL_SIZE, TEXT,
                        ha="center", va="top")
        if self.ylabel:
            width = self._tick_label_width(ylab + yminlab, TICK_SIZE)
            canvas.text(x0 - 7 - width - 6 - line_height(LABEL_SIZE) / 2, (y0 + y1) / 2, self.ylabel, LABEL_SIZE,
                        TEXT, rotate=True)
        if self.title:
            canvas.text((x0 + x1) / 2, y0 - 6, self.title, LABEL_SIZE, TEXT, ha="center", va="bottom")


class Figure:
    """A page of panels in a grid, a title over them and one legend (to the right of them, or below)."""

    def __init__(self, width: int, height: int | None = None, rows: int = 1, cols: int = 1, title: str = "",
                 panels: int | None = None, panel_height: float = 440.0):
        """height None: as tall as the title, rows of ``panel_height`` and the legend need."""
        self.width, self.height, self.rows, self.cols, self.title = int(width), height, rows, cols, title
        self.panel_height = panel_height
        self.axes = [Axes() for _ in range(rows * cols if panels is None else panels)]
        self.legend_where = None
        self.legend_items: list[dict] = []

    def legend(self, where: str = "right", items: list[dict] | None = None) -> None:
        """A legend outside the panels; items: dicts as Axes.plot keeps them (label, colour, marker, dashed,
        width), by default every labelled line of every panel, the first of each label."""
        self.legend_where = where
        if items is None:
            seen: dict = {}
            for ax in self.axes:
                for line in ax.legend_entries():
                    seen.setdefault(line["label"], line)
            items = list(seen.values())
        self.legend_items = items

    def _legend_size(self, max_width: float) -> tuple[float, float, int, float]:
        """Width and height of the legend box, its columns and their width (output pixels)."""
        if not self.legend_items:
            return 0.0, 0.0, 0, 0.0
        item_w = max(text_width(i["label"], TICK_SIZE) for i in self.legend_items) + 30 + 8 + 14
        cols = 1 if self.legend_where == "right" else int((max_width - 16) // item_w)
        cols = max(1, min(len(self.legend_items), cols))
        rows = -(-len(self.legend_items) // cols)
        return cols * item_w + 12, rows * (line_height(TICK_SIZE) + 5) + 10, cols, item_w

    def _draw_legend(self, canvas: Canvas, x: float, y: float, size) -> None:
        w, h, cols, item_w = size
        x, y, w, h = math.floor(x) + 0.5, math.floor(y) + 0.5, round(w), round(h)  # edges on pixel centres
        canvas.rect(x, y, x + w, y + h, WHITE)
        for p, q in (((x, y), (x + w, y)), ((x + w, y), (x + w, y + h)), ((x + w, y + h), (x, y + h)),
                     ((x, y + h), (x, y))):
            canvas.segment(p, q, 1.0, LEGEND_EDGE)
        row_h = line_height(TICK_SIZE) + 5
        for k, item in enumerate(self.legend_items):
            ix, iy = x + 10 + (k % cols) * item_w, y + 5 + (k // cols) * row_h + row_h / 2
            canvas.polyline([(ix, iy), (ix + 30, iy)], item.get("width", 2.0), item["colour"],
                            item.get("dashed", False))
            if item.get("marker"):
                canvas.marker(ix + 15, iy, item["marker"], item.get("marker_size", 8.0), item["colour"])
            canvas.text(ix + 38, iy, item["label"], TICK_SIZE, TEXT, va="center")

    def render(self) -> np.ndarray:
        """Lay out and rasterise the figure: (H, W, 3) uint8, top row first."""
        pad = 10.0
        lines = wrap(self.title, TITLE_SIZE, self.width - 2 * pad) if self.title else []
        top = pad + (len(lines) * line_height(TITLE_SIZE) + 4 if lines else 0.0)
        legend = self._legend_size(self.width - 2 * pad) if self.legend_where else (0.0, 0.0, 0, 0.0)
        height = self.height
        if height is None:
            below = legend[1] + pad if legend[0] and self.legend_where == "below" else 0.0
            height = int(math.ceil(top + self.rows * self.panel_height + below + pad))
        canvas = Canvas(self.width, height)
        for k, line in enumerate(lines):
            canvas.text(self.width / 2, pad + k * line_height(TITLE_SIZE), line, TITLE_SIZE, TEXT, ha="center",
                        va="top")
        right, bottom = self.width - pad, height - pad
        if legend[0] and self.legend_where == "right":
            right -= legend[0] + pad
        elif legend[0]:
            bottom -= legend[1] + pad
        cell_w, cell_h = (right - pad) / self.cols, (bottom - top) / self.rows
        for k, ax in enumerate(self.axes):
            r, c = divmod(k, self.cols)
            ml, mt, mr, mb = ax.margins()
            cx, cy = pad + c * cell_w, top + r * cell_h
            ax.rect = (round(cx + ml), round(cy + mt), round(cx + cell_w - mr), round(cy + cell_h - mb))
            ax.xlim, ax.ylim = ax.limits()
            ax.draw(canvas)
        if legend[0] and self.legend_where == "right":
            y0 = min(ax.rect[1] for ax in self.axes) if self.axes else top
            self._draw_legend(canvas, right + pad, y0, legend)
        elif legend[0]:
            self._draw_legend(canvas, (self.width - legend[0]) / 2, bottom + pad, legend)
        return canvas.image()

    def save(self, path: str | Path) -> np.ndarray:
        """Render and write a PNG; returns the image."""

        image = self.render()
        write_png(path, image)
        return image

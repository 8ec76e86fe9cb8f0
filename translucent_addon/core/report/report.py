"""The comparison report (report.json), its images and the speed-vs-accuracy chart. Pure: NumPy only (PNGs,
colours and charts by png.py, colormaps.py and raster_chart.py; the extension bundles no matplotlib)."""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..metrics import display, median_relative_error, relative_error_image, relative_rmse
from . import raster_chart
from .colormaps import TAB10, hex_rgb, inferno, series_colours
from .png import write_png


@dataclasses.dataclass
class Entry:
    """One render in the report."""

    series: str  # what a chart line joins: "Translucent (OFF)", "Cycles random walk", "EEVEE"...
    engine: str  # TRANSLUCENT_RT, CYCLES, BLENDER_EEVEE, CPU_DIPOLE_MODEL
    settings: dict
    seconds: float
    reference: str  # the series the errors are measured against
    rel_rmse: float | None = None
    ssim: float | None = None
    median_rel_error: float | None = None  # robust to fireflies
    rel_rmse_model: float | None = None  # ours against the CPU dipole model: the discretisation error
    median_vs_brute_force: float | None = None  # median relative error against the brute-force check
    image: str = ""
    error_image: str = ""
    cached: bool = False
    # Its error is within the reference's own noise (report meta "reference_noise"): the reference cannot rank it.
    below_reference_noise: bool = False


def save_png(path: Path, rgb8: np.ndarray) -> None:
    """Write an 8-bit RGB(A) image (row 0 at the bottom, as rendered) as a PNG (top row first)."""
    write_png(path, np.asarray(rgb8, np.uint8)[::-1])


def save_error_png(path: Path, image: np.ndarray, reference: np.ndarray, mask: np.ndarray, vmax: float = 0.5) -> None:
    """False-colour relative error |I - R| / mean(R) (0 to vmax, inferno), grey where the object is not."""
    err = relative_error_image(image, reference, mask)
    rgb = inferno(np.clip(err / vmax, 0, 1))
    rgb[~np.asarray(mask, bool)] = (0.25, 0.25, 0.25)
    save_png(path, (rgb * 255).astype(np.uint8))


def save_image_png(path: Path, image: np.ndarray, exposure: float = 1.0) -> None:
    save_png(path, display(image, exposure))


def write_report(path: Path, entries: list[Entry], meta: dict) -> None:
    path.write_text(json.dumps({"meta": meta, "renders": [dataclasses.asdict(e) for e in entries]}, indent=2))


def read_report(path: Path) -> tuple[list[Entry], dict]:
    data = json.loads(Path(path).read_text())
    fields = {f.name for f in dataclasses.fields(Entry)}
    return [Entry(**{k: v for k, v in e.items() if k in fields}) for e in data["renders"]], data["meta"]


def reference_noise(half_a: np.ndarray, half_b: np.ndarray, mask: np.ndarray) -> dict[str, float]:
    """The reference's own error, per chart metric, from the two independent halves it averages: their
    difference has four times the variance of their mean, so each metric of (a, b) halved."""
    return {"rel_rmse": relative_rmse(half_a, half_b, mask) / 2.0,
            "median_rel_error": median_relative_error(half_a, half_b, mask) / 2.0}


# What each chart panel plots: the RMSE, and the median that fireflies in the reference cannot move.
CHART_METRICS = (("rel_rmse", "relative RMSE over the object"),
                 ("median_rel_error", "median relative error over the object"))


def pareto_front(seconds: ArrayLike, errors: ArrayLike) -> np.ndarray:
    """Indices of the points that no other point beats in both time and error (faster and at least as
    accurate, or as fast and more accurate), in order of time: the choices worth having."""
    t = np.asarray(seconds, np.float64)
    e = np.asarray(errors, np.float64)
    front, best = [], np.inf
    for i in np.lexsort((e, t)):  # by time, then by error
        if e[i] < best:
            front.append(int(i))
            best = e[i]
    return np.array(front, np.int64)


def _measured(entries, metric: str):
    return [e for e in entries if getattr(e, metric) is not None and getattr(e, metric) > 0]


PARETO_COLOUR = (0.3, 0.3, 0.3)
NOISE_COLOUR = (0.62, 0.62, 0.62)


def _speed_accuracy_panel(ax, entries, metric: str, ylabel: str, colours: dict, labels: bool = True) -> None:
    """One log-log panel (a raster_chart.Axes): a line per series, setting labels, the Pareto front of all
    points dashed."""
    markers = raster_chart.MARKERS
    items = [e for e in _measured(entries, metric) if np.isfinite(e.seconds) and e.seconds > 0
             and np.isfinite(getattr(e, metric))]
    series = {}
    for e in items:
        series.setdefault(e.series, []).append(e)
    for name, group in sorted(series.items()):
        group.sort(key=lambda e: e.seconds)
        k = sorted(colours).index(name)
        ax.plot([e.seconds for e in group], [getattr(e, metric) for e in group], colours[name],
                marker=markers[k % len(markers)], label=name)
        for e in group if labels else ():
            label = e.settings.get("label")
            if label:
                ax.annotate(str(label), e.seconds, getattr(e, metric))
    if items:
        front = [items[i] for i in pareto_front([e.seconds for e in items], [getattr(e, metric) for e in items])]
        ax.plot([e.seconds for e in front], [getattr(e, metric) for e in front], PARETO_COLOUR, marker=None,
                label="Pareto front", width=1.2, dashed=True, step=True)
    ax.set(xlabel="seconds per frame (this machine, one run)", ylabel=ylabel)


def _legend_items(colours: dict) -> list[dict]:
    """Every series (the same marker as in the panels) and the Pareto front."""
    markers = raster_chart.MARKERS
    return ([dict(label=name, colour=colours[name], marker=markers[k % len(markers)])
             for k, name in enumerate(sorted(colours))]
            + [dict(label="Pareto front", colour=PARETO_COLOUR, marker=None, width=1.2, dashed=True)])


def speed_accuracy_chart(entries: list[Entry], path: Path, title: str, noise: dict | None = None) -> None:
    """Error against seconds per frame (log-log), one line per series, labels with settings: the relative
    RMSE (which a few fireflies in the reference can dominate) and the median relative error beside it, and
    the reference's own ``noise`` per metric as a grey dashed line (errors below it are not resolved).
    The legend sits to the right of the panels, off the data."""
    colours = series_colours(e.series for e in entries)
    legend_w = max([raster_chart.text_width(n, raster_chart.TICK_SIZE) for n in colours] + [80.0])
    fig = raster_chart.Figure(int(1300 + legend_w), 560, rows=1, cols=2, title=title)
    for ax, (metric, ylabel) in zip(fig.axes, CHART_METRICS):
        _speed_accuracy_panel(ax, entries, metric, ylabel, colours)
        if noise and np.isfinite(noise.get(metric, np.nan)) and noise[metric] > 0:
            ax.axhline(noise[metric], NOISE_COLOUR, width=1.2, dashed=True)
    items = _legend_items(colours)
    if noise:
        items.append(dict(label="reference noise", colour=NOISE_COLOUR, marker=None, width=1.2, dashed=True))
    fig.legend("right", items)
    fig.save(path)


def pareto_summary_chart(scenes: dict, path: Path, title: str, metric: str = "median_rel_error",
                         panel_metrics: dict | None = None, panel_titles: dict | None = None) -> None:
    """Every scene's speed against accuracy in one figure (a panel per scene, the same colour per series
    in each), with each scene's Pareto front: which method and setting is worth its time where.
    ``panel_metrics`` and ``panel_titles`` override the metric and the title of named panels (a scene whose
    benchmark measured only the RMSE, against its own reference). The legend sits below the panels."""
    names = sorted(scenes)
    if not names:
        raise ValueError("no scenes to chart")
    cols = min(2, len(names))
    rows = (len(names) + cols - 1) // cols
    colours = series_colours(e.series for entries in scenes.values() for e in entries)
    fig = raster_chart.Figure(750 * cols, rows=rows, cols=cols, title=title, panels=len(names), panel_height=460)
    for ax, name in zip(fig.axes, names):
        m = (panel_metrics or {}).get(name, metric)
        _speed_accuracy_panel(ax, scenes[name], m, dict(CHART_METRICS)[m], colours, labels=False)
        ax.title = (panel_titles or {}).get(name, name)
    fig.legend("below", _legend_items(colours))
    fig.save(path)


def error_against_samples_chart(rows: list[dict], path: Path, title: str) -> None:
    """Relative RMSE against the dipole model over the number of light-view samples (Shah Fig. 6.10)."""
    fig = raster_chart.Figure(715, 462)
    ax = fig.axes[0]
    ax.plot([r["object_samples"] for r in rows], [r["rel_rmse_vs_model"] for r in rows], hex_rgb(TAB10[0]),
            marker="o")
    for r in rows:
        ax.annotate(f"k={r['overlap']:g}, {r['seconds']:.2f} s", r["object_samples"], r["rel_rmse_vs_model"])
    ax.axhline(0.05, (0.5, 0.5, 0.5), width=1.0, dashed=True)
    ax.set(title=title, xlabel="light-view samples on the object (all lights)",
           ylabel="relative RMSE against the dipole model")
    fig.save(path)

"""The comparison report (report.json), its images and the speed-vs-accuracy chart. Pure."""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from .metrics import display, relative_error_image


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


def save_png(path: Path, rgb8: np.ndarray) -> None:
    """Write an 8-bit RGB image (row 0 at the bottom, as rendered) with matplotlib."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.imsave(path, rgb8[::-1])


def save_error_png(path: Path, image, reference, mask, vmax: float = 0.5) -> None:
    """False-colour relative error |I - R| / mean(R) (0 to vmax), grey where the object is not."""
    import matplotlib

    matplotlib.use("Agg")
    err = relative_error_image(image, reference, mask)
    rgba = matplotlib.colormaps["inferno"](np.clip(err / vmax, 0, 1))
    rgba[~np.asarray(mask, bool)] = (0.25, 0.25, 0.25, 1.0)
    save_png(path, (rgba[..., :3] * 255).astype(np.uint8))


def save_image_png(path: Path, image, exposure: float = 1.0) -> None:
    save_png(path, display(image, exposure))


def write_report(path: Path, entries: list[Entry], meta: dict) -> None:
    path.write_text(json.dumps({"meta": meta, "renders": [dataclasses.asdict(e) for e in entries]}, indent=2))


def read_report(path: Path) -> tuple[list[Entry], dict]:
    data = json.loads(Path(path).read_text())
    return [Entry(**e) for e in data["renders"]], data["meta"]


# What each chart panel plots: the RMSE, and the median that fireflies in the reference cannot move.
CHART_METRICS = (("rel_rmse", "relative RMSE over the object"),
                 ("median_rel_error", "median relative error over the object"))


def pareto_front(seconds, errors) -> np.ndarray:
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


def _series_colours(names) -> dict:
    """One colour per series, the same in every panel and chart (tab20 past ten series: no two alike)."""
    names = sorted(set(names))
    if len(names) <= 10:
        return {name: f"C{k}" for k, name in enumerate(names)}
    from matplotlib import colormaps

    palette = colormaps["tab20"]
    return {name: palette(k % 20) for k, name in enumerate(names)}


def _speed_accuracy_panel(ax, entries, metric: str, ylabel: str, colours: dict, labels: bool = True) -> None:
    """One log-log panel: a line per series, setting labels, the Pareto front of all points dashed."""
    markers = "osD^v<>px*h"
    items = _measured(entries, metric)
    series = {}
    for e in items:
        series.setdefault(e.series, []).append(e)
    for name, group in sorted(series.items()):
        group.sort(key=lambda e: e.seconds)
        k = sorted(colours).index(name)
        ax.plot([e.seconds for e in group], [getattr(e, metric) for e in group], marker=markers[k % len(markers)],
                color=colours[name], label=name)
        for e in group if labels else ():
            label = e.settings.get("label")
            if label:
                ax.annotate(label, (e.seconds, getattr(e, metric)), textcoords="offset points", xytext=(4, 4),
                            fontsize=6)
    if items:
        front = [items[i] for i in pareto_front([e.seconds for e in items], [getattr(e, metric) for e in items])]
        ax.step([e.seconds for e in front], [getattr(e, metric) for e in front], where="post", color="grey",
                linestyle="--", linewidth=1.0, label="Pareto front")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("seconds per frame (this machine, one run)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)


def speed_accuracy_chart(entries: list[Entry], path: Path, title: str) -> None:
    """Error against seconds per frame (log-log), one line per series, labels with settings: the relative
    RMSE (which a few fireflies in the reference can dominate) and the median relative error beside it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(14, 5))
    colours = _series_colours(e.series for e in entries)
    for ax, (metric, ylabel) in zip(axes, CHART_METRICS):
        _speed_accuracy_panel(ax, entries, metric, ylabel, colours)
    axes[1].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def pareto_summary_chart(scenes: dict, path: Path, title: str, metric: str = "median_rel_error",
                         panel_metrics: dict | None = None, panel_titles: dict | None = None) -> None:
    """Every scene's speed against accuracy in one figure (a panel per scene, the same colour per series
    in each), with each scene's Pareto front: which method and setting is worth its time where.
    ``panel_metrics`` and ``panel_titles`` override the metric and the title of named panels (a scene whose
    benchmark measured only the RMSE, against its own reference)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = sorted(scenes)
    if not names:
        raise ValueError("no scenes to chart")
    cols = min(2, len(names))
    rows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(7.5 * cols, 4.8 * rows), squeeze=False)
    colours = _series_colours(e.series for entries in scenes.values() for e in entries)
    for ax, name in zip(axes.flat, names):
        m = (panel_metrics or {}).get(name, metric)
        _speed_accuracy_panel(ax, scenes[name], m, dict(CHART_METRICS)[m], colours, labels=False)
        ax.set_title((panel_titles or {}).get(name, name), fontsize=9)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    handles = {}
    for ax in axes.flat:
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=4, fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.06 + 0.02 * rows, 1, 0.97))
    fig.savefig(path, dpi=100)
    plt.close(fig)


def error_against_samples_chart(rows: list[dict], path: Path, title: str) -> None:
    """Relative RMSE against the dipole model over the number of light-view samples (Shah Fig. 6.10)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    xs = [r["object_samples"] for r in rows]
    ax.plot(xs, [r["rel_rmse_vs_model"] for r in rows], marker="o")
    for r in rows:
        ax.annotate(f"k={r['overlap']:g}, {r['seconds']:.2f} s", (r["object_samples"], r["rel_rmse_vs_model"]),
                    textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.axhline(0.05, color="grey", linestyle="--", linewidth=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("light-view samples on the object (all lights)")
    ax.set_ylabel("relative RMSE against the dipole model")
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

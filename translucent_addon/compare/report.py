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


def speed_accuracy_chart(entries: list[Entry], path: Path, title: str) -> None:
    """Relative RMSE against seconds per frame (log-log), one line per series, labels with settings."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5))
    series = {}
    for e in entries:
        if e.rel_rmse is None or e.rel_rmse <= 0:
            continue
        series.setdefault(e.series, []).append(e)
    markers = "osD^v<>px*h"
    for k, (name, items) in enumerate(sorted(series.items())):
        items.sort(key=lambda e: e.seconds)
        ax.plot([e.seconds for e in items], [e.rel_rmse for e in items], marker=markers[k % len(markers)],
                label=name)
        for e in items:
            label = e.settings.get("label")
            if label:
                ax.annotate(label, (e.seconds, e.rel_rmse), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("seconds per frame (this machine, one run)")
    ax.set_ylabel("relative RMSE over the object (linear radiance)")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
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

"""What Auto quality's choices are made of (pure): an object as the camera sees it, the benchmark's measured
curves (``data/quality_curves.json``, written by ``scripts/quality_curves.py``), power laws fitted to them, and
a choice. Each technique's ``quality.py`` turns these into its resolutions."""
from __future__ import annotations

import dataclasses
import functools
import json
import math
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from .data import DATA
from .physics.lut import profile_model

CURVES_JSON = DATA / "quality_curves.json"  # the benchmark's measured curves (scripts/quality_curves.py)


@dataclasses.dataclass(frozen=True)
class ObjectView:
    """What AUTO needs to know of an object: its size, its material and how large the camera sees it."""

    diagonal_mm: float  # bounding-box diagonal, scale and mm_per_unit applied
    area_mm2: float  # surface area
    screen_pixels: float | None  # the bounding-box diagonal on the camera's image; None: no camera
    sigma_a: tuple
    sigma_s_prime: tuple
    eta: float
    triangles: int | None = None  # the mesh's: a proxy finer than the mesh is refined, not decimated
    profile: str = "EXACT"  # the radial profile its bake uses (``physics.lut.PROFILES``): its form factors' reach

    @property
    def pixel_mm(self) -> float:
        """Millimetres of the object one pixel covers (0 when no camera sees it: no cap)."""
        if not self.screen_pixels or self.screen_pixels <= 0:
            return 0.0
        return self.diagonal_mm / self.screen_pixels

    @property
    def r_max_mm(self) -> float:
        """The splat radius: r_max of the profile's slowest channel (Shah Eq. 6.16, epsilon 0.01), the profile the
        object is drawn with (the dipole's is 0.78-1.11 times the exact one's over the presets)."""
        return float(np.max(profile_model(self.profile).r_max(np.asarray(self.sigma_a, float),
                                                              np.asarray(self.sigma_s_prime, float), self.eta)))


@dataclasses.dataclass(frozen=True)
class PowerLaw:
    """error(x) = a x^p, fitted to measured (x, error) points."""

    a: float
    p: float
    x_range: tuple  # the measured x, for saying when a choice extrapolates

    def __call__(self, x: ArrayLike) -> np.ndarray | float:
        return self.a * np.asarray(x, float) ** self.p

    def inverse(self, error: float) -> float:
        return float((error / self.a) ** (1.0 / self.p))

    @classmethod
    def envelope(cls, x: ArrayLike, error: ArrayLike) -> "PowerLaw":
        """Least-squares slope in log-log, then the offset raised until no point lies above the line."""
        lx, le = np.log(np.asarray(x, float)), np.log(np.asarray(error, float))
        p = float(np.polyfit(lx, le, 1)[0])
        log_a = float(np.max(le - p * lx))
        return cls(math.exp(log_a), p, (float(np.min(x)), float(np.max(x))))


@functools.lru_cache(maxsize=2)
def load_curves(path: str = str(CURVES_JSON)) -> dict:
    return json.loads(Path(path).read_text())


@dataclasses.dataclass
class Choice:
    """AUTO's answer for one object: the settings, what they should cost and reach, and why."""

    method: str
    settings: dict  # Object.translucent property -> value
    scene_settings: dict  # Scene.translucent property -> value (the splat overlap is the scene's)
    predicted_error: float | None  # discretisation error against the method's model
    cost: dict
    notes: list

    def summary(self) -> str:
        parts = [f"{k} {v}" for k, v in {**self.settings, **self.scene_settings}.items()]
        err = "" if self.predicted_error is None else f"; predicted error {100 * self.predicted_error:.1f} %"
        return ", ".join(parts) + err + "".join(f"; {n}" for n in self.notes)

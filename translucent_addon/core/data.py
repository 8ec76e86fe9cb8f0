"""Where the shipped data lives (presets, calibration tables, Auto's curves, meshes): one place, so that a
module can move without its resource paths."""
from __future__ import annotations

from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "data"

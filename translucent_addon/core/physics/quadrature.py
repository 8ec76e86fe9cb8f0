"""The trapezoidal rule on any NumPy Blender ships: NumPy 2 renamed ``np.trapz`` to ``np.trapezoid``
(and 2.4 removed the old name); NumPy 1.26 (Blender 4.5) has only ``trapz``."""
from __future__ import annotations

import numpy as np

trapezoid = getattr(np, "trapezoid", None) or getattr(np, "trapz")

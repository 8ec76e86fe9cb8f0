"""The techniques, one folder each with the same file names: ``model.py`` (the pure twin), ``bake.py``,
``passes.py`` (its GPU passes), ``quality.py``; the paper's name is in each docstring, not in file names.
Here: the object methods' ids, labels and order (the registry of the ``method`` property)."""
from __future__ import annotations

METHOD_IDS = ("OFF", "IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE")

METHOD_DESCRIPTIONS = {
    "OFF": "Opaque: base colour with Lambert shading and shadows",
    "IMAGE_SPACE": "Image-space splatting of the dipole (Shah 2007): no bake, deforming objects",
    "TEXTURE_SPACE": "Texture-space kernels plus global throughput (Lensch 2002): rigid hero objects",
    "QUADGRAPH": "Diffusion equation on a tetrahedral QuadGraph (Wang 2010): thin parts, veins; edit without re-baking",
    "GEOCUBE": "Geocube refraction and thickness blur (Chan & Wang 2005): glass and slight scattering",
}

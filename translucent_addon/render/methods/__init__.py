"""Translucency methods: one module per method, each adding its own passes.

A method module holds its GPU passes (``image_space.py``, ``texture_space.py``) and its pure
maths (``*_data.py``); the pipeline calls it around the base pass. The method issues
(QUADGRAPH, GEOCUBE) each added their module here; every id below has its passes.
"""
from __future__ import annotations

METHOD_IDS = ("OFF", "IMAGE_SPACE", "TEXTURE_SPACE", "QUADGRAPH", "GEOCUBE")

METHOD_DESCRIPTIONS = {
    "OFF": "Opaque: base colour with Lambert shading and shadows",
    "IMAGE_SPACE": "Image-space splatting of the dipole (Shah 2007): no bake, deforming objects",
    "TEXTURE_SPACE": "Texture-space kernels plus global throughput (Lensch 2002): rigid hero objects",
    "QUADGRAPH": "Diffusion equation on a tetrahedral QuadGraph (Wang 2010): thin parts, veins; edit without re-baking",
    "GEOCUBE": "Geocube refraction and thickness blur (Chan & Wang 2005): glass and slight scattering",
}

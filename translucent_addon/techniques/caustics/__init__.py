"""Caustics: refractive and reflective caustics by caustic mapping (Shah 2007, ch. 5)."""

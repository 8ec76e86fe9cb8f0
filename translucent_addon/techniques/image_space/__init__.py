"""IMAGE_SPACE: image-space subsurface scattering by splatting (Shah 2007, ch. 6-7)."""

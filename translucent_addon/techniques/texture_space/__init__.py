"""TEXTURE_SPACE: texture-space kernels plus global throughput (Lensch et al. 2002)."""

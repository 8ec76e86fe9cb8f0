"""QUADGRAPH: the diffusion equation on a tetrahedral graph (Wang et al. 2010)."""

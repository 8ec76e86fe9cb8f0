"""Grass fields: a compressed bidirectional texture function with silhouettes (Shah 2007, ch. 4)."""

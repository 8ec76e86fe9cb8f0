"""GEOCUBE: two-sided refraction, internal reflection and thickness blur from geocubes (Chan & Wang 2005)."""

"""Comparison with Cycles and EEVEE: parameter conversions, metrics, charts, twin scenes."""

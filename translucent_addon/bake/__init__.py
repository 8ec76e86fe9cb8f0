"""Bakes: per-method precomputation stored on the object, with an inputs hash."""

"""Physics of subsurface scattering: coefficients, presets and (later) the dipole."""

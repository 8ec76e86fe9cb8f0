"""Pure geometry: camera rays, ray casting, mesh arrays, hashing, mesh files."""

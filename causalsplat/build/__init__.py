"""Building a stored scene graph from a scene folder (DESIGN §9): reading the folder,
the cached pipeline stages, the build report."""

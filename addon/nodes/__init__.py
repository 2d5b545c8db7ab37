"""Builders of the geometry-node groups and compositor trees that Tussock owns."""

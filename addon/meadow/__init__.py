"""Meadows of millions of blades: patch, tiles, density map and geometry-node instancing."""

"""Refine captured skeletons by movement similarity (seed 000 §4.4, Algorithm 1)."""

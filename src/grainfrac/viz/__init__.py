"""Figures (matplotlib, Agg). Drawing only: no physics, no file formats beyond images."""

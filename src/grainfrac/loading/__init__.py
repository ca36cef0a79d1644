"""Loads and boundary conditions: in-situ stress, platens, borehole pressure, fixed nodes."""

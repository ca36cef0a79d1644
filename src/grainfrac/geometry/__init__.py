"""Specimen geometry: shapes, grain tessellation, meshing and the contact/flow network."""

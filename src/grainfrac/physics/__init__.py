"""Mechanics of deformable grains and breakable contacts: model arrays, kernels, driver."""

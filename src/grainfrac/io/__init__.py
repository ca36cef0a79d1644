"""Input and output, in two layers.

Bottom (below everything): ``io.config`` reads and validates configs,
``io.files`` writes files atomically, ``io.checkpoint`` writes and reads
checkpoint records. Run layer (above the physics): ``io.results`` (history and
crack tables), ``io.snapshots`` and ``io.vtk`` (ParaView files) write a run's
results. The layer contract in pyproject.toml holds each module to its layer.
"""

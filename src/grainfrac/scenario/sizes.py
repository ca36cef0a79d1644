"""Size checks made before anything is built: the estimated element count of a
slab's mesh and the borehole's width in zones.
"""

from __future__ import annotations

import math

from grainfrac.assembly import SpecimenConfig
from grainfrac.errors import ConfigError
from grainfrac.geometry.specimens import SlabSpec

__all__ = [
    "BOREHOLE_MIN_ZONES",
    "ELEMENTS_PER_ZONE_AREA",
    "MAX_ELEMENTS",
    "MAX_ELEMENTS_3D",
    "TETS_PER_ZONE_VOLUME",
    "check_size",
    "estimated_elements",
]


# Limits checked before anything is built, so that a mistyped size fails at once
# instead of hanging or running out of memory (issue 42: ``zone_size_mm = 0.01``,
# ``duration_ms = 1e300``).
# Elements per zone area: measured 2.22 (default slab, 5562 elements at 2 mm zones)
# and 2.23 (the same slab at 0.5 mm zones, 89326 elements).
ELEMENTS_PER_ZONE_AREA = 2.25
# The assembly and mechanical model took 1.2-2.0 kB of memory per element (measured
# at those two sizes), so this is 6-10 GB before the run's own arrays.
MAX_ELEMENTS = 5_000_000
# 3D: tetrahedra per zone volume (zone_size_mm cubed), measured 8.6 (30 x 30 x 20 mm slab,
# 10 mm borehole, 2 mm zones, 17692 tets), 8.0 (the same at 1.5 mm, 38741 tets) and 7.8
# (40 x 40 x 20 mm, no borehole, 2 mm, 31223 tets); 9 bounds them.
TETS_PER_ZONE_VOLUME = 9.0
# 3D meshing is done grain by grain in Python (about 15000 tets a second here) and a
# tetrahedron carries more state than a triangle (4 nodes of 3 components): 2e6 tets
# are some minutes of meshing and a few GB before the run's own arrays.
MAX_ELEMENTS_3D = 2_000_000


# The borehole must be this many zones across: a 1 mm borehole at 2 mm zones could not
# be meshed and 0.5 mm crashed the SCDA plug's mesh; 2 mm (one zone) still meshed.
BOREHOLE_MIN_ZONES = 2.0


def estimated_elements(config: SpecimenConfig) -> float | None:
    """Elements the mesh of ``config`` will have, estimated before building it: triangles
    of a 2D slab (:data:`ELEMENTS_PER_ZONE_AREA`), tetrahedra of a 3D slab or cube
    (:data:`TETS_PER_ZONE_VOLUME`); None for the other shapes (small lab specimens)."""
    spec, zone = config.specimen, config.grains.zone_size_mm
    if not isinstance(spec, SlabSpec):
        return None
    area = spec.width_mm * spec.height_mm - math.pi * spec.borehole_diameter_mm**2 / 4
    if config.dimension == 3:
        return TETS_PER_ZONE_VOLUME * area * spec.thickness_mm / zone**3
    return ELEMENTS_PER_ZONE_AREA * area / zone**2


def check_size(config: SpecimenConfig) -> SpecimenConfig:
    """Check what can be told of a slab's mesh (2D, or 3D slab or cube) before building it.

    Raises :class:`ConfigError` if the estimated element count
    (:func:`estimated_elements`) exceeds :data:`MAX_ELEMENTS` (2D triangles) or
    :data:`MAX_ELEMENTS_3D` (3D tetrahedra), or a borehole is less than
    :data:`BOREHOLE_MIN_ZONES` zones across (with a hint when the value looks like metres).
    """
    spec, zone = config.specimen, config.grains.zone_size_mm
    problems: list[tuple[str, str]] = []
    elements = estimated_elements(config)
    if isinstance(spec, SlabSpec) and elements is not None:
        three = config.dimension == 3
        limit, power = (MAX_ELEMENTS_3D, 3) if three else (MAX_ELEMENTS, 2)
        if elements > limit:
            needed = zone * (elements / limit) ** (1 / power)
            size = (f"{spec.width_mm:g} x {spec.height_mm:g} x {spec.thickness_mm:g} mm 3D"
                    if three else f"{spec.width_mm:g} x {spec.height_mm:g} mm")
            what = (f"about {elements:.3g} {'tetrahedra' if three else 'elements'} for a "
                    f"{size} specimen at zone_size_mm = {zone:g}, more than the "
                    f"{limit:.0e} allowed")
            if needed <= config.grains.max_edge_mm:
                problems.append(("grains.zone_size_mm", f"{what}; raise zone_size_mm to at "
                                 f"least {needed:.3g} or shrink the specimen"))
            else:  # no zone the grains allow would do: the specimen is the mistake
                sides = {"width_mm": spec.width_mm, "height_mm": spec.height_mm}
                if three:
                    sides["thickness_mm"] = spec.thickness_mm
                side = max(sides, key=sides.get)
                problems.append((f"specimen.{side}", f"{what}; shrink the specimen"))
        d = spec.borehole_diameter_mm
        if 0 < d < BOREHOLE_MIN_ZONES * zone:
            hint = " (a value in metres? the unit is mm)" if d < 0.1 else ""
            problems.append(("specimen.borehole_diameter_mm", (
                f"must be 0 (no borehole) or >= {BOREHOLE_MIN_ZONES:g} zones "
                f"({BOREHOLE_MIN_ZONES * zone:g} mm at zone_size_mm = {zone:g}){hint} "
                f"(got {d:g})")))
    if problems:
        raise ConfigError(*problems[0], problems[1:])
    return config

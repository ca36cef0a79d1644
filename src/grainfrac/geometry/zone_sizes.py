"""Target zone size of a 3D mesh: uniform, or finer near a borehole along the z axis.

A linear tetrahedron's stress is constant, so the stress concentration at a
borehole wall converges with the zone size there. Refining the whole specimen
costs the cube of the ratio in zones and its first power again in time step;
refining the wall alone costs a ring of grains.

The size is chosen per mesh entity (grain edge, grain face, convex piece) at its
vertex nearest the borehole axis, so every point is still made once on the cell
complex and shared by everything that touches it (the mesh conforms as before):

    h(d) = wall                                     for d <= reach
    h(d) = wall + (far - wall) (d - reach) / reach  for reach < d < 2 reach
    h(d) = far                                      beyond,

with ``d`` the distance from the borehole wall. Whole grains that touch the
refined band are therefore refined throughout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ZoneSizes:
    """Zone edge by distance from the borehole wall (m).

    Attributes
    ----------
    far
        Zone size away from the borehole (the specimen's ``zone_size_mm``).
    wall
        Zone size on the wall and within ``reach`` of it; ``far`` when not refined.
    wall_radius
        Borehole radius; the wall is the cylinder of this radius about the z axis.
    reach
        Width of the band of wall-size zones, and of the band over which the size
        grows back to ``far``.
    """

    far: float
    wall: float | None = None
    wall_radius: float = 0.0
    reach: float = 0.0

    def __post_init__(self) -> None:
        if self.wall is None:
            object.__setattr__(self, "wall", self.far)
        if not 0 < self.wall <= self.far:
            raise ValueError(f"need 0 < wall zone size <= zone size, got {self.wall:g}, "
                             f"{self.far:g}")

    @property
    def uniform(self) -> bool:
        return self.wall == self.far or self.reach <= 0

    @property
    def smallest(self) -> float:
        return self.far if self.uniform else self.wall

    def at(self, points: np.ndarray) -> float:
        """Zone size of an entity whose vertices are ``points`` (k, 3): the size at the
        vertex nearest the borehole axis."""
        if self.uniform:
            return self.far
        return float(self.of_points(points).min())

    def of_points(self, points: np.ndarray) -> np.ndarray:
        """Zone size at each point (k, 3)."""
        if self.uniform:
            return np.full(len(points), self.far)
        d = np.hypot(points[:, 0], points[:, 1]) - self.wall_radius
        grow = np.clip((d - self.reach) / self.reach, 0.0, 1.0)
        return self.wall + (self.far - self.wall) * grow


def as_zone_sizes(zone_size: float | ZoneSizes) -> ZoneSizes:
    """A :class:`ZoneSizes` from a uniform zone size (m) or itself."""
    return zone_size if isinstance(zone_size, ZoneSizes) else ZoneSizes(float(zone_size))


__all__ = ["ZoneSizes", "as_zone_sizes"]

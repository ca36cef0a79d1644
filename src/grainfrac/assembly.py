"""Assembled grain model: a meshed specimen with every micro-property drawn.

``build_assembly`` is the step recipe -> geometry -> assembled model. One seed
fixes everything, through independent random streams (one per concern), so
that e.g. changing the fissure fraction keeps the same grain structure and
mineral map, which is what "the same grain structure" means when the paper
compares HS-only with hybrid runs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from grainfrac import materials
from grainfrac.errors import ConfigError
from grainfrac.geometry.blocks import zone_blocks
from grainfrac.geometry.meshing import GrainMesh, mesh_grains
from grainfrac.geometry.meshing3d import GrainMesh3D, mesh_grains3d
from grainfrac.geometry.solids3d import specimen_solid
from grainfrac.geometry.specimens import (
    SHAPES_2D,
    SHAPES_3D,
    SLAB_THICKNESS_3D_MM,
    DiskSpec,
    HollowCylinderSpec,
    PennySpec,
    RectangleSpec,
    SemiDiskSpec,
    SlabSpec,
    SpecimenShapeSpec,
    outline,
)
from grainfrac.geometry.tessellation import tessellate
from grainfrac.geometry.tessellation3d import TooFewGrains, tessellate3d
from grainfrac.geometry.zone_sizes import ZoneSizes
from grainfrac.io.config import StrictModel, read_toml, source_path, validate
from grainfrac.threads import default_threads
from grainfrac.units import MM

# Named random streams, spawned from the seed in this order (never reorder).
_STREAMS = ("tessellation", "minerals", "grain_weibull", "contact_weibull", "fissures",
            "intragranular_weibull")


class GrainSpec(StrictModel):
    """Grain size and mesh resolution (paper: edges 3-8 mm, zones 2 mm)."""

    min_edge_mm: float = Field(3.0, gt=0, description="shortest grain edge [mm]; < max_edge_mm")
    max_edge_mm: float = Field(8.0, gt=0, description="longest grain edge [mm]")
    zone_size_mm: float = Field(
        2.0, gt=0, description="element (zone) edge length [mm]; <= max_edge_mm")
    lloyd_iterations: int = Field(
        30, ge=0, le=1000, description="Lloyd relaxation steps of the Voronoi seeds")
    wall_zone_size_mm: float = Field(
        0.0, ge=0, description="zone edge on the borehole wall [mm], 3D slabs only; "
        "<= zone_size_mm; 0: zone_size_mm everywhere")
    wall_zone_reach_mm: float = Field(
        5.0, gt=0, le=100, description="band beside the borehole wall meshed at "
        "wall_zone_size_mm [mm]; zones grow back to zone_size_mm over a second band as wide")
    mend_steps: bool = Field(
        True, description="3D only: mend the mesh where it sets a short real-mass "
        "stable step (redraw borehole-ring layers next to short edges; edit grain "
        "interiors until no node's step is below 0.35 of a regular zone's); false: "
        "the plain meshes, quicker to build")

    @model_validator(mode="after")
    def _ordered(self) -> GrainSpec:
        if self.min_edge_mm >= self.max_edge_mm:
            raise ValueError(
                f"min_edge_mm: must be < max_edge_mm ({self.max_edge_mm:g}), "
                f"got {self.min_edge_mm:g}"
            )
        if self.zone_size_mm > self.max_edge_mm:
            raise ValueError(
                f"zone_size_mm: must be <= max_edge_mm ({self.max_edge_mm:g}), "
                f"got {self.zone_size_mm:g}"
            )
        if self.wall_zone_size_mm > self.zone_size_mm:
            raise ValueError(
                f"wall_zone_size_mm: must be <= zone_size_mm ({self.zone_size_mm:g}), "
                f"got {self.wall_zone_size_mm:g}"
            )
        return self


class FissureSpec(StrictModel):
    """Pre-existing defects: a fraction of grain boundaries start unbonded (c = 0, sigma_T = 0)."""

    fraction: float = Field(
        0.0, ge=0, lt=1, description="fraction of grain boundaries that start unbonded [-]")
    clear_radius_mm: float = Field(
        0.0, ge=0, description="no fissure closer than this to the well centre [mm]; 0 without "
        "a borehole, < half the smallest side")


def with_3d_slab_thickness(data):
    """A specimen or scenario table whose 3D slab gets the 3D default thickness if it
    gives none: the 2D slab's default is a plane-strain slice, not a 3D slab."""
    if isinstance(data, dict) and data.get("dimension") == 3:
        spec = data.get("specimen", {"shape": "slab"})
        if isinstance(spec, dict) and spec.get("shape", "slab") == "slab" \
                and "thickness_mm" not in spec:
            data = {**data, "specimen": {**spec, "thickness_mm": SLAB_THICKNESS_3D_MM}}
    return data


class SpecimenConfig(StrictModel):
    """Everything needed to build an assembly: ``grainfrac specimen SPEC.toml``."""

    seed: int = Field(0, ge=0, description="random seed of grains, minerals, Weibull draws")
    dimension: Literal[2, 3] = Field(
        2, description="2: plane-strain slice (triangles); 3: polyhedral grains (tetrahedra)")
    rock: str | materials.RockRecipe = Field(
        "strathbogie-granite", description="rock recipe: a preset name, a TOML path (relative "
        "to the file) or an inline table")
    specimen: SpecimenShapeSpec = Field(
        default_factory=SlabSpec, description="specimen shape and size, chosen by `shape`")
    grains: GrainSpec = Field(default_factory=GrainSpec, description="grain size and mesh")
    fissures: FissureSpec = Field(default_factory=FissureSpec,
                                  description="pre-existing unbonded grain boundaries")

    @model_validator(mode="before")
    @classmethod
    def _slab_thickness_3d(cls, data):
        return with_3d_slab_thickness(data)

    @model_validator(mode="after")
    def _fits(self) -> SpecimenConfig:
        spec = self.specimen
        shapes = SHAPES_3D if self.dimension == 3 else SHAPES_2D
        if spec.shape not in shapes:
            raise ValueError(f"specimen.shape: {spec.shape!r} is not built in {self.dimension}D "
                             f"(one of {', '.join(shapes)})")
        if self.dimension == 3:
            _check_3d(spec, self.grains.zone_size_mm)
        if self.grains.wall_zone_size_mm > 0 and (
                self.dimension != 3 or spec.shape != "slab" or spec.borehole_diameter_mm <= 0):
            raise ValueError(
                "grains.wall_zone_size_mm: only for a 3D slab with a borehole (dimension = 3, "
                f"specimen.shape = 'slab', borehole_diameter_mm > 0); got a {self.dimension}D "
                f"{spec.shape!r}")
        clear = self.fissures.clear_radius_mm
        if clear > 0:
            if getattr(spec, "borehole_diameter_mm", 0.0) <= 0:
                raise ValueError(
                    "fissures.clear_radius_mm: must be 0 for a specimen without a borehole "
                    f"(got {clear:g})"
                )
            limit = (spec.diameter_mm if isinstance(spec, HollowCylinderSpec)
                     else min(spec.width_mm, spec.height_mm)) / 2
            if clear >= limit:
                raise ValueError(
                    f"fissures.clear_radius_mm: must be < half the smallest side ({limit:g} mm)"
                    f" (got {clear:g})"
                )
        return self

    def recipe(self, base_dir: Path | None = None) -> materials.RockRecipe:
        """The rock recipe: inline, a preset name, or a TOML path relative to ``base_dir``."""
        if isinstance(self.rock, materials.RockRecipe):
            return self.rock
        try:
            path = source_path(self.rock, base_dir)
            return materials.load_recipe(path if path is not None else self.rock)
        except ConfigError as exc:
            if exc.field == "recipe":
                raise ConfigError("rock", exc.message) from None
            raise


def _check_3d(spec, zone: float) -> None:
    """What a 3D specimen needs beyond its schema: room for a zone or two across each
    dimension, a notch the mesher can resolve, a cylinder that is one."""
    least: list[tuple[str, float, float]] = []  # (field, value, minimum zones)
    if isinstance(spec, SlabSpec):
        least.append(("thickness_mm", spec.thickness_mm, 1.0))
    elif isinstance(spec, RectangleSpec):
        # The 3D rectangle is the cylinder of which the 2D one is the section.
        if "thickness_mm" in spec.model_fields_set and spec.thickness_mm != spec.width_mm:
            raise ValueError(
                f"specimen.thickness_mm: a 3D rectangle is the cylinder of diameter width_mm "
                f"({spec.width_mm:g} mm); leave thickness_mm out or equal to it, "
                f"got {spec.thickness_mm:g}")
        least += [("width_mm", spec.width_mm, 2.0), ("height_mm", spec.height_mm, 1.0)]
    elif isinstance(spec, DiskSpec):
        least += [("diameter_mm", spec.diameter_mm, 2.0), ("thickness_mm", spec.thickness_mm, 1.0)]
    elif isinstance(spec, SemiDiskSpec):
        least += [("diameter_mm", spec.diameter_mm, 4.0), ("thickness_mm", spec.thickness_mm, 1.0)]
        if spec.notch_length_mm > 0:
            # Shorter walls or a narrower tip would be edges below the mesher's bound.
            least += [("notch_length_mm", spec.notch_length_mm, 1.0),
                      ("notch_width_mm", spec.notch_width_mm, 0.5)]
            if spec.support_span_mm <= spec.notch_width_mm + 2 * zone:
                raise ValueError(
                    f"specimen.support_span_mm: the supports must stand on the base beside the "
                    f"notch (> notch_width_mm + 2 zones = {spec.notch_width_mm + 2 * zone:g} "
                    f"mm), got {spec.support_span_mm:g}")
    elif isinstance(spec, PennySpec):
        least += [("disc_diameter_mm", spec.disc_diameter_mm, 2.0),
                  ("size_mm", spec.size_mm, 4.0)]
    elif isinstance(spec, HollowCylinderSpec):
        least += [("diameter_mm", spec.diameter_mm, 4.0), ("height_mm", spec.height_mm, 1.0),
                  ("borehole_diameter_mm", spec.borehole_diameter_mm, 1.0)]
    for name, value, zones in least:
        if value < zones * zone:
            raise ValueError(
                f"specimen.{name}: must be at least {zones:g} zone{'s' * (zones != 1)} "
                f"({zones * zone:g} mm at zone_size_mm = {zone:g}) in 3D, got {value:g}")


def load_specimen_config(path: str | Path) -> tuple[SpecimenConfig, materials.RockRecipe]:
    """Read and validate a specimen TOML file and resolve its rock recipe."""
    path = Path(path)
    config = validate(SpecimenConfig, read_toml(path))
    return config, config.recipe(path.parent)


@dataclass(frozen=True)
class GrainAssembly:
    """A meshed specimen with materials: the input of every simulation.

    Grain properties are per grain (``grain_*``), grain-boundary properties per
    interface (``interface_*``); the ``element_*`` and ``contact_*`` views map
    them onto elements and sub-contacts. SI units throughout.

    With breakable grains (the recipe's ``intragranular`` section) the mesh's
    "grains" are blocks, each one zone of a grain (:mod:`grainfrac.geometry.blocks`):
    ``grain_*`` arrays are then per block, ``block_grain`` maps blocks to grains
    and the interfaces between blocks of one grain are grain-interior contacts.
    """

    mesh: GrainMesh | GrainMesh3D
    recipe: materials.RockRecipe
    seed: int
    mineral_table: materials.MineralTable
    contact_table: materials.ContactTable
    grain_mineral: np.ndarray
    grain_youngs_modulus: np.ndarray
    grain_poisson_ratio: np.ndarray
    grain_density: np.ndarray
    interface_pair: np.ndarray
    interface_fissure: np.ndarray
    interface_normal_stiffness: np.ndarray
    interface_shear_stiffness: np.ndarray
    interface_friction_angle: np.ndarray
    interface_cohesion: np.ndarray
    interface_tensile_strength: np.ndarray
    interface_tensile_fracture_energy: np.ndarray
    interface_shear_fracture_energy: np.ndarray
    block_grain: np.ndarray | None = None

    @property
    def dimension(self) -> int:
        return 3 if isinstance(self.mesh, GrainMesh3D) else 2

    @property
    def n_grains(self) -> int:
        if self.dimension == 3:
            return self.mesh.grains.n_grains
        if self.block_grain is not None:
            return int(self.block_grain.max()) + 1
        return self.mesh.grains.n_grains

    @property
    def interface_intragranular(self) -> np.ndarray:
        """(f,) True for contacts between blocks of one grain (none if grains never break)."""
        if self.block_grain is None:
            return np.zeros(self.mesh.n_interfaces, dtype=bool)
        ends = self.block_grain[self.mesh.interface_grains]
        return ends[:, 0] == ends[:, 1]

    @property
    def contact_intragranular(self) -> np.ndarray:
        """(c,) True for the sub-contacts of grain-interior contacts."""
        return self.interface_intragranular[self.mesh.contact_interface]

    @property
    def pair_names(self) -> tuple[str, ...]:
        return self.contact_table.pair_names

    @property
    def element_youngs_modulus(self) -> np.ndarray:
        return self.grain_youngs_modulus[self.mesh.element_grain]

    @property
    def element_poisson_ratio(self) -> np.ndarray:
        return self.grain_poisson_ratio[self.mesh.element_grain]

    @property
    def element_density(self) -> np.ndarray:
        return self.grain_density[self.mesh.element_grain]

    @property
    def element_mineral(self) -> np.ndarray:
        return self.grain_mineral[self.mesh.element_grain]

    def contact_view(self, name: str) -> np.ndarray:
        """An ``interface_<name>`` array seen per sub-contact (e.g. ``"tensile_strength"``)."""
        return getattr(self, f"interface_{name}")[self.mesh.contact_interface]

    def volume_fractions(self) -> np.ndarray:
        """Realised mineral volume (area in 2D) fractions, in recipe mineral order."""
        areas = (self.mesh.grain_volumes() if self.dimension == 3
                 else self.mesh.grains.grain_areas())
        n = self.mineral_table.n_minerals
        return np.bincount(self.grain_mineral, weights=areas, minlength=n) / areas.sum()

    def interface_distance_to(self, point: tuple[float, float]) -> np.ndarray:
        """Smallest distance (m) from ``point`` to each grain boundary."""
        return _interface_distance(self.mesh, point)


def _interface_distance(mesh: GrainMesh, point: tuple[float, float]) -> np.ndarray:
    a = mesh.fluid_node_xy[mesh.pipe_nodes[:, 0]]
    b = mesh.fluid_node_xy[mesh.pipe_nodes[:, 1]]
    p = np.asarray(point, dtype=float)
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, axis=1) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    d = np.hypot(*(a + t[:, None] * ab - p).T)
    out = np.full(mesh.n_interfaces, np.inf)
    np.minimum.at(out, mesh.pipe_interface, d)
    return out


def _random_streams(seed: int) -> dict[str, np.random.Generator]:
    return dict(
        zip(
            _STREAMS,
            (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(
                len(_STREAMS))),
            strict=True,
        )
    )


def build_assembly(config: SpecimenConfig, recipe: materials.RockRecipe) -> GrainAssembly:
    """Tessellate, mesh and assign materials.

    Parameters
    ----------
    config
        Validated specimen config (seed, dimension, shape, grain sizes, fissures).
    recipe
        The rock recipe (resolved from ``config.rock``).
    """
    if config.dimension == 3:
        return _build_assembly3d(config, recipe)
    rngs = _random_streams(config.seed)
    zone = config.grains.zone_size_mm * MM
    shape = outline(config.specimen, zone)
    grains = tessellate(
        shape,
        config.grains.min_edge_mm * MM,
        config.grains.max_edge_mm * MM,
        rngs["tessellation"],
        boundary_min_segment=0.4 * zone,
        lloyd_iterations=config.grains.lloyd_iterations,
    )
    mesh = mesh_grains(grains, zone)

    def eligible(clear: float) -> np.ndarray:
        return _interface_distance(mesh, shape.borehole_center) > clear

    grain_level = _with_materials(mesh, grains.grain_areas(), config, recipe, rngs, eligible)
    if recipe.intragranular is None:
        return grain_level
    return _breakable(grain_level, rngs["intragranular_weibull"])


def _build_assembly3d(config: SpecimenConfig, recipe: materials.RockRecipe) -> GrainAssembly:
    """The 3D path: polyhedral grains, tetrahedra, contacts on grain faces
    (:func:`~grainfrac.geometry.solids3d.specimen_solid` gives each shape's solid)."""
    if recipe.intragranular is not None:
        raise ConfigError("rock", "breakable grains (intragranular) are 2D only for now")
    rngs = _random_streams(config.seed)
    g = config.grains
    wall = g.wall_zone_size_mm * MM or None
    solid = specimen_solid(config.specimen, g.zone_size_mm * MM, wall)
    zone = ZoneSizes(g.zone_size_mm * MM, wall, float(solid.borehole_radius),
                     g.wall_zone_reach_mm * MM)
    try:
        cx = tessellate3d(solid, config.grains.min_edge_mm * MM,
                          config.grains.max_edge_mm * MM, zone, rngs["tessellation"],
                          ring_repair=g.mend_steps)
    except TooFewGrains as exc:
        raise ConfigError("grains.max_edge_mm", str(exc)) from None
    mesh = mesh_grains3d(cx, zone, rngs["tessellation"],
                         (config.grains.min_edge_mm * MM, config.grains.max_edge_mm * MM),
                         mend_steps=g.mend_steps, threads=default_threads())

    def eligible(clear: float) -> np.ndarray:
        return interface_axis_distance(mesh) > clear

    return _with_materials(mesh, mesh.grain_volumes(), config, recipe, rngs, eligible)


def interface_axis_distance(mesh: GrainMesh3D) -> np.ndarray:
    """Smallest distance (m) from the borehole axis (z through the origin) to each grain
    interface, over its sub-contact points."""
    r = np.hypot(mesh.contact_x[:, 0], mesh.contact_x[:, 1])
    out = np.full(mesh.n_interfaces, np.inf)
    np.minimum.at(out, mesh.contact_interface, r)
    return out


def _with_materials(mesh, grain_measure, config, recipe, rngs, eligible) -> GrainAssembly:
    """Minerals by measure (area in 2D, volume in 3D), Weibull draws and fissures.

    Shared by both dimensions; each concern draws from its own stream, so the
    2D numbers are those of the code before the 3D path existed.
    """
    mtab = materials.mineral_table(recipe)
    ctab = materials.contact_table(recipe)
    mineral = materials.assign_minerals(grain_measure, mtab.volume_fraction, rngs["minerals"])
    g_draw = {
        name: materials.weibull_draw(getattr(mtab, name)[mineral], rngs["grain_weibull"],
                                     recipe.weibull, materials.WEIBULL_UPPER_BOUNDS.get(name))
        for name in materials.WEIBULL_GRAIN_PROPERTIES
    }
    pair = materials.pair_index(
        mineral[mesh.interface_grains[:, 0]], mineral[mesh.interface_grains[:, 1]],
        mtab.n_minerals,
    )
    c_draw = {
        name: materials.weibull_draw(getattr(ctab, name)[pair], rngs["contact_weibull"],
                                     recipe.weibull, materials.WEIBULL_UPPER_BOUNDS.get(name))
        for name in materials.WEIBULL_CONTACT_PROPERTIES
    }

    fissure = np.zeros(mesh.n_interfaces, dtype=bool)
    if config.fissures.fraction > 0:
        clear = config.fissures.clear_radius_mm * MM
        ok = np.ones(mesh.n_interfaces, dtype=bool)
        if clear > 0:
            ok = eligible(clear)
        fissure = materials.select_fissures(
            mesh.n_interfaces, config.fissures.fraction, ok, rngs["fissures"]
        )
    cohesion = np.where(fissure, 0.0, c_draw["cohesion_Pa"])
    tensile = np.where(fissure, 0.0, c_draw["tensile_strength_Pa"])

    return GrainAssembly(
        mesh=mesh,
        recipe=recipe,
        seed=config.seed,
        mineral_table=mtab,
        contact_table=ctab,
        grain_mineral=mineral,
        grain_youngs_modulus=g_draw["youngs_modulus_Pa"],
        grain_poisson_ratio=g_draw["poisson_ratio"],
        grain_density=g_draw["density_kg_m3"],
        interface_pair=pair,
        interface_fissure=fissure,
        interface_normal_stiffness=c_draw["normal_stiffness_Pa_per_m"],
        interface_shear_stiffness=c_draw["shear_stiffness_Pa_per_m"],
        interface_friction_angle=c_draw["friction_angle_rad"],
        interface_cohesion=cohesion,
        interface_tensile_strength=tensile,
        # Fracture energies are the table values: the Weibull scatter of the
        # strengths already spreads the softening displacements 2 G / strength.
        interface_tensile_fracture_energy=np.where(
            fissure, 0.0, ctab.tensile_fracture_energy_J_per_m2[pair]),
        interface_shear_fracture_energy=np.where(
            fissure, 0.0, ctab.shear_fracture_energy_J_per_m2[pair]),
    )


_INTERFACE_FIELDS = {
    "normal_stiffness_Pa_per_m": "normal_stiffness",
    "shear_stiffness_Pa_per_m": "shear_stiffness",
    "friction_angle_rad": "friction_angle",
    "cohesion_Pa": "cohesion",
    "tensile_strength_Pa": "tensile_strength",
}


def _breakable(grains: GrainAssembly, rng: np.random.Generator) -> GrainAssembly:
    """``grains`` with every zone a block: grain boundaries keep their drawn
    properties, grain-interior contacts get the like pair's times the recipe's
    ``intragranular`` factors, drawn from their own Weibull stream."""
    recipe, ctab = grains.recipe, grains.contact_table
    spec = recipe.intragranular
    block_map, block_grain = zone_blocks(grains.mesh)
    mesh = mesh_grains(block_map, grains.mesh.zone_size)
    ends = block_grain[mesh.interface_grains]
    inside = ends[:, 0] == ends[:, 1]
    boundary_of = {(int(a), int(b)): i for i, (a, b) in enumerate(grains.mesh.interface_grains)}
    source = np.array([0 if same else boundary_of[(min(a, b), max(a, b))]
                       for (a, b), same in zip(ends.tolist(), inside, strict=True)],
                      dtype=np.int64)
    mineral = grains.grain_mineral[ends[:, 0]]
    like = materials.pair_index(mineral, mineral, grains.mineral_table.n_minerals)
    factor = {"normal_stiffness_Pa_per_m": spec.stiffness_factor,
              "shear_stiffness_Pa_per_m": spec.stiffness_factor,
              "cohesion_Pa": spec.cohesion_factor,
              "tensile_strength_Pa": spec.tensile_strength_factor}
    values = {}
    for name in materials.WEIBULL_CONTACT_PROPERTIES:
        interior = materials.weibull_draw(getattr(ctab, name)[like] * factor.get(name, 1.0), rng,
                                          recipe.weibull, materials.WEIBULL_UPPER_BOUNDS.get(name))
        boundary = getattr(grains, f"interface_{_INTERFACE_FIELDS[name]}")[source]
        values[_INTERFACE_FIELDS[name]] = np.where(inside, interior, boundary)
    for mode in ("tensile", "shear"):
        interior = getattr(ctab, f"{mode}_fracture_energy_J_per_m2")[like]
        boundary = getattr(grains, f"interface_{mode}_fracture_energy")[source]
        values[f"{mode}_fracture_energy"] = np.where(
            inside, spec.fracture_energy_factor * interior, boundary)
    return replace(
        grains,
        mesh=mesh,
        grain_mineral=grains.grain_mineral[block_grain],
        grain_youngs_modulus=grains.grain_youngs_modulus[block_grain],
        grain_poisson_ratio=grains.grain_poisson_ratio[block_grain],
        grain_density=grains.grain_density[block_grain],
        interface_pair=np.where(inside, like, grains.interface_pair[source]),
        interface_fissure=~inside & grains.interface_fissure[source],
        block_grain=block_grain,
        **{f"interface_{k}": v for k, v in values.items()},
    )


def build_specimen(config: dict | None = None) -> GrainAssembly:
    """Validate a specimen config (the content of a specimen TOML, as a dict) and build it.

    ``build_specimen()`` is the default slab; ``build_specimen({"specimen":
    {"shape": "disk"}, "seed": 3})`` a Brazilian disk. Errors are one-line
    :class:`~grainfrac.errors.ConfigError` raised before any compute.
    """
    cfg = validate(SpecimenConfig, config or {})
    return build_assembly(cfg, cfg.recipe())

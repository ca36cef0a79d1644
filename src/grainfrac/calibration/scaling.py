"""A recipe at a set of calibration factors: Table 2 times the factors, and the
starting fracture energies from Irwin's relation of the targets.
"""

from __future__ import annotations

import math

from grainfrac import materials
from grainfrac.calibration.config import FACTORS, CalibrationConfig, Targets
from grainfrac.io.config import validate
from grainfrac.units import GPA, MPA

__all__ = [
    "irwin_fracture_energy",
    "scaled_recipe",
]


def scaled_recipe(recipe: materials.RockRecipe, factors: dict[str, float], *,
                  initial_aperture_m: float | None = None,
                  name: str | None = None) -> materials.RockRecipe:
    """``recipe`` with the calibration factors applied (see the module table)."""
    data = recipe.model_dump(mode="json")
    f = {k: float(factors.get(k, 1.0)) for k in FACTORS}
    for mineral in data["minerals"]:
        mineral["youngs_modulus_GPa"] *= f["stiffness"]
        mineral["poisson_ratio"] *= f["grain_poisson_ratio"]
    strength = f["strength"] * f["strength_scale"]
    for contact in data["contacts"].values():
        contact["normal_stiffness_GPa_per_m"] *= f["stiffness"]
        contact["shear_stiffness_GPa_per_m"] *= f["stiffness"] * f["shear_ratio"]
        contact["tensile_strength_MPa"] *= strength * f["tensile_strength"]
        contact["cohesion_MPa"] *= strength * f["cohesion"]
        tan_phi = f["friction"] * math.tan(math.radians(contact["friction_angle_deg"]))
        contact["friction_angle_deg"] = math.degrees(math.atan(tan_phi))
        # Grain interiors follow their like pair, so they scale with it.
        energy = f["fracture_energy"] * f["strength_scale"] ** 2
        contact["tensile_fracture_energy_J_per_m2"] *= energy
        contact["shear_fracture_energy_J_per_m2"] *= energy * f["shear_fracture_energy"]
    if data.get("intragranular") is not None:
        data["intragranular"]["tensile_strength_factor"] *= f["grain_tensile_strength"]
        data["intragranular"]["cohesion_factor"] *= f["grain_cohesion"]
    if initial_aperture_m is not None:
        data["hydraulic"]["initial_aperture_m"] = initial_aperture_m
    if name is not None:
        data["name"] = name
    return validate(materials.RockRecipe, data)


def irwin_fracture_energy(targets: Targets) -> float:
    """Irwin's G_I = K_IC^2 (1 - nu^2) / E of the laboratory targets (J/m^2, plane strain)."""
    return ((targets.kic_MPa_sqrt_m * MPA) ** 2 * (1.0 - targets.poisson_ratio ** 2)
            / (targets.youngs_modulus_GPa * GPA))


def _with_start_fracture_energy(recipe: materials.RockRecipe, config: CalibrationConfig
                                ) -> materials.RockRecipe:
    """A brittle recipe gets Irwin's G_I of the targets (and G_II) on every pair."""
    if any(c.tensile_fracture_energy_J_per_m2 > 0 for c in recipe.contacts.values()):
        return recipe
    g_tensile = irwin_fracture_energy(config.targets)
    g_shear = config.shear_to_tensile_fracture_energy * g_tensile
    data = recipe.model_dump(mode="json")
    # Every pair explicitly: mixed pairs would otherwise average like pairs only.
    data["contacts"] = {name: {**recipe.contact(name).model_dump(mode="json"),
                               "tensile_fracture_energy_J_per_m2": g_tensile,
                               "shear_fracture_energy_J_per_m2": g_shear}
                        for name in recipe.pair_names()}
    return validate(materials.RockRecipe, data)

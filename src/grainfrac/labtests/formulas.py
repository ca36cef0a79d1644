"""Closed-form data reduction of the laboratory tests (paper Eqs. 5-8).

All inputs and outputs SI. These are the standard formulas a lab applies to
its measured peak loads; the virtual tests apply them to the model's.
"""

from __future__ import annotations

import math

import numpy as np


def brazilian_tensile_strength(peak_load: float, diameter: float, thickness: float) -> float:
    """Indirect tensile strength sigma_t = 2 P / (pi D T) (paper Eq. 5), Pa."""
    return 2.0 * peak_load / (math.pi * diameter * thickness)


def nscb_geometry_factor(support_span: float, radius: float, notch_length: float) -> float:
    """Dimensionless stress intensity factor Y' of the NSCB test (Kuruppu et al. 2014).

    ``Y' = -1.297 + 9.516 (s/R) - (0.47 + 16.457 (s/R)) beta
    + (1.071 + 34.401 (s/R)) beta^2`` with ``s`` the HALF-distance between the
    supports and ``beta = a / R``. The paper's Eq. (7) prints ``s / 2R`` and
    ``2A / D``: the same numbers when its ``s`` is the full span S (40 mm), as
    Table 3 lists it (S / 2R = 0.8 = s / R). This ISRM form is used; it was
    fitted for 0.5 <= s/R <= 0.8 and beta <= 0.5.
    """
    ratio = 0.5 * support_span / radius
    beta = notch_length / radius
    return (-1.297 + 9.516 * ratio - (0.47 + 16.457 * ratio) * beta
            + (1.071 + 34.401 * ratio) * beta**2)


def nscb_fracture_toughness(peak_load: float, radius: float, thickness: float,
                            notch_length: float, support_span: float) -> float:
    """Mode-I fracture toughness K_IC = Y' P sqrt(pi a) / (2 R B) (paper Eq. 6), Pa m^0.5."""
    y = nscb_geometry_factor(support_span, radius, notch_length)
    return y * peak_load * math.sqrt(math.pi * notch_length) / (2.0 * radius * thickness)


def darcy_permeability(flow_rate: float, viscosity: float, length: float, area: float,
                       pressure_drop: float) -> float:
    """Permeability k = Q mu H / (A dP) of a constant-head test (paper Eq. 8), m2."""
    return flow_rate * viscosity * length / (area * pressure_drop)


def plane_strain_to_isotropic(apparent_modulus: float, apparent_ratio: float,
                              ) -> tuple[float, float]:
    """E and nu of the isotropic solid whose plane-strain uniaxial response was measured.

    In plane strain with one free side, eps_axial = sigma (1 - nu^2) / E and
    eps_lateral / eps_axial = -nu / (1 - nu): so nu = nu' / (1 + nu') and
    E = E' (1 - nu^2). This is what a 3D (cylinder) test of the same solid
    reports, and what Table 3's E and nu are.
    """
    nu = apparent_ratio / (1.0 + apparent_ratio)
    return apparent_modulus * (1.0 - nu**2), nu


def slope_between(x: np.ndarray, y: np.ndarray, low: float, high: float, *,
                  by: np.ndarray | None = None, upto: int | None = None) -> float:
    """Least-squares slope dy/dx over the samples with ``low <= by <= high``
    (``by`` defaults to ``y``; only the first ``upto`` samples: the loading
    branch before the peak)."""
    x = np.asarray(x, dtype=float)[:upto]
    y = np.asarray(y, dtype=float)[:upto]
    key = y if by is None else np.asarray(by, dtype=float)[:upto]
    sel = (key >= low) & (key <= high)
    if np.count_nonzero(sel) < 3:
        raise ValueError(f"too few samples between {low:g} and {high:g} to fit a slope "
                         f"({np.count_nonzero(sel)}); sample more often")
    return float(np.polyfit(x[sel], y[sel], 1)[0])

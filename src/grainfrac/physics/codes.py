"""What the integer codes in the outputs mean, and the one sign convention of the outputs.

One source for ``legend.json``, the field data of every ``.vtu`` snapshot, the
``sign_convention`` of ``summary.json`` and the figures' labels
(docs/outputs.md).

Every stress and pressure a user reads (snapshots, tables, summary, figures) is
**compression positive**, as in the paper's figures and the rock-mechanics habit.
The mechanics inside keeps the tension-positive stress of continuum mechanics
(:mod:`grainfrac.physics.records`); the writers turn it round at the edge with
:func:`to_output_stress`.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.physics.kernels import SHEAR, TENSILE

MODE_NAMES = {TENSILE: "tensile", SHEAR: "shear"}

#: The sign convention of every stress and pressure in the outputs.
SIGN_CONVENTION = "compression positive"
#: How figures say it next to a stress axis or colour bar.
SIGN_LABEL = "compression +"

#: Per quantity in the outputs, its sign (all stresses and pressures: SIGN_CONVENTION).
SIGN_CONVENTIONS = {
    "grain stress (stress_compression_positive_Pa in grains_NNNN.vtu and scda_NNNN.vtu)":
        SIGN_CONVENTION,
    "contact normal stress (normal_stress_Pa)": SIGN_CONVENTION,
    "contact shear stress (shear_stress_Pa)": "signed along the contact tangent (the normal "
                                              "turned +90 degrees)",
    "contact opening (opening_m)": "opening positive (a displacement, not a stress)",
    "SCDA pressure (pressure_Pa, expansive_pressure_Pa, expansive_pressure_MPa)":
        SIGN_CONVENTION,
    "in-situ stresses (config.toml stress)": SIGN_CONVENTION + " (compressive magnitudes)",
    "tangential_stress_near_well_MPa (history.csv)": SIGN_CONVENTION,
    "fluid pressure (pressure_Pa, well_pressure_MPa)": SIGN_CONVENTION + " (a pressure)",
    "figures (minor_principal_stress.png, pressures.png, well_pressure.png)": SIGN_CONVENTION,
}


def to_output_stress(stress: np.ndarray) -> np.ndarray:
    """The mechanics' tension-positive stress as the outputs give it (compression positive)."""
    return -np.asarray(stress)


def code_tables(assembly: GrainAssembly) -> dict[str, dict[str, str]]:
    """The names of the integer codes in the run's files, by code (as strings)."""
    return {
        "mineral": {str(i): name for i, name in enumerate(assembly.mineral_table.names)},
        "contact_type": {str(i): name for i, name in enumerate(assembly.pair_names)},
        "mode": {"0": "intact", **{str(k): v for k, v in MODE_NAMES.items()}},
        "failed": {"0": "intact", "1": "broken (tensile or shear)"},
        "fissure": {"0": "bonded grain boundary", "1": "pre-existing fissure"},
    }


def file_metadata(assembly: GrainAssembly) -> dict[str, Any]:
    """What every snapshot carries as field data: the code tables and the sign convention."""
    return {"codes": code_tables(assembly), "sign_convention": SIGN_CONVENTION,
            "sign_conventions": SIGN_CONVENTIONS}


def metadata_bytes(assembly: GrainAssembly) -> np.ndarray:
    """:func:`file_metadata` as UTF-8 JSON bytes (a UInt8 array: what meshio and ParaView
    both read; ``bytes(array).decode()`` gives the JSON back)."""
    text = json.dumps(file_metadata(assembly), sort_keys=True)
    return np.frombuffer(text.encode("utf-8"), dtype=np.uint8)

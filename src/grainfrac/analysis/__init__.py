"""Post-processing of simulation results: breakdown, fractures, crack statistics.

Every function takes plain arrays in SI units, so the analysis runs on a run
directory's CSV files as well as on in-memory results. Data flows one way:
this package never imports from the simulation driver.
"""

from grainfrac.analysis.breakdown import (
    BreakdownResult,
    breakdown,
    breakdown_summary,
    max_drop_rate,
    pressure_drop_after_peak,
)
from grainfrac.analysis.fractures import (
    CONNECT_FACTOR,
    FracturePath,
    RadialFractures,
    connected_clusters,
    contact_fractions,
    crack_counts,
    energy_split,
    fracture_summary,
    fracture_tortuosity,
    main_fracture_path,
    radial_fractures,
    tortuosity,
)
from grainfrac.analysis.rundir import analyse_run
from grainfrac.physics.fields import (
    major_principal_stress,
    minor_principal_stress,
    ring_mean_tangential_stress,
    tangential_stress,
)

__all__ = [
    "analyse_run",
    "major_principal_stress",
    "minor_principal_stress",
    "ring_mean_tangential_stress",
    "tangential_stress",
    "CONNECT_FACTOR",
    "BreakdownResult",
    "FracturePath",
    "RadialFractures",
    "breakdown",
    "breakdown_summary",
    "connected_clusters",
    "contact_fractions",
    "crack_counts",
    "energy_split",
    "fracture_summary",
    "fracture_tortuosity",
    "main_fracture_path",
    "max_drop_rate",
    "pressure_drop_after_peak",
    "radial_fractures",
    "tortuosity",
]

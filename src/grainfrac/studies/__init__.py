"""Studies: parameter sweeps and ensembles on Dask, and the paper's study matrix.

``sweep`` plans and runs sweeps (``grainfrac sweep``); ``stats`` has the
ensemble statistics (mean, std, Student-t intervals); ``paper`` builds the
paper's studies as sweeps and decides its claims; ``report`` writes the
reproduction report. Studies sit at the end of the data flow: they import
scenario, simulation and analysis, never the reverse.
"""

from grainfrac.studies.sweep import (
    SweepConfig,
    SweepError,
    SweepPlan,
    SweepResult,
    load_sweep,
    plan_sweep,
    run_sweep,
    run_sweeps,
)

__all__ = ["SweepConfig", "SweepError", "SweepPlan", "SweepResult", "load_sweep", "plan_sweep",
           "run_sweep", "run_sweeps"]

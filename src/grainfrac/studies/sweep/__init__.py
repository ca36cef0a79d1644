"""Parameter sweeps and ensembles on Dask: ``grainfrac sweep SWEEP.toml --out DIR``.

A sweep is a base scenario, the points to run it at and the realisations
(grain structures) per point. ``SWEEP.toml``::

    name = "hs-rate"
    base = "../hs-case2-18mlmin.toml"    # a scenario file (relative to this file) or a [base] table
    realisations = 3                     # realisation r uses seed = the point's seed + r
    # seeds = [0, 7, 11]                 # ... or a listed set of seeds
    combine = "grid"                     # "grid": every combination; "zip": i-th with i-th
    set = { "output.snapshot_every_ms" = 10.0 }   # applied at every point

    [[parameters]]                       # any dotted path into the scenario
    path = "stages.1.rate_ml_per_min"
    values = [18.0, 42.0, 66.0]

    [[parameters]]
    path = "stages.1.duration_ms"
    values = [40.0, 17.1, 10.9]

Instead of ``parameters``, explicit ``[[points]]`` may each name an ``id``, their
own ``base`` and the paths they ``set``. Paths are checked against the scenario
schema and every point's scenario is validated before any compute: an unknown
path or a bad value is one :class:`~grainfrac.errors.ConfigError` naming the
sweep field (``parameters.0.path``, ``parameters.1.values.2``, ``points.3.set``).

Setting ``stress.case`` replaces the base's stress values; setting
``stress.sigma_x_MPa`` / ``sigma_y_MPa`` / ``sigma_z_MPa`` alone drops the base's
case and keeps its other values. Paths into ``rock`` or an SCDA stage's ``scda`` write the
preset inline first, so ``rock.weibull.shape`` can be varied.

Output directory::

    DIR/runs/<point-id>/r<k>/   one run directory per realisation (grainfrac run layout)
    DIR/runs.csv                one row per run: point, realisation, seed, status, the
                                point's parameter values, wall time, every summary value
    DIR/stats.csv               one row per point and quantity: n, mean, std (ddof 1),
                                95 % Student-t CI
    DIR/runs.parquet, DIR/stats.parquet   the same, only if pyarrow is importable
    DIR/sweep.json              the plan (points, values, seeds) and the last invocation

A run is done when its ``summary.json`` (written atomically, last) is valid
and its ``config.toml`` is the planned scenario; re-running a sweep skips done
runs and resumes a run that has a checkpoint. A finished run of a *different*
scenario at a planned place is an error, never silently reused. The tables
are rebuilt from the run directories alone, so a worker that dies (Dask
reschedules its task; ``retries`` covers exceptions) can neither lose nor
duplicate a row, and the same sweep and seeds always give the same tables.

The package's modules, one job each:

* ``sweep.config``: the ``SWEEP.toml`` schema;
* ``sweep.plan``: the planned points and runs, built and validated before any compute;
* ``sweep.runs``: one run directory's state and the Dask task that runs it;
* ``sweep.execute``: running sweeps on Dask;
* ``sweep.tables``: the tables and the plan file, rebuilt from the run directories.

Every public name is importable from ``grainfrac.studies.sweep`` itself.
"""

from __future__ import annotations

from grainfrac.studies.sweep.config import GROUPED_QUANTITIES as GROUPED_QUANTITIES
from grainfrac.studies.sweep.config import SCALAR_QUANTITIES as SCALAR_QUANTITIES
from grainfrac.studies.sweep.config import AxisSpec, PointSpec, SweepConfig
from grainfrac.studies.sweep.execute import (
    DaskSession,
    SweepError,
    SweepProgress,
    run_sweep,
    run_sweeps,
)
from grainfrac.studies.sweep.plan import (
    PlannedRun,
    SweepPlan,
    SweepPoint,
    apply_overrides,
    check_path,
    load_sweep,
    plan_sweep,
)
from grainfrac.studies.sweep.runs import FAILED_FILE as FAILED_FILE
from grainfrac.studies.sweep.runs import execute_run, read_summary, run_state
from grainfrac.studies.sweep.tables import PLAN_FILE as PLAN_FILE
from grainfrac.studies.sweep.tables import RUNS_TABLE as RUNS_TABLE
from grainfrac.studies.sweep.tables import STATS_TABLE as STATS_TABLE
from grainfrac.studies.sweep.tables import (
    SweepResult,
    collect,
    flatten_summary,
    write_tables,
)

__all__ = [
    "AxisSpec", "DaskSession", "PlannedRun", "PointSpec", "SweepConfig", "SweepError",
    "SweepPlan", "SweepPoint", "SweepProgress", "SweepResult", "apply_overrides", "check_path",
    "collect", "execute_run", "flatten_summary", "load_sweep", "plan_sweep", "read_summary",
    "run_state", "run_sweep", "run_sweeps", "write_tables",
]

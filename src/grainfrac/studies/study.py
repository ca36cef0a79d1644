"""``grainfrac study paper``: plan every study, run all sweeps on one cluster, report.

Output directory::

    DIR/<study>/           one sweep directory per study (runs/, runs.csv, stats.csv)
    DIR/figures/<study>.png
    DIR/claims.csv, DIR/claims.json, DIR/report.md, DIR/report.html

Every scenario of every study is validated before any compute; runs already
done in DIR are skipped, so an interrupted study continues where it stopped
and a larger ``--realisations`` adds realisations to the ones there.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from grainfrac.studies.paper import Study, plan_studies, select
from grainfrac.studies.report import StudyOutcome, build_reproduction_report, decide
from grainfrac.studies.sweep import SweepProgress, run_sweeps


@dataclass
class StudyRun:
    """What ``run_paper_study`` did: outcomes per study and the files it wrote."""

    outcomes: list[StudyOutcome]
    files: list[Path]
    wall_time_s: float

    @property
    def failures(self) -> dict[str, str]:
        return {f"{o.study.name}/{k}": v for o in self.outcomes
                for k, v in o.result.failures.items()}

    @property
    def runs_computed(self) -> int:
        return sum(o.result.computed for o in self.outcomes)


def run_studies(studies: Sequence[Study], out: str | Path, *, realisations: int = 10,
                examples: str | Path | None = None, scheduler: Any = None,
                n_workers: int | None = None,
                progress: Callable[[SweepProgress], None] | None = None) -> StudyRun:
    """Plan ``studies``, run all their sweeps on one cluster, decide the claims, report."""
    out = Path(out)
    start = time.perf_counter()
    planned = plan_studies(studies, realisations, examples)
    results = run_sweeps([(plan, out / study.name) for study, plan in planned],
                         scheduler=scheduler, n_workers=n_workers, progress=progress)
    outcomes = [decide(study, result) for (study, _), result in zip(planned, results,
                                                                     strict=True)]
    wall = time.perf_counter() - start
    files = build_reproduction_report(outcomes, out, realisations=realisations,
                                      wall_time_s=wall)
    return StudyRun(outcomes, files, wall)


def run_paper_study(out: str | Path, *, realisations: int = 10,
                    only: Sequence[str] | None = None, examples: str | Path | None = None,
                    scheduler: Any = None, n_workers: int | None = None,
                    progress: Callable[[SweepProgress], None] | None = None,
                    dimensions: Sequence[int] = (2,)) -> StudyRun:
    """Run the paper's study matrix (or the studies in ``only``) in ``dimensions`` and
    write the report."""
    return run_studies(select(only, dimensions), out, realisations=realisations, examples=examples,
                       scheduler=scheduler, n_workers=n_workers, progress=progress)


__all__ = ["StudyRun", "run_paper_study", "run_studies"]

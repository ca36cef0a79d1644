"""Kill a run from its progress callback in a given stage, then resume it.

Shared by the resume tests (``test_simulation.py``, ``test_scda.py``,
``test_hydromechanics3d.py``).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from grainfrac.simulation import run_scenario


class Killed(Exception):
    """Raised from the progress callback: the run stops as if killed."""


def killed_then_resumed(scenario, out: Path, stage_kind: str, at_call: int) -> dict:
    """Run ``scenario`` into ``out``, kill it at the ``at_call``-th progress call of its
    ``stage_kind`` stage (checking that it got that far and wrote no summary), resume it
    from its last checkpoint and return the resumed run's summary."""
    calls = {"n": 0}

    def kill(progress):
        if progress.stage_kind == stage_kind:
            calls["n"] += 1
            if calls["n"] == at_call:
                raise Killed

    with pytest.raises(Killed):
        run_scenario(scenario, scenario.recipe(), out, progress=kill)
    assert not (out / "summary.json").exists()
    return run_scenario(scenario, scenario.recipe(), out, resume=True)


def comparable(summary: dict) -> dict:
    """A summary less what differs between identical runs (the wall time)."""
    return {k: v for k, v in summary.items() if k != "wall_time_s"}

"""The one loop every run goes through: stages in order, a chunk at a time.

Scenarios (:mod:`grainfrac.run`), lab tests (:mod:`grainfrac.labtests`) and the
verification cases (:mod:`grainfrac.verification`) all hand their stages to a
:class:`Driver`. What happens between chunks (history rows, snapshots,
checkpoints, progress) is the caller's, through :class:`Hooks`; the driver
knows nothing of files.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from grainfrac.stages.base import Stage
from grainfrac.stages.world import World


@dataclass
class DriverState:
    """Where the driver is: the stage it is in, whether that stage has begun, and
    whether every stage has finished. A checkpoint saves it with the stages' own."""

    stage_index: int = 0
    begun: bool = False
    done: bool = False


class Hooks:
    """What the driver calls around the chunks; these defaults do nothing."""

    def after_chunk(self, stage: Stage) -> None:
        """After every ``advance`` (the stage may have finished)."""

    def after_stage(self, stage: Stage) -> None:
        """After a stage finished; the driver already points at the next one."""

    def between_chunks(self) -> None:
        """After a chunk that did not finish its stage."""

    def at_end(self) -> None:
        """After the last stage."""


class Driver:
    """Runs ``stages`` on ``world``; resumes from ``state`` if given."""

    def __init__(self, stages: Sequence[Stage], world: World, hooks: Hooks | None = None,
                 state: DriverState | None = None):
        self.stages = list(stages)
        self.world = world
        self.hooks = hooks if hooks is not None else Hooks()
        self.state = state if state is not None else DriverState()

    @property
    def current(self) -> Stage | None:
        """The stage being run (None once all have finished)."""
        i = self.state.stage_index
        return self.stages[i] if i < len(self.stages) else None

    def execute(self) -> None:
        """Run (or continue) every stage to its end."""
        st = self.state
        while st.stage_index < len(self.stages):
            stage = self.stages[st.stage_index]
            if not st.begun:
                stage.begin(self.world)
                st.begun = True
            stage.advance(self.world)
            self.hooks.after_chunk(stage)
            if stage.finished():
                st.stage_index += 1
                st.begun = False
                self.hooks.after_stage(stage)
            else:
                self.hooks.between_chunks()
        st.done = True
        self.hooks.at_end()

"""What a stage is: one part of a run that the driver advances a chunk at a time.

A stage is an object with four hooks (pyro2 style: the driver owns the loop,
the stage supplies the physics):

``begin(world)``
    Once, when the stage starts (not again when a run resumes inside it).
``advance(world)``
    One chunk of work: a few hundred mechanical steps, one fluid step, one
    loading sample. Fixed chunks make a resumed run retrace an uninterrupted one.
``finished()``
    Whether the stage has ended (after the last ``advance``).
``state``
    The stage's own evolving values as a dataclass record of plain scalars;
    a checkpoint writes it field by field and a resumed run loads it back.

``kind`` names the stage in histories and summaries, ``fraction()`` says how
far it has got (0 to 1, for progress displays) and ``periodic_snapshots``
whether the run writes snapshots between its chunks.
"""

from __future__ import annotations

from typing import Any, Protocol

from grainfrac.stages.world import World


class Stage(Protocol):
    """The hooks a :class:`~grainfrac.stages.driver.Driver` calls."""

    kind: str
    periodic_snapshots: bool
    state: Any  # a dataclass of scalars

    def begin(self, world: World) -> None: ...

    def advance(self, world: World) -> None: ...

    def finished(self) -> bool: ...

    def fraction(self) -> float: ...

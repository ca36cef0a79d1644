"""The output section of a scenario: snapshot and checkpoint intervals.
"""

from __future__ import annotations

from pydantic import Field

from grainfrac.io.config import StrictModel

__all__ = [
    "MAX_CHECKPOINT_EVERY_STEPS",
    "OutputSpec",
]


# More steps than any stage's limit allows (MAX_STAGE_MS at the default slab's step).
MAX_CHECKPOINT_EVERY_STEPS = 10**9


class OutputSpec(StrictModel):
    """What a run writes besides histories and the crack catalogue."""

    snapshot_every_ms: float = Field(1.0, gt=0, description="ParaView snapshot interval [ms]")
    checkpoint_every_minutes: float = Field(5.0, gt=0, description="checkpoint interval [min]")
    checkpoint_every_steps: int | None = Field(
        None, ge=1, le=MAX_CHECKPOINT_EVERY_STEPS,
        description="also checkpoint every N mechanical steps (checked between chunks, "
                    "so at the first chunk end at or after N steps); unset: by wall clock "
                    f"and at stage ends only; 1 to {MAX_CHECKPOINT_EVERY_STEPS:.0e}")

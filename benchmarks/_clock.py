"""Wall time spent in wrapped functions, by label (shared by the run benchmarks)."""

from __future__ import annotations

import time
from collections import defaultdict


class Clock:
    """Wall time (s) spent in wrapped functions, by label.

    ``wrap(owner, name, label)`` replaces ``owner.name`` by a timed call; ``restore()``
    puts the originals back. A call nested in another wrapped call counts in both.
    """

    def __init__(self):
        self.seconds: dict[str, float] = defaultdict(float)
        self._undo: list = []

    def wrap(self, owner, name: str, label: str) -> None:
        original = getattr(owner, name)

        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                self.seconds[label] += time.perf_counter() - start

        setattr(owner, name, timed)
        self._undo.append((owner, name, original))

    def restore(self) -> None:
        for owner, name, original in reversed(self._undo):
            setattr(owner, name, original)
        self._undo.clear()

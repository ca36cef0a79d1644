"""Comparison rows shared by every verification case (docs/outputs.md, ``grainfrac verify``).

A verification case returns a list of :class:`Comparison`: one simulated scalar
next to its analytical (or reference) value and a relative tolerance.
``grainfrac verify NAME --json`` prints :meth:`Comparison.as_row` of each, one
JSON object per line, with exactly the keys in :data:`ROW_KEYS`. Values are
in the user-facing units named at the end of the quantity (``..._MPa``,
``..._um``), as the rest of the user edge.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from rich.console import Console
from rich.table import Table

ROW_KEYS = ("case", "quantity", "simulated", "analytical", "relative_error", "tolerance",
            "passed")


@dataclass(frozen=True)
class Comparison:
    """One simulated quantity against its analytical value.

    Attributes
    ----------
    case : str
        Verification case name (``kirsch``, ``lame``, ``cubic-law``, ...).
    quantity : str
        What is compared, with its unit at the end (``hoop_stress_wall_0deg_MPa``).
    simulated, analytical : float
        The two values, in the unit named in ``quantity``.
    tolerance : float
        Largest accepted relative error (0.1 = 10 %).
    """

    case: str
    quantity: str
    simulated: float
    analytical: float
    tolerance: float

    @property
    def relative_error(self) -> float:
        """``|simulated - analytical| / |analytical|``.

        When the analytical value is exactly 0 the absolute difference is
        returned instead (a case comparing against zero sets its tolerance in
        the quantity's unit and says so). NaN when the simulated value is not finite.
        """
        diff = abs(float(self.simulated) - float(self.analytical))
        if self.analytical == 0:
            return diff
        return diff / abs(float(self.analytical))

    @property
    def passed(self) -> bool:
        """Finite and within tolerance."""
        err = self.relative_error
        return math.isfinite(err) and err <= self.tolerance

    def as_row(self) -> dict:
        """The JSON row: exactly :data:`ROW_KEYS`; non-finite numbers become ``None``."""
        return {
            "case": self.case,
            "quantity": self.quantity,
            "simulated": _finite_or_none(self.simulated),
            "analytical": _finite_or_none(self.analytical),
            "relative_error": _finite_or_none(self.relative_error),
            "tolerance": _finite_or_none(self.tolerance),
            "passed": bool(self.passed),
        }


def _finite_or_none(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def all_passed(comparisons: Iterable[Comparison]) -> bool:
    """True when every comparison passed (and there is at least one)."""
    comparisons = list(comparisons)
    return bool(comparisons) and all(c.passed for c in comparisons)


def comparison_table(comparisons: Iterable[Comparison], title: str | None = None) -> Table:
    """A rich table: case, quantity, simulated, analytical, error %, tolerance %, PASS/FAIL."""
    comparisons = list(comparisons)
    table = Table(title=title)
    table.add_column("case", overflow="fold")
    table.add_column("quantity", overflow="fold")  # narrow terminals fold, never ellipsise
    for col in ("simulated", "analytical", "error %", "tolerance %"):
        table.add_column(col, justify="right")
    table.add_column("result", justify="center")
    for c in comparisons:
        err = c.relative_error
        table.add_row(
            c.case,
            c.quantity,
            f"{c.simulated:.5g}",
            f"{c.analytical:.5g}",
            f"{100 * err:.2f}" if math.isfinite(err) else "nan",
            f"{100 * c.tolerance:.1f}",
            "[green]PASS[/]" if c.passed else "[bold red]FAIL[/]",
        )
    return table


def print_comparisons(comparisons: Iterable[Comparison], console: Console | None = None,
                      title: str | None = None) -> None:
    """Print :func:`comparison_table` to ``console`` (stdout by default)."""
    (console or Console()).print(comparison_table(comparisons, title=title))

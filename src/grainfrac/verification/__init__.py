"""Verification against analytical solutions: ``grainfrac verify NAME``.

Every case is a function ``case(seed=0) -> list[Comparison]`` registered in
:data:`CASES` under its command-line name; it builds, runs and measures its own
model, prints nothing and raises only on a failure to run (a miss of a
tolerance is a failed :class:`Comparison`, not an exception). A new case plugs in by
adding an entry.
"""

from __future__ import annotations

from collections.abc import Callable

from grainfrac.verification import (
    elastic,
    elastic3d,
    hydraulic,
    hydraulic3d,
    kgd,
    kgd_toughness,
    penny,
)
from grainfrac.verification.report import (
    ROW_KEYS,
    Comparison,
    all_passed,
    comparison_table,
    print_comparisons,
)

#: Command-line name -> case function (called as ``case(seed=N)``).
CASES: dict[str, Callable[..., list[Comparison]]] = {
    "kirsch": elastic.kirsch,
    "lame": elastic.lame,
    "cubic-law": hydraulic.cubic_law,
    "kgd": kgd.kgd,
    "kgd-toughness": kgd_toughness.kgd_toughness,
    "patch3d": elastic3d.patch3d,
    "lame3d": elastic3d.lame3d,
    "kirsch3d": elastic3d.kirsch3d,
    "kirsch3d-plane-strain": elastic3d.kirsch3d_plane_strain,
    "cubic-law3d": hydraulic3d.cubic_law3d,
    "penny": penny.penny,
}

__all__ = ["CASES", "ROW_KEYS", "Comparison", "all_passed", "comparison_table",
           "print_comparisons"]

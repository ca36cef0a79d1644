"""The paper's scenario designs as functions: hydraulic stimulation only
(:func:`hs_only`) and the hybrid method (:func:`hybrid`).
"""

from __future__ import annotations

from typing import Any

from grainfrac.assembly import FissureSpec
from grainfrac.io.config import validate
from grainfrac.scenario.config import Scenario
from grainfrac.scenario.stages import DEFAULT_RATE_ML_PER_MIN, default_inject_duration_ms

__all__ = [
    "hs_only",
    "hybrid",
]


def _preset(
    name: str, stages: list[dict[str, Any]], stress_case: str, seed: int,
    fissures: FissureSpec | dict[str, Any] | None, **extra: Any,
) -> Scenario:
    data: dict[str, Any] = {"name": name, "seed": seed, "stress": {"case": stress_case},
                            "stages": stages, **extra}
    if fissures is not None:
        data["fissures"] = fissures
    return validate(Scenario, data)


def hs_only(
    rate_ml_per_min: float = DEFAULT_RATE_ML_PER_MIN,
    stress_case: str = "case2",
    duration_ms: float | None = None,
    *,
    seed: int = 0,
    fissures: FissureSpec | dict[str, Any] | None = None,
    name: str | None = None,
    **extra: Any,
) -> Scenario:
    """Hydraulic stimulation only: ``[equilibrate, inject]`` (paper Fig. 17c at 90 ml/min).

    ``duration_ms`` defaults to :func:`default_inject_duration_ms` (12 ms at
    90 ml/min on the default slab, where breakdown comes 4-5 ms after the start
    of injection). ``extra`` are further top-level scenario fields
    (``specimen``, ``grains``, ``fluid``, ``output``...).
    """
    duration = default_inject_duration_ms(rate_ml_per_min) if duration_ms is None else duration_ms
    return _preset(
        name or f"hs-only-{stress_case}-{rate_ml_per_min:g}mlmin",
        [{"kind": "equilibrate"},
         {"kind": "inject", "rate_ml_per_min": rate_ml_per_min, "duration_ms": duration}],
        stress_case, seed, fissures, **extra,
    )


def hybrid(
    rate_ml_per_min: float = DEFAULT_RATE_ML_PER_MIN,
    stress_case: str = "case2",
    duration_ms: float | None = None,
    *,
    peak_pressure_MPa: float = 45.0,
    seed: int = 0,
    fissures: FissureSpec | dict[str, Any] | None = None,
    name: str | None = None,
    **extra: Any,
) -> Scenario:
    """The hybrid method: ``[equilibrate, scda, drill_out, inject]`` (paper Fig. 17a, b, d).

    SCDA charging with the paper's parameters (peak 45 MPa, f = 1, b = 20),
    drill-out, then injection; ``duration_ms`` as in :func:`hs_only`.
    """
    duration = default_inject_duration_ms(rate_ml_per_min) if duration_ms is None else duration_ms
    return _preset(
        name or f"hybrid-{stress_case}-{rate_ml_per_min:g}mlmin",
        [{"kind": "equilibrate"},
         {"kind": "scda", "peak_pressure_MPa": peak_pressure_MPa},
         {"kind": "drill_out"},
         {"kind": "inject", "rate_ml_per_min": rate_ml_per_min, "duration_ms": duration}],
        stress_case, seed, fissures, **extra,
    )

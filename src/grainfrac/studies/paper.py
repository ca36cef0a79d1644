"""The paper's study matrix as sweeps, and its claims: ``grainfrac study paper``.

Each study is a sweep over the example scenarios of ``examples/`` (resolved
relative to that directory) with ``realisations`` grain structures per point
(seeds 0, 1, ... as the examples use seed 0), and the claims of the paper it
tests (:mod:`grainfrac.studies.claims`):

=================  ===============================================================
scda-confinement   SCDA charging, stress Cases 1-4 (Sect. 5.1, Fig. 10)
hs-confinement     HS at 18 ml/min, Cases 1-4 (Sect. 5.3, Fig. 12)
grain-size         HS 18 ml/min, Case 4, grain edges 3-6 ... 3-9 mm, zones 1.4 mm
                   (Sect. 5.4, Figs. 13-14)
fissures           HS 18 ml/min, Case 3, 5 % and 15 % fissures (Sect. 5.5, Fig. 15)
injection-rate     HS at 18, 42, 66 ml/min, Case 2 (Sect. 5.6, Fig. 16)
hybrid             hybrid SCDA-HS vs HS-only at 90 ml/min, Case 2, 0 % and 15 %
                   fissures (Sect. 6, Figs. 17-18)
lab-hs             the unconfined laboratory HS test at 5 ml/min (Sect. 5.2, Fig. 11)
=================  ===============================================================

and in 3D (``grainfrac study paper --dim 3``; the scenarios of ``examples/3d``), the
same claims where the paper's 3D model makes them:

===================  ==============================================================
scda-confinement-3d  SCDA charging, Cases 1-4, on a 50 x 50 x 10 mm slab
hybrid-3d            hybrid vs HS-only at 90 ml/min, Case 2, on the same slab
lab-hs-3d            the laboratory HS test on the hollow cylinder (Sect. 5.2)
===================  ==============================================================

Every run writes a ParaView snapshot every 10 ms instead of the examples'
1 ms (a study makes hundreds of runs); nothing else about the examples changes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grainfrac.errors import ConfigError
from grainfrac.scenario import default_inject_duration_ms
from grainfrac.studies.claims import Claim
from grainfrac.studies.sweep import SweepPlan, plan_sweep

# Applied to every run of every study.
COMMON_SET: dict[str, Any] = {"output.snapshot_every_ms": 10.0}
CASES = ("case1", "case2", "case3", "case4")
# Paper Table 6: sigma_y / sigma_x in the slab plane.
STRESS_RATIO = {"case1": 1.0, "case2": 2.0, "case3": 1.0, "case4": 5.0}
GRAIN_MAX_EDGES_MM = (6.0, 7.0, 8.0, 9.0)
GRAIN_STUDY_ZONE_MM = 1.4   # paper Sect. 5.4: "kept constant at 1.4 mm for all four"
RATES_ML_PER_MIN = (18.0, 42.0, 66.0)
FISSURE_CLEAR_RADIUS_MM = 10.0  # as examples/hybrid-case2-90mlmin-fissures15.toml
LAB_BREAKDOWN_MPA = 9.16     # paper Sect. 5.2 (3DEC: 8.39 MPa, 8.35 % off)
LAB_TOLERANCE = 0.10

# The laboratory HS test (paper Sect. 2.3 and 5.2, Fig. 11): a 22.5 mm diameter,
# 45 mm tall granite cylinder with a 3 mm central hole, unconfined laterally, water
# at 5 ml/min. The scenario schema has square slabs only: the closest is a
# 22.5 mm square slab, 45 mm thick (the cylinder's height, so the rate per unit
# thickness matches a hole along the whole height), with a 3 mm borehole and no
# in-plane stress (the ~5 MPa axial load acts out of plane and is left out of
# plane strain). The 2 mm zones of the default slab leave about 5 chords on the
# hole; 1 mm zones resolve it (grains 3-8 mm as elsewhere). The duration is the
# volume that takes the default slab past breakdown, scaled to the small well.
LAB_SCENARIO: dict[str, Any] = {
    "name": "lab-hs-5mlmin",
    "seed": 0,
    "specimen": {"shape": "slab", "width_mm": 22.5, "height_mm": 22.5, "thickness_mm": 45.0,
                 "borehole_diameter_mm": 3.0},
    "grains": {"zone_size_mm": 1.0},
    "stress": {"sigma_x_MPa": 0.0, "sigma_y_MPa": 0.0},
    "stages": [{"kind": "equilibrate"},
               {"kind": "inject", "rate_ml_per_min": 5.0, "duration_ms": 60.0,
                "time_step_ms": 0.01, "stop_at_boundary": True}],
}


@dataclass(frozen=True)
class Study:
    """One study of the paper: a sweep, what it reproduces and the claims it tests."""

    name: str
    title: str
    reference: str
    description: str
    sweep: dict[str, Any]
    figure_quantities: tuple[str, ...]
    claims: tuple[Claim, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)
    dimension: int = 2

    @property
    def family(self) -> str:
        """The study's name without its dimension: a 3D study and its 2D counterpart
        share it (and the ids of the claims they both test)."""
        return self.name.removesuffix("-3d")

    def plan(self, realisations: int, examples: Path) -> SweepPlan:
        """The sweep with ``realisations`` per point, scenario files under ``examples``."""
        return plan_sweep({**self.sweep, "realisations": realisations}, base_dir=examples)


def _cases(prefix: str, suffix: str) -> list[dict[str, Any]]:
    return [{"id": case, "base": f"{prefix}{case}{suffix}.toml"} for case in CASES]


def paper_studies() -> list[Study]:
    """The study matrix of the paper (sections 5.1-5.6 and 6), in the paper's order."""
    scda = Study(
        "scda-confinement", "SCDA charging under the four in-situ stress cases",
        "Sect. 5.1, Fig. 10",
        "examples/scda-case1..4.toml: SCDA expansion (Eq. 9) to the 45 MPa peak.",
        {"name": "scda-confinement", "base": "scda-case1.toml", "set": COMMON_SET,
         "points": _cases("scda-", "")},
        ("n_radial_fractures", "fracture_extent_mm", "peak_expansive_pressure_MPa", "n_cracks"),
        (Claim("scda-radial", "SCDA charging produces multiple (>= 3) radial fractures in "
               "every stress case", "n_radial_fractures", "at_least", CASES,
               paper="multiple radial fractures in Cases 1-4 (Fig. 10a-d)", threshold=3.0),
         Claim("scda-confinement-shortens", "fractures are shorter under isotropic "
               "confinement: extent in Case 3 (5/5 MPa) < Case 1 (1/1 MPa)",
               "fracture_extent_mm", "greater", ("case1", "case3"),
               paper="confinement restrains the extension of SCDA fractures (Fig. 10a vs c)")),
    )
    hs = Study(
        "hs-confinement", "Hydraulic stimulation at 18 ml/min under the four stress cases",
        "Sect. 5.3, Fig. 12",
        "examples/hs-case1..4-18mlmin.toml: constant-rate injection, 60 ms or until a "
        "fracture reaches the boundary.",
        {"name": "hs-confinement", "base": "hs-case1-18mlmin.toml", "set": COMMON_SET,
         "points": _cases("hs-", "-18mlmin")},
        ("breakdown_pressure_MPa", "tensile_shear_ratio", "n_cracks", "tortuosity"),
        (Claim("hs-breakdown-confinement", "breakdown pressure rises with confinement from "
               "Case 1 to Case 4", "breakdown_pressure_MPa", "trend", CASES,
               paper="lowest in Case 1, highest in Case 4, Cases 2-3 slightly above Case 1 "
               "(Fig. 12e)", x=(1.0, 2.0, 3.0, 4.0), x_label="case number"),
         Claim("hs-breakdown-case4-above-case1", "breakdown pressure in Case 4 > Case 1",
               "breakdown_pressure_MPa", "greater", ("case4", "case1"),
               paper="highest breakdown in Case 4, lowest in Case 1 (Fig. 12e)"),
         Claim("hs-ts-stress-ratio", "T/S ratio falls as the stress ratio rises from 1 to 5 "
               "(Cases 1, 2, 4)", "tensile_shear_ratio", "trend", ("case1", "case2", "case4"),
               paper="T/S 8.45 (ratio 1) to 6.49 (ratio 5) (Fig. 12a, b, d)",
               x=tuple(STRESS_RATIO[c] for c in ("case1", "case2", "case4")),
               x_label="stress ratio", direction=-1)),
    )
    grains = Study(
        "grain-size", "Grain size: HS 18 ml/min, Case 4, edges 3-6 to 3-9 mm",
        "Sect. 5.4, Figs. 13-14",
        "examples/hs-case4-18mlmin.toml with grains.max_edge_mm 6, 7, 8, 9 (min 3) and "
        f"grains.zone_size_mm {GRAIN_STUDY_ZONE_MM} at every size, as in the paper.",
        {"name": "grain-size", "base": "hs-case4-18mlmin.toml",
         "set": {**COMMON_SET, "grains.zone_size_mm": GRAIN_STUDY_ZONE_MM},
         "parameters": [{"path": "grains.max_edge_mm", "values": list(GRAIN_MAX_EDGES_MM),
                         "labels": [f"3-{m:g}mm" for m in GRAIN_MAX_EDGES_MM]}]},
        ("breakdown_pressure_MPa", "n_grains", "contact_fraction_failed.F-Q",
         "contact_fraction_failed.Q-Q"),
        (Claim("grain-fq-enriched", "F-Q contacts are over-represented among failed "
               "contacts (C > T)", "contact_fraction_failed.F-Q", "exceeds",
               tuple(f"3-{m:g}mm" for m in GRAIN_MAX_EDGES_MM),
               other="contact_fraction_total.F-Q",
               paper="the fraction of F-Q contacts increases in the failed contacts (Fig. 14e)"),
         Claim("grain-qq-depleted", "Q-Q contacts are under-represented among failed "
               "contacts (C < T)", "contact_fraction_total.Q-Q", "exceeds",
               tuple(f"3-{m:g}mm" for m in GRAIN_MAX_EDGES_MM),
               other="contact_fraction_failed.Q-Q",
               paper="the fraction of Q-Q contacts decreases in the failed contacts "
               "(Fig. 14e)")),
        notes=("The paper also says the breakdown pressure shows little to no variation "
               "with grain size; that is an equivalence statement without a stated margin "
               "and is shown, not decided.",),
    )
    fissures = Study(
        "fissures", "Fissures: HS 18 ml/min, Case 3, 5 % and 15 % of grain boundaries",
        "Sect. 5.5, Fig. 15",
        "examples/hs-case3-18mlmin.toml with fissures.fraction 0.05 and 0.15, kept "
        f"{FISSURE_CLEAR_RADIUS_MM:g} mm clear of the well (the paper left defects out "
        "around the well).",
        {"name": "fissures", "base": "hs-case3-18mlmin.toml",
         "set": {**COMMON_SET, "fissures.clear_radius_mm": FISSURE_CLEAR_RADIUS_MM},
         "parameters": [{"path": "fissures.fraction", "values": [0.05, 0.15],
                         "labels": ["5pct", "15pct"]}]},
        ("energy_friction_J", "energy_shear_J", "energy_tensile_J", "breakdown_pressure_MPa"),
        (Claim("fissures-friction", "more fissures raise the frictional work: "
               "15 % > 5 %", "energy_friction_J", "greater", ("15pct", "5pct"),
               paper="joint friction energy +148 % from 5 % to 15 % fissures (Fig. 15e)"),
         Claim("fissures-shear-energy", "more fissures raise the shear strain energy "
               "released: 15 % > 5 %", "energy_shear_J", "greater", ("15pct", "5pct"),
               paper="shear strain energy +18 % from 5 % to 15 % fissures (Fig. 15e)")),
    )
    durations = [default_inject_duration_ms(r) for r in RATES_ML_PER_MIN]
    rate = Study(
        "injection-rate", "Injection rate: HS at 18, 42 and 66 ml/min, Case 2",
        "Sect. 5.6, Fig. 16",
        "examples/hs-case2-18mlmin.toml with stages.1.rate_ml_per_min 18, 42, 66 and the "
        "duration scaled as 1/rate (60, 25.7, 16.4 ms: the same injected volume).",
        {"name": "injection-rate", "base": "hs-case2-18mlmin.toml", "set": COMMON_SET,
         "combine": "zip",
         "parameters": [{"path": "stages.1.rate_ml_per_min", "values": list(RATES_ML_PER_MIN),
                         "labels": [f"{r:g}mlmin" for r in RATES_ML_PER_MIN]},
                        {"path": "stages.1.duration_ms", "values": durations,
                         "labels": [""] * len(durations)}]},
        ("breakdown_pressure_MPa", "n_cracks", "n_radial_fractures", "tensile_shear_ratio"),
        (Claim("rate-breakdown", "breakdown pressure rises with the injection rate",
               "breakdown_pressure_MPa", "trend",
               tuple(f"{r:g}mlmin" for r in RATES_ML_PER_MIN), x=RATES_ML_PER_MIN,
               x_label="ml/min", paper="higher rate, higher breakdown pressure (Fig. 16d)"),
         Claim("rate-cracking", "more cracking around the well at higher rates",
               "n_cracks", "trend", tuple(f"{r:g}mlmin" for r in RATES_ML_PER_MIN),
               x=RATES_ML_PER_MIN, x_label="ml/min",
               paper="higher rate, more fractures around the injection well (Fig. 16a-c)")),
    )
    hybrid = Study(
        "hybrid", "Hybrid SCDA-HS vs HS alone, 90 ml/min, Case 2, 0 % and 15 % fissures",
        "Sect. 6, Figs. 17-18",
        "examples/hybrid-case2-90mlmin.toml, hybrid-case2-90mlmin-fissures15.toml and "
        "hs-only-case2-90mlmin.toml (with the same fissures, 15 % kept "
        f"{FISSURE_CLEAR_RADIUS_MM:g} mm clear of the well, for HS-only at 15 %); same "
        "seeds, so each pair shares its grain structure.",
        {"name": "hybrid", "base": "hybrid-case2-90mlmin.toml", "set": COMMON_SET,
         "points": [
             {"id": "hybrid-f0", "base": "hybrid-case2-90mlmin.toml"},
             {"id": "hs-only-f0", "base": "hs-only-case2-90mlmin.toml"},
             {"id": "hybrid-f15", "base": "hybrid-case2-90mlmin-fissures15.toml"},
             {"id": "hs-only-f15", "base": "hs-only-case2-90mlmin.toml",
              "set": {"fissures.fraction": 0.15,
                      "fissures.clear_radius_mm": FISSURE_CLEAR_RADIUS_MM}},
         ]},
        ("breakdown_pressure_MPa", "n_radial_fractures", "breakdown_drop_1ms_fraction",
         "n_cracks"),
        (Claim("hybrid-breakdown-f0", "hybrid breakdown pressure < HS-only (no fissures)",
               "breakdown_pressure_MPa", "greater", ("hs-only-f0", "hybrid-f0"),
               paper="HS-only breaks down at 31.2 MPa; the hybrid well pressure has no "
               "abrupt breakdown and lower peaks (Fig. 17d)"),
         Claim("hybrid-breakdown-f15", "hybrid breakdown pressure < HS-only (15 % fissures)",
               "breakdown_pressure_MPa", "greater", ("hs-only-f15", "hybrid-f15"),
               paper="lower peak injection pressure with 15 % fissures (Fig. 18d)"),
         Claim("hybrid-gentler-f0", "the well pressure falls less in the 1 ms after "
               "breakdown with the hybrid than with HS-only (no fissures)",
               "breakdown_drop_1ms_fraction", "greater", ("hs-only-f0", "hybrid-f0"),
               paper="no sudden pressure drop with the hybrid, multiple peaks and a gradual "
               "reduction instead (Fig. 17d)"),
         Claim("hybrid-fractures-f0", "more fractures extended by the hybrid than by HS-only "
               "(no fissures)", "n_radial_fractures", "greater", ("hybrid-f0", "hs-only-f0"),
               paper="five fractures extended by the hybrid vs three cracks by HS-only "
               "(Fig. 17b, c)"),
         Claim("hybrid-fractures-f15", "more fractures extended by the hybrid than by "
               "HS-only (15 % fissures)", "n_radial_fractures", "greater",
               ("hybrid-f15", "hs-only-f15"),
               paper="fissures give inferior extension during injection (Fig. 18b)")),
        notes=("n_radial_fractures counts fracture branches from the well crossing 2 well "
               "radii at the end of the run: for the hybrid it includes the SCDA fractures "
               "the injection extended.",),
    )
    lab = Study(
        "lab-hs", "Laboratory HS test: unconfined, 5 ml/min", "Sect. 5.2, Fig. 11",
        "A 22.5 x 22.5 mm slab, 45 mm thick, 3 mm borehole, zero in-plane stress, 1 mm "
        "zones, 5 ml/min for 60 ms or until a fracture reaches the boundary: the closest "
        "the scenario schema (square slabs) comes to the 22.5 mm diameter cylinder with a "
        "3 mm hole; the ~5 MPa axial load is out of plane and left out.",
        {"name": "lab-hs", "base": LAB_SCENARIO, "set": COMMON_SET,
         "points": [{"id": "lab-5mlmin"}]},
        ("breakdown_pressure_MPa", "n_radial_fractures", "n_cracks", "tortuosity"),
        (Claim("lab-breakdown", f"breakdown pressure within {LAB_TOLERANCE:.0%} of the "
               f"laboratory {LAB_BREAKDOWN_MPA} MPa", "breakdown_pressure_MPa", "within",
               ("lab-5mlmin",), paper=f"laboratory {LAB_BREAKDOWN_MPA} MPa; 3DEC 8.39 MPa "
               "(8.35 % error)", reference=LAB_BREAKDOWN_MPA, tolerance=LAB_TOLERANCE),),
        notes=("The specimen is a square cross-section, not a disk: corners sit farther "
               "from the hole than the cylinder's surface (15.9 vs 11.25 mm).",),
    )
    return [scda, hs, grains, fissures, rate, hybrid, lab]


# The 3D slab of the 3D studies: the 100 x 100 x 20 mm slab at an eighth of its volume.
# SCDA charging takes tens of ms of simulated time to its 45 MPa peak; on the full slab
# that is tens of minutes per run on one core, on this one a few minutes.
SLAB_3D_SET: dict[str, Any] = {"specimen.width_mm": 50.0, "specimen.height_mm": 50.0,
                               "specimen.thickness_mm": 10.0}


def paper_studies_3d() -> list[Study]:
    """The studies of the paper's 3D model (SCDA Cases 1-4, hybrid, lab HS), with the
    claims of their 2D counterparts (same ids) and the 3D fracture counts."""
    claims = {c.id: c for s in paper_studies() for c in s.claims}
    slab = "a 50 x 50 x 10 mm slab with the 10 mm borehole along z"
    scda = Study(
        "scda-confinement-3d", "SCDA charging under the four in-situ stress cases, 3D",
        "Sect. 5.1, Fig. 10",
        f"examples/3d/scda-case2.toml on {slab}, stress.case 1-4: SCDA expansion (Eq. 9) "
        "to the 45 MPa peak.",
        {"name": "scda-confinement-3d", "base": "3d/scda-case2.toml",
         "set": {**COMMON_SET, **SLAB_3D_SET},
         "points": [{"id": case, "set": {"stress.case": case}} for case in CASES]},
        ("n_radial_fractures_top", "n_radial_fractures_mid", "fracture_extent_mm",
         "peak_expansive_pressure_MPa"),
        (claims["scda-radial"], claims["scda-confinement-shortens"]),
        notes=("Radial fractures are counted on the slab's top face (n_radial_fractures); "
               "the slab's half-width, 25 mm, bounds the fracture extent.",),
        dimension=3,
    )
    hybrid = Study(
        "hybrid-3d", "Hybrid SCDA-HS vs HS alone, 90 ml/min, Case 2, 3D", "Sect. 6, Fig. 17",
        "examples/3d/hybrid-case2-90mlmin-50mm.toml and hs-only-case2-90mlmin-50mm.toml: "
        f"{slab}, no fissures, injection stopped 1 ms after breakdown; same seeds, so each "
        "pair shares its grain structure.",
        {"name": "hybrid-3d", "base": "3d/hybrid-case2-90mlmin-50mm.toml", "set": COMMON_SET,
         "points": [{"id": "hybrid-f0", "base": "3d/hybrid-case2-90mlmin-50mm.toml"},
                    {"id": "hs-only-f0", "base": "3d/hs-only-case2-90mlmin-50mm.toml"}]},
        ("breakdown_pressure_MPa", "n_radial_fractures_top", "n_radial_fractures_mid",
         "breakdown_drop_1ms_fraction"),
        (claims["hybrid-breakdown-f0"], claims["hybrid-gentler-f0"],
         claims["hybrid-fractures-f0"],
         Claim("hybrid-fractures-mid-f0", "more fractures extended by the hybrid than by "
               "HS-only on the mid-plane (no fissures)", "n_radial_fractures_mid", "greater",
               ("hybrid-f0", "hs-only-f0"), paper="five vs three, counted on the top face "
               "(Fig. 17b, c)")),
        notes=("n_radial_fractures counts the branches crossing 2 well radii on the top "
               "face, as the paper counted; n_radial_fractures_mid on the mid-plane.",),
        dimension=3,
    )
    lab = Study(
        "lab-hs-3d", "Laboratory HS test: unconfined, 5 ml/min, 3D", "Sect. 5.2, Fig. 11",
        "examples/3d/lab-hs-5mlmin.toml: the 22.5 x 45 mm cylinder with its 3 mm hole "
        "along the axis, 2 kN on its ends, 2-5 mm grains at 1.5 mm zones, stopped 1 ms "
        "after breakdown (15-25 min per run on one core).",
        {"name": "lab-hs-3d", "base": "3d/lab-hs-5mlmin.toml", "set": COMMON_SET,
         "points": [{"id": "lab-5mlmin"}]},
        ("breakdown_pressure_MPa", "n_cracks"),
        (claims["lab-breakdown"],),
        dimension=3,
    )
    return [scda, hybrid, lab]


STUDY_NAMES = tuple(s.name for s in paper_studies())
STUDY_NAMES_3D = tuple(s.name for s in paper_studies_3d())
DIMENSIONS = (2, 3)


def default_examples_dir() -> Path:
    """``examples/`` of the source checkout this package runs from."""
    return Path(__file__).resolve().parents[3] / "examples"


def select(names: Sequence[str] | None = None, dimensions: Sequence[int] = (2,)
           ) -> list[Study]:
    """The studies named (all by default) in each of ``dimensions``, in the paper's
    order; a name is a study's own or its family's (``hybrid`` selects ``hybrid-3d`` in
    3D). Unknown names and dimensions are errors."""
    for i, d in enumerate(dimensions):
        if d not in DIMENSIONS:
            raise ConfigError(f"dim.{i}", f"must be 2 or 3 (got {d})")
    studies = [s for d in DIMENSIONS if d in dimensions
               for s in (paper_studies() if d == 2 else paper_studies_3d())]
    if not names:
        return studies
    for i, name in enumerate(names):
        if not any(name in (s.name, s.family) for s in studies):
            raise ConfigError(f"only.{i}", f"unknown study {name!r}; known: "
                              + ", ".join(s.name for s in studies))
    return [s for s in studies if s.name in names or s.family in names]


def plan_studies(studies: Sequence[Study], realisations: int, examples: str | Path | None
                 ) -> list[tuple[Study, SweepPlan]]:
    """Plan every study (validating all scenarios) before any compute."""
    examples = Path(examples) if examples is not None else default_examples_dir()
    if not examples.is_dir():
        raise ConfigError("examples", f"directory not found: {examples} (the paper study uses "
                          "the example scenarios of a source checkout; pass --examples DIR)")
    if realisations < 1:
        raise ConfigError("realisations", f"must be >= 1 (got {realisations})")
    return [(s, s.plan(realisations, examples)) for s in studies]


__all__ = ["COMMON_SET", "DIMENSIONS", "LAB_SCENARIO", "SLAB_3D_SET", "STUDY_NAMES",
           "STUDY_NAMES_3D", "Study", "default_examples_dir", "paper_studies",
           "paper_studies_3d", "plan_studies", "select"]

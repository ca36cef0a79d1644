"""grainfrac: grain-scale hydro-mechanical fracturing of crystalline rock.

The verbs of a notebook session, imported lazily so that ``import grainfrac``
stays fast::

    import grainfrac as gf
    slab = gf.build_specimen({"fissures": {"fraction": 0.05}})
    scenario, rock = gf.load_scenario("examples/hybrid-case2-90mlmin.toml")
    summary = gf.run_scenario(scenario, rock, "runs/hybrid")
    gf.build_report(["runs/hybrid"], "runs/hybrid/report.html")
"""

from importlib import import_module

__version__ = "0.1.0"

_VERBS = {
    "build_specimen": "grainfrac.assembly",
    "build_assembly": "grainfrac.assembly",
    "load_specimen_config": "grainfrac.assembly",
    "load_recipe": "grainfrac.materials",
    "load_scenario": "grainfrac.scenario",
    "run_scenario": "grainfrac.simulation",
    "analyse_run": "grainfrac.analysis",
    "build_report": "grainfrac.viz.report",
    "lab_test_config": "grainfrac.labtests",
    "run_labtest": "grainfrac.labtests",
    "load_sweep": "grainfrac.studies",
}

__all__ = ["__version__", *_VERBS]


def __getattr__(name: str):
    if name in _VERBS:
        return getattr(import_module(_VERBS[name]), name)
    raise AttributeError(f"module 'grainfrac' has no attribute {name!r}")

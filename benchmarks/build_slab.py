"""Benchmark: build the default specimen (target: under 5 s in total).

The default specimen is the paper's slab: 100 x 100 mm, 10 mm thick, 10 mm
borehole, grains with edges of 3-8 mm, 2 mm zones, Strathbogie granite.

The script times :func:`grainfrac.assembly.build_assembly` itself, with the
functions it calls wrapped by timers, so the phases add up to exactly what a
user's build costs:

* tessellation: ``outline`` + ``tessellate`` (Voronoi grains, edge control);
* meshing: ``mesh_grains`` (triangles, sub-contacts, flow network, node sets);
* materials: the rest of ``build_assembly`` (mineral map, Weibull draws,
  contact pairs, fissures).

The first build in the process is reported separately as "cold"; the others
are summarised by their median.

Usage::

    python benchmarks/build_slab.py --repeats 5 --seed 0
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from contextlib import contextmanager

import grainfrac.assembly as assembly_module
from grainfrac.assembly import GrainAssembly, SpecimenConfig, build_assembly
from grainfrac.io.config import validate

TARGET_S = 5.0
PHASES = ("tessellation", "meshing", "materials", "total")
_WRAPPED = {"outline": "tessellation", "tessellate": "tessellation", "mesh_grains": "meshing"}


@contextmanager
def _timed_phases(times: dict[str, float]):
    """Wrap the functions build_assembly calls so each call adds its wall time to a phase."""
    originals = {name: getattr(assembly_module, name) for name in _WRAPPED}

    def wrap(name: str, func: Callable) -> Callable:
        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return func(*args, **kwargs)
            finally:
                times[_WRAPPED[name]] += time.perf_counter() - start

        return timed

    for name, func in originals.items():
        setattr(assembly_module, name, wrap(name, func))
    try:
        yield
    finally:
        for name, func in originals.items():
            setattr(assembly_module, name, func)


def timed_build(seed: int) -> tuple[dict[str, float], GrainAssembly]:
    """Build the default slab once; return the phase times (s) and the assembly."""
    times = dict.fromkeys(PHASES, 0.0)
    cfg = validate(SpecimenConfig, {"seed": seed})
    recipe = cfg.recipe()
    with _timed_phases(times):
        start = time.perf_counter()
        assembly = build_assembly(cfg, recipe)
        times["total"] = time.perf_counter() - start
    times["materials"] = times["total"] - times["tessellation"] - times["meshing"]
    return times, assembly


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="warm builds after the cold one")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the specimen")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")

    cold, assembly = timed_build(args.seed)
    warm = [timed_build(args.seed)[0] for _ in range(args.repeats)]
    median = {p: statistics.median(t[p] for t in warm) for p in PHASES}

    mesh = assembly.mesh
    print(f"default slab, seed {args.seed}: 100 x 100 mm, borehole 10 mm, grains 3-8 mm, "
          f"zone {mesh.zone_size * 1e3:g} mm")
    print(f"{'phase':<14}{'cold (s)':>10}{f'median of {args.repeats} (s)':>22}")
    for p in PHASES:
        print(f"{p:<14}{cold[p]:>10.3f}{median[p]:>22.3f}")
    counts = {
        "grains": mesh.grains.n_grains,
        "elements": mesh.n_elements,
        "nodes": mesh.n_nodes,
        "sub-contacts": mesh.n_contacts,
        "interfaces": mesh.n_interfaces,
        "fluid nodes": len(mesh.fluid_node_xy),
        "pipes": len(mesh.pipe_length),
    }
    print("counts: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    worst = max(cold["total"], median["total"])
    verdict = "OK" if worst < TARGET_S else "TOO SLOW"
    print(f"target: total under {TARGET_S:g} s -> cold {cold['total']:.3f} s, "
          f"median {median['total']:.3f} s: {verdict}")
    return 0 if worst < TARGET_S else 1


if __name__ == "__main__":
    sys.exit(main())

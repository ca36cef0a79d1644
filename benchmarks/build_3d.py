"""Build time, peak memory and acceptance numbers of the full-size 3D specimens.

Usage: ``python benchmarks/build_3d.py [--plain] [slab|cube|penny|ucs|bts|nscb ...]``
(default: all; ``--plain`` sets ``grains.mend_steps = false``). Each case runs in its
own process so its peak resident memory (``ru_maxrss``) is its own; the mesher uses
``$GRAINFRAC_THREADS`` threads (default 1). Targets (issue 38, 2 cores): slab 100 x 100
x 20 mm <= 10 s; 100 mm cube <= 60 s and <= 4 GB. The penny block (paper Fig. 8) and
the Table 3 lab specimens (UCS cylinder, Brazilian disc, NSCB) are reported for their
mesh quality.
"""

from __future__ import annotations

import multiprocessing as mp
import resource
import sys
import time

CASES = {
    "slab": {"dimension": 3, "seed": 1,
             "specimen": {"shape": "slab", "width_mm": 100, "height_mm": 100,
                          "thickness_mm": 20}},
    "cube": {"dimension": 3, "seed": 1,
             "specimen": {"shape": "slab", "width_mm": 100, "height_mm": 100,
                          "thickness_mm": 100}},
    "penny": {"dimension": 3, "seed": 1, "specimen": {"shape": "penny"}},
    "ucs": {"dimension": 3, "seed": 1, "specimen": {"shape": "rectangle"}},
    "bts": {"dimension": 3, "seed": 1, "specimen": {"shape": "disk"}},
    "nscb": {"dimension": 3, "seed": 1, "specimen": {"shape": "semi_disk"}},
}


def _run(name: str, mend: bool, queue) -> None:
    import numpy as np

    from grainfrac.assembly import build_specimen
    from grainfrac.specimen_report import specimen_summary3d

    start = time.perf_counter()
    assembly = build_specimen({**CASES[name], "grains": {"mend_steps": mend}})
    build = time.perf_counter() - start
    peak_gb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024 ** 2
    s = specimen_summary3d(assembly, build)
    diff = [v["achieved"] - v["target"] for v in s["volume_percent"].values()]
    median = s["size_distribution"]["edge_length_mm"].get("p50", float("nan"))
    queue.put(
        f"{name}: build {build:.1f} s, peak RSS {peak_gb:.2f} GB | {s['n_grains']} grains, "
        f"{s['n_elements']} tets, {s['n_nodes']} nodes, {s['n_contacts']} contacts | "
        f"fractions off by {np.round(diff, 2).tolist()} pp | volume error "
        f"{s['volume_relative_error']:.1e} | min dihedral {s['min_dihedral_angle_deg']:.2f} deg "
        f"| stable step / regular quartz tet: tets {s['stable_step']['grains_table_ratio']:.3f} "
        f"(drawn grains {s['stable_step']['grains_ratio']:.3f}), "
        f"with contacts {s['stable_step']['with_contacts_ratio']:.3f} | shortest edge "
        f"{s['shortest_edge_mm']:.3f} mm, rule breaks {s['edges_breaking_rule']} | "
        f"median interior edge {median:.2f} mm"
    )


def main(args: list[str]) -> None:
    from grainfrac.threads import default_threads

    ctx = mp.get_context("spawn")
    mend = "--plain" not in args
    names = [a for a in args if a != "--plain"]
    print(f"{'mended' if mend else 'plain'} meshes, {default_threads()} mesher thread(s)",
          flush=True)
    for name in names or list(CASES):
        queue = ctx.Queue()
        proc = ctx.Process(target=_run, args=(name, mend, queue))
        proc.start()
        print(queue.get(), flush=True)
        proc.join()


if __name__ == "__main__":
    main(sys.argv[1:])

"""CPU threads of grainfrac's parallel work: the explicit step's kernels and the 3D
mesher's grains. Results are the same on any number of threads."""

from __future__ import annotations

import os

import numba

# Environment variable naming the CPU threads (see default_threads).
THREADS_VARIABLE = "GRAINFRAC_THREADS"


def default_threads() -> int:
    """CPU threads: ``$GRAINFRAC_THREADS``, ``all``, or 1.

    One by default: parallel regions on busy cores are catastrophically slow (measured
    on this project's 2-core machine under load: a 1296-tetrahedron step took 34.6 ms
    on 2 threads against 0.39 ms on 1), and Dask workers already fill the cores. A
    run on a machine of its own asks for more with ``--threads`` or the variable
    (``all``: every core numba may use).
    """
    value = os.environ.get(THREADS_VARIABLE, "1").strip().lower()
    limit = numba.config.NUMBA_NUM_THREADS
    if value == "all":
        return limit
    try:
        threads = int(value)
    except ValueError:
        raise ValueError(f"{THREADS_VARIABLE} must be a whole number or 'all', got "
                         f"{value!r}") from None
    if not 1 <= threads <= limit:
        raise ValueError(f"{THREADS_VARIABLE} must be in [1, {limit}] or 'all', got {threads}")
    return threads

"""numba's CUDA module, imported once for the backend (real GPU or the simulator).

numba-cuda 0.x with numpy >= 2.4 fails its first kernel compile because
``np.row_stack`` was removed; the alias goes in before ``numba.cuda`` is
imported. ``NUMBA_ENABLE_CUDASIM=1`` (set before
numba is first imported) runs the kernels on the CPU in numba's simulator.
"""

from __future__ import annotations

import numpy as np

if not hasattr(np, "row_stack"):  # numba-cuda 0.x still calls it
    np.row_stack = np.vstack  # noqa: NPY201 (an alias, for numba-cuda)

from numba import (  # noqa: E402
    config,
    cuda,  # noqa: E402
    njit,
)

SIMULATOR = bool(config.ENABLE_CUDASIM)

if SIMULATOR:
    def raw(array):
        """The simulator's in-kernel array as its numpy array, so that an ``@njit``
        law (compiled for the CPU here) can take it; on a GPU this is the identity."""
        item = getattr(array, "_item", array)
        return getattr(item, "_ary", item)
else:
    @njit(inline="always")
    def raw(array):
        """Identity: on a GPU the ``@njit`` laws compile for the device and take
        device arrays as they are."""
        return array


def cuda_available() -> bool:
    """Whether a real CUDA device (not the simulator) can run the kernels."""
    if SIMULATOR:
        return False
    try:
        return bool(cuda.is_available())
    except Exception:  # no driver, no toolkit: no GPU backend  # noqa: BLE001
        return False


def device_name() -> str:
    """The card's name, or ``"simulator"``."""
    if SIMULATOR:
        return "numba CUDA simulator"
    name = cuda.get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)

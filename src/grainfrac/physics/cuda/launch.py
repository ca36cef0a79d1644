"""Kernel launches whose arguments are converted once per cycle, not at every step.

numba-cuda converts every argument of every launch (type dispatch, then each device
array into its pointer, shape and strides), and the element and contact kernels take
14 to 29 arguments: a 1e5-tetrahedron block stepped in 0.276 ms and a 1e6 one in
0.285 ms (H200), and a cProfile of the 100 mm cube's run put that conversion at the
top of the host's time. Within a cycle the arrays do not change, only the step
number: a :class:`PreparedLaunch` asks numba-cuda for the compiled kernel and the
converted arguments once, and then launches with the step number updated in place
(the cube's step: 0.401 ms before, 0.371 ms after, H100).

It uses numba-cuda's kernel object (``compile``, ``_prepare_args``, the code
library's function) and ``cuda.core.launch``, as numba-cuda 0.30 does itself. Where
any of that is missing (another numba-cuda, the simulator) or
``GRAINFRAC_CUDA_PREPARED=0`` is set, it launches through the dispatcher as usual:
the same kernel with the same arguments either way.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from grainfrac.physics.cuda._numba import SIMULATOR

# Set to 0 to launch through numba-cuda's dispatcher at every step.
PREPARED_VARIABLE = "GRAINFRAC_CUDA_PREPARED"
# How many launches were set up each way in this process (tests and benchmarks read it).
counts = {"prepared": 0, "plain": 0}


class PreparedLaunch:
    """``dispatcher[griddim, blockdim](*args)`` with the arguments at ``varying``
    (integer positions, integer or float arguments) given anew at each call.

    Parameters
    ----------
    dispatcher
        A ``cuda.jit`` kernel.
    griddim, blockdim
        Blocks and threads per block.
    args
        Every argument, as for a plain launch (device arrays and scalars).
    varying
        Positions of the scalar arguments that change between launches; each call
        passes their new values in this order.
    """

    def __init__(self, dispatcher, griddim: int, blockdim: int, args: Sequence,
                 varying: Sequence[int] = ()):
        self._plain = dispatcher[griddim, blockdim]
        self._args = list(args)
        self._varying = tuple(varying)
        self._fast = None
        if not SIMULATOR and os.environ.get(PREPARED_VARIABLE, "1") != "0":
            try:
                self._fast = _prepare(dispatcher, griddim, blockdim, self._args,
                                      self._varying)
            except Exception:  # noqa: BLE001 - another numba-cuda: launch as usual
                self._fast = None
        counts["prepared" if self._fast is not None else "plain"] += 1

    @property
    def prepared(self) -> bool:
        """Whether launches skip numba-cuda's argument conversion."""
        return self._fast is not None

    def __call__(self, *values) -> None:
        if self._fast is not None:
            launch, stream, config, function, kernel_args, slots = self._fast
            for slot, value in zip(slots, values, strict=True):
                slot.value = value
            try:
                launch(stream, config, function, *kernel_args)
                return
            except (TypeError, ValueError, AttributeError):
                # Refused before it was queued (another cuda.core's argument rules):
                # launch as usual from now on.
                self._fast = None
                counts["prepared"] -= 1
                counts["plain"] += 1
        for i, value in zip(self._varying, values, strict=True):
            self._args[i] = value
        self._plain(*self._args)


def _prepare(dispatcher, griddim: int, blockdim: int, args: list, varying: tuple[int, ...]):
    """What :meth:`PreparedLaunch.__call__` hands to ``cuda.core.launch``: numba-cuda's
    own conversion of ``args``, with the ctypes scalars at ``varying`` kept to update."""
    from cuda.core import LaunchConfig, launch
    from numba.cuda.cudadrv import driver

    if list(varying) != sorted(varying):
        raise ValueError("varying positions must be given in increasing order")
    kernel = dispatcher.compile(tuple(dispatcher.typeof_pyval(a) for a in args))
    stream = driver._to_core_stream(0)
    kernel_args: list = []
    slots = []
    write_back: list = []
    for i, (ty, value) in enumerate(zip(kernel.argument_types, args, strict=True)):
        start = len(kernel_args)
        kernel._prepare_args(ty, value, stream, write_back, kernel_args)
        if i in varying:
            if len(kernel_args) != start + 1 or not hasattr(kernel_args[start], "value"):
                raise TypeError(f"argument {i} is not a scalar that can change in place")
            slots.append(kernel_args[start])
    if write_back:  # host arrays copied in and out at each launch: not for this path
        raise TypeError("every array argument must already be on the device")
    function = kernel._codelibrary.get_cufunc().kernel
    config = LaunchConfig(grid=griddim, block=blockdim, shmem_size=0)
    return launch, stream, config, function, kernel_args, slots

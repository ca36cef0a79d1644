"""CUDA backend of the explicit mechanics (numba-cuda), the CPU kernels its reference.

One physics, two backends: the kernels in :mod:`.device_kernels` call the CPU
backend's ``@njit`` scalar laws (:func:`grainfrac.physics.kernels.contact_law`,
``elastic_strain``, ``hooke_stress``, ``relative_normal``), which numba compiles
for the device. Under ``NUMBA_ENABLE_CUDASIM=1`` (set before numba is imported)
everything runs in numba's CUDA simulator, which is how the test suite checks
the backend against the CPU on machines without a GPU.
"""

from grainfrac.physics.cuda._numba import SIMULATOR, cuda_available, device_name
from grainfrac.physics.cuda.mechanics import CudaMechanics
from grainfrac.physics.cuda.stepper import (
    copy_fields,
    device_energies,
    fetch_cracks,
    host_zeros,
    run_steps_cuda,
    to_device,
)

__all__ = ["SIMULATOR", "CudaMechanics", "copy_fields", "cuda_available", "device_energies",
           "device_name", "fetch_cracks", "host_zeros", "run_steps_cuda", "to_device"]

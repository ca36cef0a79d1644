"""The contact law on one tangent with a signed shear stress, as the kernels apply it in 2D.

``contact_law`` sees |tau|; the kernel keeps the shear vector's direction. With one
tangent the direction is a sign, so the law's tests can drive it with a signed
shear increment and read a signed shear stress back.
"""

from __future__ import annotations

import math

from grainfrac.physics import kernels


def signed_contact_law(u_n, du_s, tau_old, kn, ks, *args):
    """``kernels.contact_law`` with a signed trial shear ``tau_old + ks du_s``.

    Returns the law's results with the shear magnitude replaced by the signed shear.
    """
    trial = tau_old + ks * du_s
    out = kernels.contact_law(u_n, abs(trial), kn, ks, *args)
    shear = out[1]
    signed = trial if shear == abs(trial) else math.copysign(1.0, trial) * shear
    return (out[0], signed, *out[2:])

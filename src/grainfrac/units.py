"""Unit conversions between the user-facing edge and the SI interior.

Everything inside grainfrac is SI (Pa, m, s, kg, m3/s). Configs, tables and
plots speak the field's units (MPa, GPa, mm, ml/min, degrees); these factors are
the one place where the two meet. Multiply a user value by the factor to get SI,
divide an SI value by it to get the user unit.
"""

import math

MPA = 1.0e6  # Pa per MPa
GPA = 1.0e9  # Pa per GPa
GPA_PER_M = 1.0e9  # (Pa/m) per (GPa/m), contact stiffness
MM = 1.0e-3  # m per mm
ML_PER_MIN = 1.0e-6 / 60.0  # (m3/s) per (ml/min)
ML = 1.0e-6  # m3 per ml
DEG = math.pi / 180.0  # rad per degree

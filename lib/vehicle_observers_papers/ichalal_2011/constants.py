"""Constants of Ichalal, Arioui, Mammar, MED 2011 (autonomous bicycle).

Printed: k1 = k2 = 10, x3d = sin t, x4d = cos t, C = [[1,0,0,0],[0,0,1,0]], the premise
bounds of the Jacobian TS model 84.92 <= xi1 <= 167.83, 8.9 <= xi2 <= 19.95 and the
matrices A1..A4 (34) with the entry 30 in position (1, 2).

Inferred (see ../shared/papers/README.md): p = 0.6 m, v = 10 m/s, c = 0.5 m, g = 9.81 from
the factors 16.35 = g/p, 100 = v^2, 8.33 = c v/p of eqs. (32)-(33). The "30" in (31)/(34)
would be v and disagrees with v = 10: both are reported side by side in notebook 04.
"""

import numpy as np
from vehicle_observers.models.bicycle import BicycleParams

params = BicycleParams(p=0.6, c=0.5, v=10.0, g=9.81, k1=10.0, k2=10.0)
C = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])

xi1_bounds_printed = (84.92, 167.83)
xi2_bounds_printed = (8.9, 19.95)
A12_printed = 30.0


def printed_jacobian_vertices():
    """A1..A4 exactly as printed in (34) (ordering: h1 = F1^1 F2^1 ... see the paper)."""
    out = []
    for xi2 in xi2_bounds_printed:
        for xi1 in xi1_bounds_printed:
            A = np.zeros((4, 4))
            A[0, 1] = A12_printed
            A[2, 3] = 1.0
            A[3, 1] = xi1
            A[3, 2] = xi2
            out.append(A)
    return out

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


def printed_jacobian_entries(X, U, include_third: bool = False) -> np.ndarray:
    """Literal transcription of Ichalal 2011 eqs. (32)-(33) along states ``X`` (N, 4) and
    inputs ``U`` (N,), with ``z2 -> x2``, ``z3 -> x3`` (the printed ``z`` are the DMVT points):

        (32)  100 cos x3 x2 sin x3 + 100 cos x3 sin x3 (+ 1/3)
        (33)  16.35 cos x3 + 100 x2^2 cos^2 x3 - 8.33 u sin x3 - 100 x2^2 sin^2 x3 (+ 1/3)

    The trailing ``+ 1/3`` (garbled in the extraction) is added when ``include_third``.
    Returns (N, 2). Used only to explain the printed premise bounds: (33) lacks the term
    ``-(v^2/p) x2 sin x3`` of the exact derivative and (32) does not match ``(v^2/p) cos x3
    (1 + 2 p x2 sin x3)`` at all (it vanishes at x3 = 0 where the exact value is v^2/p).
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    U = np.ravel(U)
    x2, x3 = X[:, 1], X[:, 2]
    extra = 1.0 / 3.0 if include_third else 0.0
    xi1 = 100 * np.cos(x3) * x2 * np.sin(x3) + 100 * np.cos(x3) * np.sin(x3) + extra
    xi2 = (16.35 * np.cos(x3) + 100 * x2**2 * np.cos(x3) ** 2 - 8.33 * U * np.sin(x3)
           - 100 * x2**2 * np.sin(x3) ** 2 + extra)
    return np.column_stack([xi1, xi2])

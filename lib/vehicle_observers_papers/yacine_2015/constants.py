"""Constants of Yacine, Ichalal, Ait-Oufroukh, Mammar, Djennoune, IEEE TCST 23(2), 2015.

Printed in the paper (Table I and Sec. IV): m, I_z, a_f, a_r, l_s, r_f = r_r, the sector
bounds M_f1, M_f2, M_r1, M_r2, the speed bounds, alpha (decay), Ts.

Not printed: the Pacejka coefficients B, C, D, E. They are *chosen* here so that the
secant stiffness ``f(alpha) = F(alpha)/alpha`` spans exactly the paper's sector bounds over
``|alpha| <= 8 deg`` (the slip range the paper allows, Sec. II-A): ``B C D = M_1`` (slope at
zero slip) and ``f(8 deg) = M_2``, with ``C = 1.3`` (a typical lateral shape factor) and
``E = 0``; ``B`` solves the second condition (``Pacejka.from_sector``). The resulting peak
forces (D) are printed by ``tests/test_papers.py``.
"""

import numpy as np
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import Pacejka

m = 1500.0          # kg
I_z = 2454.0        # kg m^2
a_f = 1.1           # m
a_r = 1.44          # m
l_s = 0.5           # m, vision look-ahead
r_relax = 0.1       # m, relaxation length r_f = r_r (Table I)

M_f1, M_f2 = 4.2e4, 3.3e4   # N/rad, front secant-stiffness bounds (max, min)
M_r1, M_r2 = 4.9e4, 3.3e4   # N/rad, rear
vx_min, vx_max = 0.2, 17.0  # m/s
alpha_decay = 0.001         # Theorem 1 decay parameter alpha
Ts = 0.001                  # s, observer sampling period
alpha_slip_max = np.radians(8.0)  # rad, slip range of the TS sector

C_shape = 1.3
E_curv = 0.0

tire_f = Pacejka.from_sector(M_f1, M_f2, alpha_slip_max, C=C_shape, E=E_curv)
tire_r = Pacejka.from_sector(M_r1, M_r2, alpha_slip_max, C=C_shape, E=E_curv)

params = LateralParams(m=m, I_z=I_z, a_f=a_f, a_r=a_r, tire_f=tire_f, tire_r=tire_r,
                       r_f=r_relax, r_r=r_relax, l_s=l_s, name="Yacine 2015 (Satory car)")


def ts_model():
    """The paper's 8-submodel TS model (24) with its printed bounds."""
    from vehicle_observers.models.lateral import yacine_ts

    return yacine_ts(params, Mf=(M_f2, M_f1), Mr=(M_r2, M_r1), vx_bounds=(vx_min, vx_max))

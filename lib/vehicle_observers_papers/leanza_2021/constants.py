"""Constants of the real log: Revs Program 2014, Ferrari 250 LM (see data/revs_250lm_2014).

Vehicle parameters as used by the publishing repository MBDS/sideslip-angle-vehicle-
estimation (PROVENANCE.md): m, l_f, l_r, track, I_z (an approximation m/12 (1.7^2+4.09^2)),
linear cornering stiffness C_f = 0.7e5, C_r = 1.2e5 N/rad (tuned by them).

Chosen here (not in the source): Pacejka tyres with the same slope at zero slip
(``B C D = C_f, C_r``), peak ``D = mu F_z`` per axle with ``mu = 1.3`` (the filtered
lateral acceleration reaches 12 m/s^2, so mu >= 1.2) and static axle loads, ``C = 1.3``,
``E = 0``; relaxation length 0.1 m as in Yacine 2015 (no value is known for this car).
"""

from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import LinearTire, Pacejka

g = 9.81
m = 982.0
l_f = 1.33
l_r = 1.07
track = 1.35
I_z = m / 12.0 * (1.7**2 + 4.09**2)   # ~1605 kg m^2
C_f = 0.7e5
C_r = 1.2e5
steering_ratio = 13.529
mu = 1.3
C_shape = 1.3

Fz_f = m * g * l_r / (l_f + l_r)
Fz_r = m * g * l_f / (l_f + l_r)
D_f = mu * Fz_f
D_r = mu * Fz_r

tire_f = Pacejka(B=C_f / (C_shape * D_f), C=C_shape, D=D_f, E=0.0)
tire_r = Pacejka(B=C_r / (C_shape * D_r), C=C_shape, D=D_r, E=0.0)

params = LateralParams(m=m, I_z=I_z, a_f=l_f, a_r=l_r, tire_f=tire_f, tire_r=tire_r,
                       r_f=0.1, r_r=0.1, l_s=0.5, name="Revs Ferrari 250 LM")
linear_params = LateralParams(m=m, I_z=I_z, a_f=l_f, a_r=l_r, tire_f=LinearTire(C_f),
                              tire_r=LinearTire(C_r), r_f=0.1, r_r=0.1, l_s=0.5,
                              name="Revs Ferrari 250 LM (linear tyres)")

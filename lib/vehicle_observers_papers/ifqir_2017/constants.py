"""Constants of Ifqir, Ait-Oufroukh, Ichalal, Mammar, GTAA 2017 (slides): switched TS
interval observer with uncertain cornering stiffness.

Printed in the slides: the switching law (22) (bands 0-6, 6-11, 11-16.6 m/s), the +-10 %
stiffness uncertainty, and the Theorem 2 solution: diagonal ``P_i^j`` and gains ``L_i^j``
(3 modes x 4 vertices), below as ``P_printed`` (diagonals) and ``L_printed``. The slides
label the last gain ``L_4^4``; it is ``L_3^4`` (mode 3 has four gains, there is no mode 4).

Not printed (chosen here, see ../shared/papers/README.md): the vehicle. We use the same
group's Satory car (Yacine 2015): m = 1500 kg, I_z = 2454 kg m^2, l_f = 1.1 m,
l_r = 1.44 m, and nominal stiffness from the same tyre sector bounds: ``c_0 = M_1 / 1.1``
(front 4.2e4, rear 4.9e4 N/rad are the zero-slip slopes of Yacine's tyres), so that the
+-10 % box ``[0.9 c_0, 1.1 c_0]`` has the linear-range stiffness as its upper edge and
reaches down to 0.82 M_1, i.e. it contains the secant stiffness of the Pacejka tyres up to
a few degrees of slip (front: 6.4 deg, rear: 3.6 deg with ``yacine_2015.constants`` tyres).

Design constants (not printed; chosen here): ISS decay ``eps_decay`` = 1 1/s, Metzler
diagonal shift ``epsilon_shift`` = 1000 1/s (bounds the gains), membership-rate bound from
``|dv_x/dt| <= 3 m/s^2`` (the braking limit of ``scenarios.emulated_satory``), normalisation
``P >= I``. The lowest band starts at 0.1 m/s (the model divides by ``v_x``; the slides'
"0 < v_x" has no usable bound) and the highest ends at 17.5 m/s (the emulated run reaches
17 m/s, above the slides' 16.6).
"""

import numpy as np
from vehicle_observers.models.uncertain_bicycle import SpeedBands, UncertainBicycle

from vehicle_observers_papers.yacine_2015 import constants as yacine2015

m = yacine2015.m          # kg
I_z = yacine2015.I_z      # kg m^2
l_f = yacine2015.a_f      # m
l_r = yacine2015.a_r      # m
c_f0 = yacine2015.M_f1 / 1.1   # N/rad, nominal front axle stiffness
c_r0 = yacine2015.M_r1 / 1.1   # N/rad, nominal rear axle stiffness
rel_unc = 0.10                 # slides: "10% uncertainty in their nominal value"

vehicle = UncertainBicycle(m=m, I_z=I_z, l_f=l_f, l_r=l_r, c_f0=c_f0, c_r0=c_r0,
                           rel_unc=rel_unc, name="Satory car (Yacine 2015), +-10 % stiffness")

#: switching law (22) as printed [m/s]; the lower edge 0 is not usable (1/v_x)
bands_printed = (0.0, 6.0, 11.0, 16.6)
#: bands used here (lower edge 0.1 m/s, upper 17.5 m/s; inner edges as printed)
bands = SpeedBands((0.1, 6.0, 11.0, 17.5))
#: single-mode (non-switched) comparison observer over the same speed range
bands_single = SpeedBands((0.1, 17.5))

eps_decay = 1.0          # 1/s
epsilon_shift = 1000.0   # 1/s
accel_max = 3.0          # m/s^2
p_min = 1.0
Ts = 0.001               # s, 1 kHz like the Satory data
#: vertex polarity of the premise 1/v_x (not printed). False: vertices 1-2 use its lower
#: bound 1/v_max, vertices 3-4 its upper bound 1/v_min (the reverse of the :mod:`models.ts`
#: convention). Chosen because the Theorem 2 gains designed with it are closer to the printed
#: ones (mean |log10 L/L_printed| 0.39 against 0.64 over the 3 modes) and put the largest
#: L2 of mode 1 at vertices 1-2, where the slides print L2 = 4383 (notebook 03, Reproduction;
#: tests/papers/test_ifqir2017.py)
inv_vx_upper_first = False

# ---- printed Theorem 2 solution (slides, "Solving the linear matrix inequalities") -------
#: P_i^j diagonals, shape (3 modes, 4 vertices, 2)
P_printed = np.array([
    [[0.0080, 0.0205], [0.0080, 0.0205], [0.0080, 0.3545], [0.0080, 0.3396]],
    [[0.2891, 0.4252], [0.2891, 0.4465], [0.2870, 0.5521], [0.2870, 0.5521]],
    [[0.0673, 0.3219], [0.0673, 0.3171], [0.0673, 0.3407], [0.0673, 0.3407]],
])
#: L_i^j, shape (3, 4, 2); mode 1 vertices 1-2 are printed as 10^3 [-0.0136, 4.3830] etc.
L_printed = np.array([
    [[-13.6, 4383.0], [-7.8, 4381.3], [-70.1966, 260.5428], [-68.2978, 272.1352]],
    [[-11.1729, 153.0217], [-6.2345, 145.5492], [-12.6483, 120.0691], [-7.7325, 119.1450]],
    [[-19.1574, 331.7307], [-13.6983, 336.8248], [-19.5678, 314.5372], [-14.0961, 316.8263]],
])


def model(bands_: SpeedBands | None = None, veh: UncertainBicycle | None = None,
          inv_vx_upper_first: bool | None = None):
    """The switched interval model with this module's vehicle and bands.
    ``inv_vx_upper_first``: vertex polarity of the premise ``1/v_x`` (True: vertices 1-2
    use the upper bound ``1/v_min``; False: the lower bound ``1/v_max``). The slides do not
    say which; both are compared with the printed gains in notebook 03."""
    from vehicle_observers.models.uncertain_bicycle import SwitchedIntervalModel

    pol = globals()["inv_vx_upper_first"] if inv_vx_upper_first is None else inv_vx_upper_first
    return SwitchedIntervalModel(veh or vehicle, bands_ or bands, pol)


def design(bands_: SpeedBands | None = None, veh: UncertainBicycle | None = None,
           inv_vx_upper_first: bool | None = None, **kw):
    """Theorem 2 design with this module's constants (keywords override them)."""
    from vehicle_observers.observers.interval import design_theorem2

    opts = dict(eps_decay=eps_decay, epsilon_shift=epsilon_shift, accel_max=accel_max,
                p_min=p_min)
    opts.update(kw)
    return design_theorem2(model(bands_, veh, inv_vx_upper_first), **opts)


# ---- choices for the real log (Revs Ferrari 250 LM, 100 Hz, v_x 16.5-61 m/s) -------------
#: vehicle from leanza_2021.constants (m, I_z, l_f, l_r, tuned C_f, C_r as nominal), +-10 %
revs_rel_unc = 0.10
#: three bands of similar v_max / v_min ratio covering 16.5-61.2 m/s, and one band
revs_bands = SpeedBands((16.0, 30.0, 45.0, 62.0))
revs_bands_single = SpeedBands((16.0, 62.0))
#: (20) shift = 1/T_s so one Euler step per 10 ms sample keeps the discrete positivity
revs_epsilon_shift = 100.0
#: |dv_x/dt| bound [m/s^2]: the log's |a_x| reaches 11.0 m/s^2
revs_accel_max = 12.0
#: measurement bounds: about 4 std of the high-frequency part of each channel
#: (yaw rate 0.0049 rad/s, steering 0.0024 rad after despiking)
revs_y_noise = 0.02
revs_steer_noise = 0.01


def revs_vehicle(rel_unc: float = revs_rel_unc) -> UncertainBicycle:
    from vehicle_observers_papers.leanza_2021 import constants as rv

    return UncertainBicycle(m=rv.m, I_z=rv.I_z, l_f=rv.l_f, l_r=rv.l_r, c_f0=rv.C_f,
                            c_r0=rv.C_r, rel_unc=rel_unc,
                            name=f"Revs Ferrari 250 LM, +-{100 * rel_unc:g} % stiffness")


def revs_design(bands_: SpeedBands | None = None, rel_unc: float = revs_rel_unc, **kw):
    """Theorem 2 design for the real log with the choices above."""
    opts = dict(eps_decay=eps_decay, epsilon_shift=revs_epsilon_shift,
                accel_max=revs_accel_max, p_min=p_min)
    opts.update(kw)
    from vehicle_observers.observers.interval import design_theorem2

    return design_theorem2(model(bands_ or revs_bands, revs_vehicle(rel_unc)), **opts)

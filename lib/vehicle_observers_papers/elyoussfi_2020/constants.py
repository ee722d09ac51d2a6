"""Constants and reconstruction choices for the relaxed UIO paper (Hindawi J. Control Sci.
Eng. 2020, article 8797482; El Youssfi et al. line of work, cf. Optim. Control Appl. Meth.
2021, doi:10.1002/oca.2808).

The extraction kept **no formula and no number**: every value below is a *choice* of this
reproduction, made so the paper's surviving structure can be exercised. Each choice is
written here and repeated in Notebook 06.

Vehicle (the paper's Table 1 cites [40]; values lost). We use the same group's car as the
rest of the repository (Yacine 2015 Table I): m, I_z, l_f, l_r, and its per-axle Pacejka
tyres (:mod:`.yacine2015`) as the "true" cornering-force curves that the fuzzy forces (2)
are identified from (Levenberg-Marquardt, as in Sec. 2.2). Constant speed (Sec. 5 says
v_x is constant; its value is lost): ``vx = 15 m/s``. No yaw moment (M_z = 0, Sec. 5).

Main problem (``build_model()``, variant ``"adhesion"``): the paper states that every pair
(A_i, C) is observable and plots both states; with two sensors on the three-dimensional
augmented state, the only sensor sets on which a decoupled observer sees v_y are those that
read it (with yaw-rate sensors only, an uncertainty on the r equation hides v_y, and one on the
v_y equation cannot be decoupled: Notebook 06, Sec. 2). So ``C = I_2`` (v_y from an optical
ground-speed sensor, r from the gyro), the fault on the gyro ``F_s = [0, 1]^T`` and on the
steering actuator, and the uncertainty (10) of Sec. 3 ("variation of the road adhesion
coefficient") as a relative error ``rho`` on the rear cornering force, direction
``M = [1/m, -l_r/I_z]^T`` (both equations). Then ``Cbar Mbar`` has rank 1, ``T`` mixes v_y and
r, and ``(T Abar_i, Cbar)`` has no unobservable mode. The front axle is not used: its force
direction ``[1/m, l_f/I_z]^T`` is that of the actuator fault (``B_i = C_fi [1/m, l_f/I_z]^T``),
so decoupling it also decouples the actuator part of ``f`` and the fault is then seen only in
``r + f`` (``build_model(rear=False)``: fault error ~ 0.03 rad on a 0.01 rad fault). Design
decay rate ``alpha_design = 5`` 1/s (chosen here; the verdicts at 2, 10 and 20 1/s are reported
beside it).

Diagnostic variant ``"yaw"`` (the previous main problem, v_y **not measured**): two yaw-rate sources,
``y = C x + F_s f`` with ``C = [[0, 1], [0, 1]]`` (row 1: the gyro, row 2: the yaw rate
from the rear wheel-speed difference of the ABS sensors) and the fault on the gyro,
``F_s = [1, 0]^T``; the actuator part of the *same* fault ``f`` adds to the steering angle
(Sec. 6: "an identical fault affects the actuator and the sensor"). Uncertainty (10):
a relative error ``rho`` on ``1/I_z`` (payload placement), ``M = [0, 1]^T``. Then
``Cbar Mbar = [1, 1]^T`` has rank 1 = rank(Mbar) and (T Abar_i, Cbar) is detectable: its only
unobservable mode is the open-loop lateral-velocity mode ``[A_i]_11`` (-4.05 and -0.99 1/s),
so the decay rate must stay below 0.99 1/s (``alpha_yaw = 0.5``).

Comparison variant (``build_model(variant="full")``, the first version of this
reproduction): ``C = I_2`` (v_y also measured), fault on the gyro, ``M = [1, 0]^T`` (error on
``1/m``). There v_y lies in the decoupled direction and its "estimate" is the measurement.
"""

import numpy as np

from vehicle_observers_papers.yacine_2015.constants import I_z, m, tire_f, tire_r
from vehicle_observers_papers.yacine_2015.constants import a_f as l_f
from vehicle_observers_papers.yacine_2015.constants import a_r as l_r

__all__ = ["m", "I_z", "l_f", "l_r", "tire_f", "tire_r"]

vx = 15.0                          # m/s, constant longitudinal speed (choice)
alpha_fit_max = np.radians(8.0)    # rad, slip range of the LM identification (Yacine 2015)
n_fit = 401                        # grid points per axle for the identification
# initial guess (a [rad], b [-], c [rad], C_f1, C_f2, C_r1, C_r2 [N/rad]) for LM
fit_x0 = (np.radians(4.0), 1.0, 0.0, 4.2e4, 2.5e4, 4.9e4, 2.5e4)

# main problem: v_y unmeasured; gyro (faulty) and wheel-speed yaw rate
C = np.array([[0.0, 1.0], [0.0, 1.0]])   # y = [r_gyro, r_wheel]
F_s = np.array([[1.0], [0.0]])     # sensor part of the fault: the gyro (rad/s per rad)
M = np.array([[0.0], [1.0]])       # uncertainty direction: 1/I_z error
rho = 0.2                          # +-20 % on 1/I_z
sigma_gyro = 0.002                 # rad/s, gyro noise standard deviation
sigma_wheel = 0.005                # rad/s, wheel-speed yaw-rate noise standard deviation

# main problem: C = I, fault on the gyro and the actuator, front cornering-force error
C_adh = np.eye(2)                  # y = [v_y (optical sensor), r (gyro)]
F_s_adh = np.array([[0.0], [1.0]])  # sensor part of the fault: the gyro
sigma_vy_adh = 0.02                # m/s, optical lateral-velocity sensor noise
sigma_gyro_adh = 0.002             # rad/s
#: uncertainty sizes of the map (relative error on the rear cornering force; rho = 0.2 is the main one)
rho_map = (0.1, 0.2, 0.4)

# comparison variant (C = I): v_y measured, uncertainty on 1/m
C_full = np.eye(2)                 # y = [v_y, r]
F_s_full = np.array([[0.0], [1.0]])
M_full = np.array([[1.0], [0.0]])
sigma_vy = 0.02                    # m/s
sigma_r = 0.002                    # rad/s
alpha_full = 2.0                   # 1/s, design decay rate of the variant
phi_full = 10.0                    # 1/s, the variant's first (run-based) phi

# normalisation of the estimation-error output (typical magnitudes) and of the fault rate
scale_x = np.array([0.5, 0.2, 0.02])   # v_y [m/s], r [rad/s], f [rad]
scale_fdot = 0.05                      # rad/s, fault-rate bound (also the L2-index scale)

# stated input bound behind phi (Assumption 2): road-wheel steering rate
delta_dot_max = 0.3                # rad/s (~ 260 deg/s at the steering wheel, ratio 15)

# design parameters (Theorem 2 / Remark 2: "chosen arbitrarily ... feasible"); sweep ranges
alpha_design = 5.0                 # 1/s, decay rate (V' <= -2 alpha V) of the main problem
alpha_sensitivity = (2.0, 5.0, 10.0, 20.0)   # 1/s, decay rates of the sensitivity rows
alpha_yaw = 0.5                    # 1/s, of the "yaw" variant (below its v_y mode 0.99)
mu_grid = (1e-6, 1e-3, 1e-2)       # s, Finsler slack scalar mu (line search, Remark 2)
#: LMI strictness (time-scaled units) of the main problem's designs and map: with 1e-6 the
#: gamma-optimal solutions sit at round-off (relative margin < 1e-9 or condition > 1e8:
#: "inconclusive"); 1e-3 keeps every certificate above it at a gamma cost below 1 %
lmi_eps = 1e-3
radius = 200.0                     # 1/s, observer poles kept in |lambda| < radius (1 kHz RK4)

# scenario (Fig. 3 analogue): steering, fault, uncertainty signal
t_end = 20.0                       # s
dt = 1e-3                          # s (1 kHz)
t_fault = 8.0                      # s, fault appears
x0_true = np.array([0.3, 0.05])    # v_y [m/s], r [rad/s] (system initial state)
fault_offset = 0.01                # rad, fault offset after t_fault
fault_amp = 0.005                  # rad, amplitude of its 0.5 Hz sine


def build_model(rho_value: float | None = None, variant: str = "adhesion", rear: bool = True):
    """Identify the fuzzy forces from the Pacejka tyres and build the uncertain TS model.

    ``variant="adhesion"`` (main problem: C = I, gyro + actuator fault, rear-force error;
    ``rear=False``: front-force error, see the module docstring),
    ``"yaw"`` (the previous main problem, v_y unmeasured; diagnostic) or ``"full"``
    (C = I, error on 1/m)."""
    from vehicle_observers.models.uncertain_lateral import UncertainLateralTS, fit_fuzzy_forces

    ty = fit_fuzzy_forces(tire_f, tire_r, alpha_fit_max, n_fit, fit_x0)
    r = rho if rho_value is None else rho_value
    if variant == "adhesion":
        M_r = np.array([[1.0 / m], [-l_r / I_z]]) if rear else np.array([[1.0 / m], [l_f / I_z]])
        return UncertainLateralTS(m, I_z, l_f, l_r, vx, ty, C_adh, F_s_adh, M_r, r,
                                  np.diag([sigma_vy_adh, sigma_gyro_adh]), scale_x, scale_fdot)
    if variant == "yaw":
        return UncertainLateralTS(m, I_z, l_f, l_r, vx, ty, C, F_s, M, r,
                                  np.diag([sigma_gyro, sigma_wheel]), scale_x, scale_fdot)
    if variant == "full":
        return UncertainLateralTS(m, I_z, l_f, l_r, vx, ty, C_full, F_s_full, M_full, r,
                                  np.diag([sigma_vy, sigma_r]), scale_x, scale_fdot)
    raise ValueError(f"variant must be 'adhesion', 'yaw' (v_y unmeasured) or 'full' (C = I), "
                     f"got {variant!r}")

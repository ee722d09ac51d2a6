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

Measurements: ``y = C x + F_s f`` with ``C = I_2`` (lateral velocity and yaw rate, both
sensed) and the fault on the yaw-rate gyro, ``F_s = [0, 1]^T`` (rad/s per rad); the
actuator part of the *same* fault ``f`` adds to the steering angle, ``E_f = B_i`` (Sec. 6:
"an identical fault affects the actuator and the sensor").

Uncertainty (10): ``Delta A_i = M F(t) N_{a,i}``, ``Delta B_i = M F(t) N_{b,i}``,
``|F| <= 1``; we take a relative error ``rho`` on ``1/m`` (payload), so ``M = [1, 0]^T``
(full column rank, as the text requires) and ``N_{a,i} = rho [A_i]_{1, forces}``,
``N_{b,i} = rho [B_i]_1``. One column is the most the UIO can decouple with two outputs.
"""

import numpy as np

from vehicle_observers.papers.yacine2015 import I_z, m, tire_f, tire_r
from vehicle_observers.papers.yacine2015 import a_f as l_f
from vehicle_observers.papers.yacine2015 import a_r as l_r

__all__ = ["m", "I_z", "l_f", "l_r", "tire_f", "tire_r"]

vx = 15.0                          # m/s, constant longitudinal speed (choice)
alpha_fit_max = np.radians(8.0)    # rad, slip range of the LM identification (Yacine 2015)
n_fit = 401                        # grid points per axle for the identification
# initial guess (a [rad], b [-], c [rad], C_f1, C_f2, C_r1, C_r2 [N/rad]) for LM
fit_x0 = (np.radians(4.0), 1.0, 0.0, 4.2e4, 2.5e4, 4.9e4, 2.5e4)

C = np.eye(2)                      # y = [v_y, r] (both sensed)
F_s = np.array([[0.0], [1.0]])     # sensor part of the fault: yaw-rate gyro
M = np.array([[1.0], [0.0]])       # uncertainty direction (1/m error)
rho = 0.2                          # +-20 % on 1/m

# measurement noise (standard deviations) used in the L2-gain index and in the simulation
sigma_vy = 0.02                    # m/s
sigma_r = 0.002                    # rad/s

# normalisation of the estimation-error output (typical magnitudes) and of the fault rate
scale_x = np.array([0.5, 0.2, 0.02])   # v_y [m/s], r [rad/s], f [rad]
scale_fdot = 0.05                      # rad/s, typical fault rate

# design parameters (Theorem 2 / Remark 2: "chosen arbitrarily ... feasible"); sweep ranges
alpha_design = 2.0                 # 1/s, decay rate of the Lyapunov function (V' <= -2 alpha V)
phi_design = 10.0                  # 1/s, |dh_i/dt| bound (Assumption 2; run max ~ 6 1/s)
mu_grid = (1e-6, 1e-3, 1e-2)       # s, Finsler slack scalar mu (line search, Remark 2)
radius = 200.0                     # 1/s, observer poles kept in |lambda| < radius (1 kHz RK4)
gamma_level = 0.55                 # L2-gain level defining the feasibility map

# scenario (Fig. 3 analogue): steering, fault, uncertainty signal
t_end = 20.0                       # s
dt = 1e-3                          # s (1 kHz)
t_fault = 8.0                      # s, fault appears
x0_true = np.array([0.3, 0.05])    # v_y [m/s], r [rad/s] (system initial state)


def build_model(rho_value: float | None = None):
    """Identify the fuzzy forces from the Pacejka tyres and build the uncertain TS model."""
    from vehicle_observers.observers.uio import UncertainLateralTS, fit_fuzzy_forces

    ty = fit_fuzzy_forces(tire_f, tire_r, alpha_fit_max, n_fit, fit_x0)
    return UncertainLateralTS(m, I_z, l_f, l_r, vx, ty, C, F_s, M,
                              rho if rho_value is None else rho_value,
                              np.diag([sigma_vy, sigma_r]), scale_x, scale_fdot)

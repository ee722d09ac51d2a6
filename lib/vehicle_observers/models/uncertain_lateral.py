"""Uncertain two-rule Takagi-Sugeno lateral model with an actuator + sensor fault (El Youssfi
et al., Hindawi J. Control Sci. Eng. 2020, reconstruction; eqs. (1)-(15)), the plant of the
relaxed UIO of :mod:`vehicle_observers.observers.uio`.

Model, eqs. (1)-(9) (states ``x = [v_y (m/s), r (rad/s)]``, input ``delta`` (rad))::

    v_y' = (F_f + F_r)/m - v_x r,      r' = (l_f F_f - l_r F_r)/I_z
    alpha_f = delta - (v_y + l_f r)/v_x,   alpha_r = -(v_y - l_r r)/v_x
    F_f = (h_1 C_f1 + h_2 C_f2) alpha_f,  F_r = (h_1 C_r1 + h_2 C_r2) alpha_r     (2)
    h_1 = 1 / (1 + |(alpha_f - c)/a|^(2b)),  h_2 = 1 - h_1                          (5)-(7)

Reconstruction: the membership parameters are named (a, b, c) in the text, which is the
generalised-bell function; both axles share the memberships of the *front* slip angle (two
rules, Fig. 7 shows h_1', h_2'), as in the Chadli / El Hajjaji vehicle models the paper
builds on. (a, b, c, C_f1, C_f2, C_r1, C_r2) are identified by Levenberg-Marquardt least
squares (``scipy.optimize.least_squares(method='lm')``) on the Pacejka curves of the
foundation (:func:`fit_fuzzy_forces`).

Uncertain faulty TS model, eqs. (9)-(13)::

    x' = sum h_i [(A_i + dA_i) x + (B_i + dB_i)(delta + f)],  y = C x + F_s f
    dA_i = M F(t) N_ai, dB_i = M F(t) N_bi, F^T F <= I      ->  + M d,  d = F (N_a x + N_b u)

Augmented system (14)-(15): ``X = [x; f]``, ``Abar_i = [[A_i, B_i], [0, 0]]``,
``Cbar = [C, F_s]``, ``Mbar = [M; 0]``, ``Gam = [0; 0; 1]`` (:meth:`UncertainLateralTS.augmented`,
normalised). The observer side (UIO (20)-(24), designs) is in :mod:`vehicle_observers.observers.uio`.

Arrays: time series (N,), states (N, 2), memberships (N, 2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models.tires import magic_formula

#: :attr:`UncertainLateralTS.unc_row` of an error on the front / rear cornering force (both
#: rows of the model)
UNC_FRONT, UNC_REAR = 2, 3


# ---------------------------------------------------------------- fuzzy cornering forces --
def gbell(alpha, a, b, c):
    """Membership h_1 (5)-(7), generalised bell ``1 / (1 + |(alpha - c)/a|^(2b))``."""
    u = np.abs((np.asarray(alpha, dtype=float) - c) / a)
    return 1.0 / (1.0 + u ** (2.0 * b))


def gbell_derivative(alpha, a, b, c):
    """``d h_1 / d alpha`` [1/rad] of :func:`gbell` (used for Assumption 2 bounds)."""
    x = (np.asarray(alpha, dtype=float) - c) / a
    u = np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        du = np.where(u > 0, 2.0 * b * u ** (2.0 * b - 1.0) * np.sign(x) / a, 0.0)
    return -du / (1.0 + u ** (2.0 * b)) ** 2


@dataclass(frozen=True)
class FuzzyTyres:
    """Fuzzy cornering forces (2): ``F = (h_1 C_1 + h_2 C_2) alpha`` per axle [N].

    a [rad], b [-], c [rad]: bell membership of the front slip angle; C_f1, C_f2, C_r1,
    C_r2 [N/rad]: rule stiffnesses. ``rms_rel``: RMS fit residual relative to the peak
    force; ``cost``/``nfev``/``status`` from the LM solver.
    """

    a: float
    b: float
    c: float
    C_f: tuple[float, float]
    C_r: tuple[float, float]
    rms_rel: float = float("nan")
    max_rel: float = float("nan")
    nfev: int = 0
    status: int = 0

    def memberships(self, alpha_f):
        """(N, 2) memberships ``[h_1, h_2]`` of the front slip angle."""
        h1 = gbell(alpha_f, self.a, self.b, self.c)
        return np.stack([h1, 1.0 - h1], axis=-1)

    def force_front(self, alpha):
        h1 = gbell(alpha, self.a, self.b, self.c)
        return (h1 * self.C_f[0] + (1 - h1) * self.C_f[1]) * np.asarray(alpha, dtype=float)

    def force_rear(self, alpha_r, alpha_f=None):
        """Rear force; the membership is that of ``alpha_f`` (defaults to ``alpha_r``)."""
        af = alpha_r if alpha_f is None else alpha_f
        h1 = gbell(af, self.a, self.b, self.c)
        return (h1 * self.C_r[0] + (1 - h1) * self.C_r[1]) * np.asarray(alpha_r, dtype=float)

    def as_array(self) -> np.ndarray:
        return np.array([self.a, self.b, self.c, *self.C_f, *self.C_r], dtype=float)


def fit_fuzzy_forces(tire_f, tire_r, alpha_max: float, n: int = 401, x0=None) -> FuzzyTyres:
    """Identify (a, b, c, C_f1, C_f2, C_r1, C_r2) of (2)/(5) from two Pacejka curves.

    Paper Sec. 2.2: "Levenberg-Marquardt algorithm-based identification combined with the
    least square method". Residuals: front and rear force errors on ``n`` slip angles in
    ``[-alpha_max, alpha_max]`` [rad], each divided by that tyre's peak force ``D``.
    ``x0``: initial guess (a, b, c, C_f1, C_f2, C_r1, C_r2).
    """
    if not (np.isfinite(alpha_max) and alpha_max > 0):
        raise ObserverArgumentError(f"alpha_max must be a positive slip angle [rad], got {alpha_max}")
    al = np.linspace(-alpha_max, alpha_max, int(n))
    Ff, Fr = tire_f.force(al), tire_r.force(al)
    Df, Dr = float(np.max(np.abs(Ff))), float(np.max(np.abs(Fr)))

    def resid(th):
        a, b, c, cf1, cf2, cr1, cr2 = th
        h1 = gbell(al, a, b, c)
        return np.r_[((h1 * cf1 + (1 - h1) * cf2) * al - Ff) / Df,
                     ((h1 * cr1 + (1 - h1) * cr2) * al - Fr) / Dr]

    if x0 is None:
        k0f, k0r = tire_f.cornering_stiffness, tire_r.cornering_stiffness
        x0 = (alpha_max / 2, 1.0, 0.0, k0f, 0.6 * k0f, k0r, 0.6 * k0r)
    scale = [alpha_max, 1.0, alpha_max, *(4 * [max(tire_f.cornering_stiffness, 1.0)])]
    from scipy.optimize import least_squares

    res = least_squares(resid, np.asarray(x0, dtype=float), method="lm", x_scale=scale,
                        xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=20000)
    a, b, c, cf1, cf2, cr1, cr2 = res.x
    if not res.success or a == 0 or b <= 0:
        raise RuntimeError(f"fuzzy-force identification failed: {res.message} (a={a}, b={b})")
    return FuzzyTyres(abs(a), b, c, (cf1, cf2), (cr1, cr2),
                      rms_rel=float(np.sqrt(np.mean(res.fun**2))),
                      max_rel=float(np.max(np.abs(res.fun))), nfev=int(res.nfev),
                      status=int(res.status))


# ------------------------------------------------------------ uncertain faulty TS model --
@dataclass
class UncertainLateralTS:
    """Uncertain two-rule TS lateral model with actuator + sensor fault, eqs. (8)-(15).

    m [kg], I_z [kg m^2], l_f, l_r [m], vx [m/s], tyres: :class:`FuzzyTyres`.
    C (p, 2), F_s (p, 1): ``y = C x + F_s f``. M (2, 1): uncertainty direction, ``[1, 0]^T``
    (relative error ``rho`` on ``1/m``), ``[0, 1]^T`` (on ``1/I_z``) or ``[1/m, l_f/I_z]^T``
    (relative error ``rho`` on the front cornering force, ``d = rho F(t) F_f`` [N]) or
    ``[1/m, -l_r/I_z]^T`` (on the rear force, ``d = rho F(t) F_r``); only the
    simulation uses ``rho`` (the UIO decouples it).
    D_w (p, p): noise standard deviations (unit-variance ``w``); scale_x (3,): error
    normalisation of ``[v_y, r, f]``; scale_fdot: fault-rate normalisation [rad/s].
    """

    m: float
    I_z: float
    l_f: float
    l_r: float
    vx: float
    tyres: FuzzyTyres
    C: np.ndarray
    F_s: np.ndarray
    M: np.ndarray
    rho: float = 0.2
    D_w: np.ndarray = field(default_factory=lambda: np.diag([0.02, 0.002]))
    scale_x: np.ndarray = field(default_factory=lambda: np.array([0.5, 0.2, 0.02]))
    scale_fdot: float = 0.05

    def __post_init__(self):
        self.C = np.atleast_2d(np.asarray(self.C, dtype=float))
        self.F_s = np.asarray(self.F_s, dtype=float)
        if self.F_s.size != len(self.C):
            raise ObserverArgumentError(f"F_s must be ({len(self.C)}, 1) (one fault, one entry per output "
                                        f"row of C), got shape {self.F_s.shape}")
        self.F_s = self.F_s.reshape(len(self.C), 1)
        self.M = np.asarray(self.M, dtype=float).reshape(2, -1)
        if self.M.shape != (2, 1) or not (np.count_nonzero(self.M) == 1 or any(np.allclose(
                self.M, d, rtol=1e-12, atol=0.0) for d in self.axle_directions())):
            raise ObserverArgumentError(f"M must be [1, 0]^T (1/m error), [0, 1]^T (1/I_z error), "
                                        f"[1/m, l_f/I_z]^T (front) or [1/m, -l_r/I_z]^T (rear "
                                        f"cornering-force error), got {self.M.ravel().tolist()}")
        self.D_w = np.atleast_2d(np.asarray(self.D_w, dtype=float))
        self.scale_x = np.asarray(self.scale_x, dtype=float)
        if self.vx <= 0:
            raise ObserverArgumentError(f"vx must be > 0 m/s, got {self.vx}")
        if self.C.shape[1] != 2:
            raise ObserverArgumentError(f"C must have 2 columns (v_y, r), got shape {self.C.shape}")
        if self.F_s.shape != (len(self.C), 1):
            raise ObserverArgumentError(f"F_s must be ({len(self.C)}, 1) (one fault), got {self.F_s.shape}")
        if self.D_w.shape != (len(self.C), len(self.C)):
            raise ObserverArgumentError(f"D_w must be ({len(self.C)}, {len(self.C)}), got {self.D_w.shape}")
        if self.scale_x.shape != (3,) or np.any(self.scale_x <= 0) or self.scale_fdot <= 0:
            raise ObserverArgumentError("scale_x must be 3 positive numbers and scale_fdot > 0")

    # --- rule matrices ------------------------------------------------------------------
    def rule_matrices(self, Cf: float, Cr: float):
        """``A (2,2), B (2,1)`` of the bicycle model with stiffnesses Cf, Cr [N/rad]."""
        m, Iz, lf, lr, vx = self.m, self.I_z, self.l_f, self.l_r, self.vx
        A = np.array([[-(Cf + Cr) / (m * vx), -(lf * Cf - lr * Cr) / (m * vx) - vx],
                      [-(lf * Cf - lr * Cr) / (Iz * vx), -(lf**2 * Cf + lr**2 * Cr) / (Iz * vx)]])
        B = np.array([[Cf / m], [lf * Cf / Iz]])
        return A, B

    @property
    def A(self) -> np.ndarray:
        """(2, 2, 2) rule matrices A_i (8)."""
        return np.array([self.rule_matrices(cf, cr)[0]
                         for cf, cr in zip(self.tyres.C_f, self.tyres.C_r)])

    @property
    def B(self) -> np.ndarray:
        return np.array([self.rule_matrices(cf, cr)[1]
                         for cf, cr in zip(self.tyres.C_f, self.tyres.C_r)])

    def axle_directions(self):
        """Directions ``(M_front, M_rear)`` (2, 1) of an error on one axle's cornering force:
        ``[1/m, l_f/I_z]^T`` and ``[1/m, -l_r/I_z]^T`` (per newton of force)."""
        return (np.array([[1.0 / self.m], [self.l_f / self.I_z]]),
                np.array([[1.0 / self.m], [-self.l_r / self.I_z]]))

    @property
    def unc_row(self) -> int:
        """What the uncertainty hits: 0 (``1/m``, v_y equation), 1 (``1/I_z``, r equation) or
        :data:`UNC_FRONT` = 2 (the front cornering force ``F_f``, both equations, direction
        ``M = [1/m, l_f/I_z]^T``) or :data:`UNC_REAR` = 3 (the rear force ``F_r``,
        ``M = [1/m, -l_r/I_z]^T``): a road-adhesion / stiffness error on one axle."""
        if np.count_nonzero(self.M) == 2:
            return UNC_FRONT if self.M[1, 0] > 0 else UNC_REAR
        return int(np.flatnonzero(self.M[:, 0])[0])

    def uncertainty_matrices(self):
        """``N_a (2, 1, 2), N_b (2, 1, 1)`` of (10): ``rho`` times the force part of the row
        of A_i, B_i selected by ``M`` (scaled by ``1/M[row]``)."""
        k = self.unc_row
        Na, Nb = [], []
        if k == UNC_FRONT:       # d = rho F C_fi alpha_f, alpha_f = delta - (v_y + l_f r)/v_x
            for cf in self.tyres.C_f:
                Na.append(self.rho * cf * np.array([[-1.0 / self.vx, -self.l_f / self.vx]]))
                Nb.append(self.rho * cf * np.array([[1.0]]))
            return np.array(Na), np.array(Nb)
        if k == UNC_REAR:        # d = rho F C_ri alpha_r, alpha_r = -(v_y - l_r r)/v_x
            for cr in self.tyres.C_r:
                Na.append(self.rho * cr * np.array([[-1.0 / self.vx, self.l_r / self.vx]]))
                Nb.append(np.zeros((1, 1)))
            return np.array(Na), np.array(Nb)
        for A, B in zip(self.A, self.B):
            row = A[k].copy()
            if k == 0:
                row[1] += self.vx       # remove the kinematic -v_x r term (not scaled by 1/m)
            Na.append(self.rho * row[None, :] / self.M[k, 0])
            Nb.append(self.rho * B[k][None, :] / self.M[k, 0])
        return np.array(Na), np.array(Nb)

    # --- augmented system (14)-(15), in normalised coordinates --------------------------
    def augmented(self):
        """Normalised augmented matrices ``(Abar (r,3,3), Bbar (r,3,1), Cbar (p,3),
        Mbar (3,nd), Gam (3,1), Dw (p,p))`` with ``X = S X_s``, ``y = R y_s``,
        S = diag(scale_x), R = :meth:`output_scale` (the scale of the state each row of C
        reads)."""
        S = np.diag(self.scale_x)
        R = self.output_scale()
        Si, Ri = np.linalg.inv(S), np.linalg.inv(R)
        Ab, Bb = [], []
        for A, B in zip(self.A, self.B):
            Aa = np.zeros((3, 3))
            Aa[:2, :2], Aa[:2, 2:] = A, B
            Ab.append(Si @ Aa @ S)
            Bb.append(Si @ np.vstack([B, [[0.0]]]))
        Cb = Ri @ np.hstack([self.C, self.F_s]) @ S
        Mb = Si @ np.vstack([self.M, np.zeros((1, self.M.shape[1]))])
        Gam = Si @ np.array([[0.0], [0.0], [self.scale_fdot]])
        Dw = Ri @ self.D_w
        return np.array(Ab), np.array(Bb), Cb, Mb, Gam, Dw

    def output_scale(self) -> np.ndarray:
        """Output normalisation R (p, p): the state scale of the sensed state for each row
        of C that picks one state, 1 otherwise."""
        R = np.ones(len(self.C))
        for k, row in enumerate(self.C):
            nz = np.flatnonzero(row)
            if len(nz) == 1:
                R[k] = self.scale_x[nz[0]] * abs(row[nz[0]])
        return np.diag(R)



# ---------------------------------------------------------------------- simulation -------
#: index of each entry of the packed constants of :func:`simulate_truth` (read by
#: ``_truth_rhs``): vehicle, fuzzy forces (2)/(5), the Pacejka switch and coefficients of the
#: mismatch check, and the row hit by the uncertainty (0: ``1/m``, 1: ``1/I_z``)
(TP_M, TP_IZ, TP_LF, TP_LR, TP_VX, TP_RHO, TP_A, TP_B, TP_C, TP_CF1, TP_CF2, TP_CR1, TP_CR2,
 TP_PACEJKA, TP_BF, TP_CF, TP_DF, TP_EF, TP_BR, TP_CR, TP_DR, TP_ER, TP_UNC_ROW) = range(23)


@njit(cache=True)
def _truth_rhs(x, delta, f, Fu, P, out):
    """Right-hand side (1)+(2)+(10) of ``x = [v_y, r]`` with steering ``delta``, fault ``f``
    [rad] and uncertainty ``Fu`` (``|Fu| <= 1``); forces fuzzy (2) or, with the switch
    ``P[TP_PACEJKA]``, the Pacejka magic formula of :func:`~vehicle_observers.models.tires.magic_formula`."""
    m, Iz, lf, lr, vx, rho = P[TP_M], P[TP_IZ], P[TP_LF], P[TP_LR], P[TP_VX], P[TP_RHO]
    af = delta + f - (x[0] + lf * x[1]) / vx
    ar = -(x[0] - lr * x[1]) / vx
    if P[TP_PACEJKA] > 0.5:
        Ff = magic_formula(af, P[TP_BF], P[TP_CF], P[TP_DF], P[TP_EF])
        Fr = magic_formula(ar, P[TP_BR], P[TP_CR], P[TP_DR], P[TP_ER])
    else:
        u = abs((af - P[TP_C]) / P[TP_A])
        h1 = 1.0 / (1.0 + u ** (2.0 * P[TP_B]))
        Ff = (h1 * P[TP_CF1] + (1 - h1) * P[TP_CF2]) * af
        Fr = (h1 * P[TP_CR1] + (1 - h1) * P[TP_CR2]) * ar
    k = P[TP_UNC_ROW]           # 0: uncertainty on 1/m, 1: on 1/I_z, 2: on F_f, 3: on F_r
    if k > 1.5:
        if k > 2.5:
            Fr = (1.0 + rho * Fu) * Fr
        else:
            Ff = (1.0 + rho * Fu) * Ff
        out[0] = (Ff + Fr) / m - vx * x[1]
        out[1] = (lf * Ff - lr * Fr) / Iz
    else:
        out[0] = (1.0 + rho * Fu * (1.0 - k)) * (Ff + Fr) / m - vx * x[1]
        out[1] = (1.0 + rho * Fu * k) * (lf * Ff - lr * Fr) / Iz


@njit(cache=True)
def _simulate_truth(x0, delta, fault, Fu, dt, substeps, P):
    N = delta.shape[0]
    X = np.empty((N, 2))
    x = x0.copy()
    h = dt / substeps
    k1 = np.empty(2)
    k2 = np.empty(2)
    k3 = np.empty(2)
    k4 = np.empty(2)
    tmp = np.empty(2)
    for k in range(N):
        X[k] = x
        for _ in range(substeps):
            _truth_rhs(x, delta[k], fault[k], Fu[k], P, k1)
            for i in range(2):
                tmp[i] = x[i] + 0.5 * h * k1[i]
            _truth_rhs(tmp, delta[k], fault[k], Fu[k], P, k2)
            for i in range(2):
                tmp[i] = x[i] + 0.5 * h * k2[i]
            _truth_rhs(tmp, delta[k], fault[k], Fu[k], P, k3)
            for i in range(2):
                tmp[i] = x[i] + h * k3[i]
            _truth_rhs(tmp, delta[k], fault[k], Fu[k], P, k4)
            for i in range(2):
                x[i] += h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
    return X


def simulate_truth(model: UncertainLateralTS, x0, delta, fault, F_unc, dt: float,
                   pacejka=None, substeps: int = 2):
    """Simulate the faulty uncertain model (1)+(2)+(9)-(10) (RK4, ZOH inputs); the factor
    ``1 + rho F(t)`` multiplies the force term of the equation selected by ``model.M``.

    x0 (2,); delta, fault, F_unc (N,) [rad, rad, -] sampled every ``dt`` s; ``|F_unc| <= 1``.
    ``pacejka=(tire_f, tire_r)``: use those Pacejka forces instead of the fuzzy ones (model
    mismatch check). Returns X (N, 2) ``[v_y, r]``.
    """
    delta = np.ascontiguousarray(delta, dtype=float)
    if delta.ndim != 1:
        raise ObserverArgumentError(f"simulate_truth: delta must be (N,) [rad], got shape "
                                    f"{delta.shape}")
    N = len(delta)
    try:
        fault = np.ascontiguousarray(np.broadcast_to(fault, (N,)), dtype=float)
        F_unc = np.ascontiguousarray(np.broadcast_to(F_unc, (N,)), dtype=float)
    except ValueError as exc:
        raise ObserverArgumentError(f"simulate_truth: fault and F_unc must be scalars or (N,) "
                                    f"= ({N},) like delta ({exc})") from None
    for name, arr in (("delta", delta), ("fault", fault), ("F_unc", F_unc)):
        if not np.all(np.isfinite(arr)):
            raise ObserverArgumentError(f"simulate_truth: {name} must be finite (first bad "
                                        f"sample {int(np.argmax(~np.isfinite(arr)))})")
    if np.any(np.abs(F_unc) > 1 + 1e-12):
        k = int(np.argmax(np.abs(F_unc) > 1 + 1e-12))
        raise ObserverArgumentError(f"simulate_truth: F_unc must satisfy |F| <= 1 "
                                    f"(norm-bounded uncertainty (10)); F_unc[{k}] = {F_unc[k]}")
    if not (np.isfinite(dt) and dt > 0):
        raise ObserverArgumentError(f"simulate_truth: dt must be > 0 s, got {dt}")
    if int(substeps) != substeps or substeps < 1:
        raise ObserverArgumentError(f"simulate_truth: substeps must be an integer >= 1, got "
                                    f"{substeps}")
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (2,) or not np.all(np.isfinite(x0)):
        raise ObserverArgumentError(f"simulate_truth: x0 must be 2 finite values [v_y, r], got "
                                    f"{x0}")
    ty = model.tyres
    P = np.zeros(TP_UNC_ROW + 1)
    P[[TP_M, TP_IZ, TP_LF, TP_LR, TP_VX, TP_RHO]] = (model.m, model.I_z, model.l_f, model.l_r,
                                                      model.vx, model.rho)
    P[[TP_A, TP_B, TP_C]] = ty.a, ty.b, ty.c
    P[[TP_CF1, TP_CF2, TP_CR1, TP_CR2]] = (*ty.C_f, *ty.C_r)
    if pacejka is not None:
        tf, tr = pacejka
        P[TP_PACEJKA] = 1.0
        P[[TP_BF, TP_CF, TP_DF, TP_EF]] = tf.B, tf.C, tf.D, tf.E
        P[[TP_BR, TP_CR, TP_DR, TP_ER]] = tr.B, tr.C, tr.D, tr.E
    P[TP_UNC_ROW] = float(model.unc_row)
    return _simulate_truth(x0.copy(), delta, fault, F_unc, float(dt), int(substeps), P)


def slip_front(model: UncertainLateralTS, X, delta, fault=0.0):
    """Front slip angle (3) [rad] including the actuator fault, (N,)."""
    X = np.atleast_2d(X)
    return np.asarray(delta) + fault - (X[:, 0] + model.l_f * X[:, 1]) / model.vx

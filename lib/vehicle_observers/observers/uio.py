"""Relaxed unknown-input observer (UIO) for the uncertain T-S lateral model with a fault
acting on both the steering actuator and a sensor (paper 003, Hindawi 2020; El Youssfi et
al.), and the non-relaxed design of its reference [22].

The extracted paper lost every formula. This module is a reconstruction from its surviving
structure and the standard literature; every choice is listed here and in Notebook 06.

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

The uncertainty is rewritten as an unknown input ``d`` ((12)-(13)) that the UIO decouples.

Augmented system (14)-(15): ``X = [x; f]`` (n_a = 3), ``X' = Abar_i X + Bbar_i u + Mbar d
+ Gam f'``, ``y = Cbar X`` with ``Abar_i = [[A_i, B_i], [0, 0]]``, ``Cbar = [C, F_s]``,
``Mbar = [M; 0]``, ``Gam = [0; 0; 1]`` (reconstruction: the fault is a state with unknown
derivative, the usual PI-type augmentation; its derivative is a disturbance of the error).

UIO (20)::

    z' = sum h_i (N_i z + G_i u + L_i y),   Xhat = z + H y

Error ``e = X - Xhat = eps - H D_w w`` with ``eps = T X - z`` and ``T = I - H Cbar``
((21)-(22)). The error is free of ``X``, ``u`` and ``d`` iff (23a)-(23c)::

    (23a) T Mbar = 0              (decouple the uncertainty)
    (23b) N_i = T Abar_i - K_i Cbar,  L_i = K_i + N_i H
    (23c) G_i = T Bbar_i

and then (24): ``eps' = sum h_i (N_i eps + T Gam f' - L_i D_w w)``.
(23a) is ``H (Cbar Mbar) = Mbar``; by Lemma 2 (Moore-Penrose general solution of
``X A = B``: ``X = B A^+ + Y (I - A A^+)``, solvable iff ``B A^+ A = B``) its solutions are
``H = Mbar (Cbar Mbar)^+ + Y (I - (Cbar Mbar)(Cbar Mbar)^+)``. Assumption 1 (reconstructed):
``Cbar`` full row rank and ``Cbar Mbar`` full column rank (so ``B A^+ A = B`` holds); we
take ``Y = 0`` (minimum-norm solution; a free ``Y`` would make the L2 index bilinear).

Performance index (the same for both designs): the L2 gain ``gamma`` from
``omega = [f'/s_fd; w]`` (fault rate and unit measurement noise) to the normalised error
``S^-1 e``, with decay rate ``alpha`` (``V' <= -2 alpha V``), minimised over the gains.

(a) non-relaxed, reference [22]: quadratic ``V = eps^T P eps``, one LMI per rule::

    [[2a P + He(P T Abar_i - W_i Cbar), P B_i, I], [*, -g I, D_e^T], [*, *, -I]] < 0,
    B_i = [T Gam, -(W_i(I - Cbar H) + P T Abar_i H) D_w] / (P-multiplied), K_i = P^-1 W_i

(b) relaxed, Theorem 2: fuzzy Lyapunov ``V = eps^T (sum h_i P_i) eps`` with Assumption 2
``|h_i'| <= phi`` and Finsler's lemma (Lemma 1) with slack ``[G; mu G; 0]`` on the
constraint ``eps' = N_h eps + B_h omega``::

    [[s phi (P_1 - P_2) + 2a P_i + He(G N_i), P_i - G + mu N_i^T G^T, G B_i, I],
     [*, -mu (G + G^T), mu G B_i, 0], [*, *, -g I, D_e^T], [*, *, *, -I]] < 0

for each rule i and s = +-1 (for two rules h_1' = -h_2', so P' = h_1' (P_1 - P_2) is
affine in h_1' in [-phi, phi]: the two signs are exact), ``G N_i = G T Abar_i - W_i Cbar``,
``K_i = G^-1 W_i``. Because P_h and N_h enter affinely (the slack separates them) a single
sum over the rules suffices. Remark 1: with ``P_i = P``, ``G = P`` the matrix is the one of
(a) plus ``mu/2 [N B]^T P [N B]`` (Schur complement), so every (a) solution gives a (b)
solution for ``mu`` small enough: :func:`relaxed_from_quadratic` builds it explicitly and
the certificate checks it. For a fixed ``mu > 0`` (b) does *not* contain (a) in general
(projection lemma: it also needs ``2 P > mu (...)``); the line search over ``mu`` therefore
includes a near-limit value (1e-6 s), so (b) contains (a) up to solver accuracy.

Pole region (both designs, not in the paper): the observer poles are kept in the disk
``|lambda| < radius`` (default 200 1/s) for the 1 kHz implementation; without it the
quadratic design drives one pole to ~ -1e7 1/s. (a): ``[[P, (P N_i)^T], [P N_i, P]] > 0``
in the time unit ``1/radius``; (b): ``[[P_i, (G N_i)^T], [G N_i, G + G^T - P_i]] > 0``
(de Oliveira's extended discrete-Lyapunov LMI; congruence with ``[I, -N^T]`` gives
``N^T P_i N < P_i``). All LMIs are solved in the time unit ``1/radius`` (conditioning).

Arrays: time series (N,), states (N, 2), augmented (N, 3), memberships (N, 2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.core.metrics import rmse
from vehicle_observers.design.lmi import LMIDesign, LMISolution, bmat


class AssumptionError(ValueError):
    """A structural existence condition of the UIO (Assumption 1 / 2) does not hold."""


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
        raise ValueError(f"alpha_max must be a positive slip angle [rad], got {alpha_max}")
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
    (relative error ``rho`` on ``1/m``) or ``[0, 1]^T`` (on ``1/I_z``); only the simulation
    uses ``rho`` (the UIO decouples it).
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
            raise ValueError(f"F_s must be ({len(self.C)}, 1) (one fault, one entry per output "
                             f"row of C), got shape {self.F_s.shape}")
        self.F_s = self.F_s.reshape(len(self.C), 1)
        self.M = np.asarray(self.M, dtype=float).reshape(2, -1)
        if self.M.shape != (2, 1) or np.count_nonzero(self.M) != 1:
            raise ValueError(f"M must be [1, 0]^T (1/m error) or [0, 1]^T (1/I_z error), got "
                             f"{self.M.ravel().tolist()}")
        self.D_w = np.atleast_2d(np.asarray(self.D_w, dtype=float))
        self.scale_x = np.asarray(self.scale_x, dtype=float)
        if self.vx <= 0:
            raise ValueError(f"vx must be > 0 m/s, got {self.vx}")
        if self.C.shape[1] != 2:
            raise ValueError(f"C must have 2 columns (v_y, r), got shape {self.C.shape}")
        if self.F_s.shape != (len(self.C), 1):
            raise ValueError(f"F_s must be ({len(self.C)}, 1) (one fault), got {self.F_s.shape}")
        if self.D_w.shape != (len(self.C), len(self.C)):
            raise ValueError(f"D_w must be ({len(self.C)}, {len(self.C)}), got {self.D_w.shape}")
        if self.scale_x.shape != (3,) or np.any(self.scale_x <= 0) or self.scale_fdot <= 0:
            raise ValueError("scale_x must be 3 positive numbers and scale_fdot > 0")

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

    @property
    def unc_row(self) -> int:
        """Equation hit by the uncertainty: 0 (``1/m``, v_y equation) or 1 (``1/I_z``, r)."""
        return int(np.flatnonzero(self.M[:, 0])[0])

    def uncertainty_matrices(self):
        """``N_a (2, 1, 2), N_b (2, 1, 1)`` of (10): ``rho`` times the force part of the row
        of A_i, B_i selected by ``M`` (scaled by ``1/M[row]``)."""
        k = self.unc_row
        Na, Nb = [], []
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


# ------------------------------------------------------- (23a)-(23c): general solution --
def pinv_general_solution(A, B, Y=None, rtol: float = 1e-10):
    """Lemma 2: ``X = B A^+ + Y (I - A A^+)`` solves ``X A = B`` iff ``B A^+ A = B``.

    Raises :class:`AssumptionError` when ``B A^+ A != B`` (no solution). ``Y`` defaults to
    0 (minimum-norm solution).
    """
    A, B = np.atleast_2d(A), np.atleast_2d(B)
    Ap = np.linalg.pinv(A)
    gap = np.abs(B @ Ap @ A - B).max() / max(np.abs(B).max(), 1e-300)
    if gap > rtol:
        raise AssumptionError(f"Lemma 2: X A = B has no solution (|B A^+ A - B| / |B| = "
                              f"{gap:.2e}); Assumption 1 fails")
    X = B @ Ap
    if Y is not None:
        X = X + np.asarray(Y) @ (np.eye(A.shape[0]) - A @ Ap)
    return X


def check_assumption1(Cb, Mb, rtol: float = 1e-9):
    """Assumption 1 (reconstructed): ``Cbar`` full row rank and ``Cbar Mbar`` full column
    rank (the uncertainty can be decoupled, (23a)). Raises :class:`AssumptionError`."""
    p = Cb.shape[0]
    sv = np.linalg.svd(Cb, compute_uv=False)
    if sv.size < p or sv[-1] <= rtol * sv[0]:
        raise AssumptionError(f"Assumption 1: Cbar = [C, F_s] ({Cb.shape[0]}x{Cb.shape[1]}) must "
                              f"have full row rank {p}; singular values {sv}")
    CM = Cb @ Mb
    nd = Mb.shape[1]
    svm = np.linalg.svd(Mb, compute_uv=False)
    if svm[-1] <= rtol * max(svm[0], 1e-300):
        raise AssumptionError(f"M must have full column rank {nd} (uncertainty direction), "
                              f"singular values {svm}")
    s = np.linalg.svd(CM, compute_uv=False)
    if s.size < nd or s[-1] <= rtol * max(s[0], 1e-300):
        raise AssumptionError(f"Assumption 1: Cbar Mbar ({CM.shape[0]}x{nd}) must have full "
                              f"column rank {nd} so (23a) T Mbar = 0 is solvable; singular "
                              f"values {s} (the uncertainty direction is not seen by the "
                              "sensors)")


def uio_structure(model: UncertainLateralTS, Y=None) -> dict:
    """T, H of (23a) by Lemma 2, plus the matrices of the error system (24).

    Also checks that every ``(T Abar_i, Cbar)`` is detectable (PBH test on the modes with
    Re >= 0); raises :class:`AssumptionError` naming the rule and the mode otherwise.
    Returns a dict with Abar, Bbar, Cbar, Mbar, Gam, Dw, H, T, TA (r,3,3), TG (3,1).
    """
    Ab, Bb, Cb, Mb, Gam, Dw = model.augmented()
    check_assumption1(Cb, Mb)
    H = pinv_general_solution(Cb @ Mb, Mb, Y)
    T = np.eye(3) - H @ Cb
    TA = np.array([T @ A for A in Ab])
    for i, TAi in enumerate(TA):
        for lam in np.linalg.eigvals(TAi):
            if lam.real >= -1e-12:
                pbh = np.vstack([lam * np.eye(3) - TAi, Cb])
                if np.linalg.matrix_rank(pbh, tol=1e-9 * max(1.0, np.abs(pbh).max())) < 3:
                    raise AssumptionError(f"rule {i + 1}: (T Abar, Cbar) is not detectable "
                                          f"(unobservable mode {lam:.4g}); no UIO gain exists")
    return {"Abar": Ab, "Bbar": Bb, "Cbar": Cb, "Mbar": Mb, "Gam": Gam, "Dw": Dw, "H": H,
            "T": T, "TA": TA, "TG": T @ Gam}


# ------------------------------------------------------------------------ LMI designs ----
@dataclass
class UIOGains:
    """Observer (20) in normalised coordinates plus its certificate.

    N (r,3,3), G (r,3,1), L (r,3,p), H (3,p), K (r,3,p); S (3,) and R (p,) scales (physical
    ``X = S * X_s``, ``y_s = y / R``). gamma: certified L2 gain; design: "a" or "b".
    """

    design: str
    N: np.ndarray
    G: np.ndarray
    L: np.ndarray
    H: np.ndarray
    K: np.ndarray
    S: np.ndarray
    R: np.ndarray
    gamma: float
    alpha: float
    phi: float | None
    mu: float | None
    radius: float
    solution: LMISolution

    @property
    def min_margin(self) -> float:
        return self.solution.certificate.min_margin

    @property
    def poles(self) -> np.ndarray:
        """(r, 3) eigenvalues of N_i [1/s]."""
        return np.array([np.linalg.eigvals(n) for n in self.N])


def _error_input(st, i, W, PorG):
    """``PorG @ B_i`` with ``B_i = [T Gam, -L_i Dw]``, L_i = K_i (I - Cbar H) + T Abar_i H,
    written with ``W = PorG K_i`` (linear in the decision variables)."""
    p = st["Cbar"].shape[0]
    IcH = np.eye(p) - st["Cbar"] @ st["H"]
    TAH = st["TA"][i] @ st["H"]
    col1 = PorG @ st["TG"]
    col2 = -(W @ IcH + PorG @ TAH) @ st["Dw"]
    return bmat([[col1, col2]])


def _De(st):
    p = st["Cbar"].shape[0]
    return np.hstack([np.zeros((3, 1)), -st["H"] @ st["Dw"]]).reshape(3, 1 + p)


def _time_scaled(st, radius):
    """Copy of ``st`` in the time unit ``tau = 1/radius`` (dynamics O(1), better conditioned
    LMIs; the L2 gain is invariant under time scaling). Gains: ``K = K_tau / tau``."""
    tau = 1.0 / radius
    out = dict(st)
    out["TA"] = st["TA"] * tau
    out["TG"] = st["TG"] * tau
    out["tau"] = tau
    return out


def design_quadratic(model: UncertainLateralTS, alpha: float, st: dict | None = None,
                     radius: float = 200.0, eps: float = 1e-6) -> UIOGains:
    """Design (a), the non-relaxed conditions of [22]: common quadratic Lyapunov matrix.

    Minimises ``g = gamma^2`` s.t. ``P > 0`` and, per rule i,
    ``[[2 alpha P + He(P T Abar_i - W_i Cbar), P B_i, I], [*, -g I, D_e^T], [*, *, -I]] < 0``.
    Raises InfeasibleDesign / CertificationError (lmi.LMIDesign).
    """
    st0 = structure(model) if st is None else st
    st = _time_scaled(st0, radius)
    tau = st["tau"]
    a_s = alpha * tau
    r, p = len(st["TA"]), st["Cbar"].shape[0]
    nw = 1 + p
    De = _De(st)
    d = LMIDesign(f"UIO (a) quadratic [22], alpha={alpha:g}", eps=eps)
    d.symmetric("P", 3)
    d.scalar("g")
    for i in range(r):
        d.matrix(f"W{i}", (3, p))
    d.positive("P>0", lambda V: V.P)
    for i in range(r):
        def build(V, i=i):
            P, W = V.P, V[f"W{i}"]
            PN = P @ st["TA"][i] - W @ st["Cbar"]
            PB = _error_input(st, i, W, P)
            return bmat([[2 * a_s * P + PN + PN.T, PB, np.eye(3)],
                         [PB.T, -V.g * np.eye(nw), De.T],
                         [np.eye(3), De, -np.eye(3)]])
        d.negative(f"Phi[{i + 1}]", build)

        def disk(V, i=i):
            PN = V.P @ st["TA"][i] - V[f"W{i}"] @ st["Cbar"]
            return bmat([[V.P, PN.T], [PN, V.P]])
        d.positive(f"disk[{i + 1}]", disk)
    sol = d.solve(objective=lambda V: V.g)
    P = sol["P"]
    K = np.array([np.linalg.solve(P, sol[f"W{i}"]) for i in range(r)]) / tau
    return _gains("a", st0, K, sol, alpha, None, None, radius)


def relaxed_builders(st, alpha, phi, mu):
    """Builders of Theorem 2 (b) for rule i and sign s (see module docstring)."""
    r, p = len(st["TA"]), st["Cbar"].shape[0]
    if r != 2:
        raise ValueError(f"the relaxed design handles two rules (h_2' = -h_1'), got {r}")
    nw = 1 + p
    De = _De(st)

    def build(V, i, s):
        Pi, G, W = V[f"P{i}"], V.G, V[f"W{i}"]
        GN = G @ st["TA"][i] - W @ st["Cbar"]
        GB = _error_input(st, i, W, G)
        Pdot = s * phi * (V.P0 - V.P1)
        Z3 = np.zeros((3, 3))
        return bmat([[Pdot + 2 * alpha * Pi + GN + GN.T, Pi - G + mu * GN.T, GB, np.eye(3)],
                     [Pi - G.T + mu * GN, -mu * (G + G.T), mu * GB, Z3],
                     [GB.T, mu * GB.T, -V.g * np.eye(nw), De.T],
                     [np.eye(3), Z3, De, -np.eye(3)]])

    return build


def _relaxed_design(st0, alpha, phi, mu, eps, radius=200.0):
    """LMIDesign of Theorem 2 in the time unit 1/radius (alpha, phi [1/s], mu [s])."""
    st = _time_scaled(st0, radius)
    tau = st["tau"]
    r, p = len(st["TA"]), st["Cbar"].shape[0]
    build = relaxed_builders(st, alpha * tau, phi * tau, mu / tau)
    d = LMIDesign(f"UIO (b) relaxed Thm 2, alpha={alpha:g}, phi={phi:g}, mu={mu:g}", eps=eps)
    for i in range(r):
        d.symmetric(f"P{i}", 3)
    d.matrix("G", (3, 3))
    d.scalar("g")
    for i in range(r):
        d.matrix(f"W{i}", (3, p))
    for i in range(r):
        d.positive(f"P{i + 1}>0", lambda V, i=i: V[f"P{i}"])
    for i in range(r):
        for s in (1, -1):
            d.negative(f"Ups[{i + 1},{'+' if s > 0 else '-'}]",
                       lambda V, i=i, s=s: build(V, i, s))

    def disk(V, i):
        GN = V.G @ st["TA"][i] - V[f"W{i}"] @ st["Cbar"]
        Pi = V[f"P{i}"]
        return bmat([[Pi, GN.T], [GN, V.G + V.G.T - Pi]])
    for i in range(r):
        d.positive(f"disk[{i + 1}]", lambda V, i=i: disk(V, i))
    return d


def design_relaxed(model: UncertainLateralTS, alpha: float, phi: float, mu=(1e-6, 1e-3, 1e-2),
                   st: dict | None = None, radius: float = 200.0,
                   eps: float = 1e-6) -> UIOGains:
    """Design (b), Theorem 2: fuzzy Lyapunov matrices + Finsler slack ``G``, scalar ``mu``.

    ``mu`` may be a sequence: the LMIs are solved for each value and the lowest certified
    gamma kept (Remark 2: mu is "chosen ... in such a way that the conditions are
    feasible"). Raises InfeasibleDesign if no mu works.
    """
    st = structure(model) if st is None else st
    mus = np.atleast_1d(np.asarray(mu, dtype=float))
    if np.any(mus <= 0) or phi < 0:
        raise ValueError(f"need mu > 0 and phi >= 0, got mu={mus}, phi={phi}")
    best, errs = None, []
    for m_ in mus:
        d = _relaxed_design(st, alpha, phi, float(m_), eps, radius)
        try:
            sol = d.solve(objective=lambda V: V.g)
        except InfeasibleDesign as exc:
            errs.append(f"mu={m_:g}: {exc}")
            continue
        if best is None or sol.objective < best[0].objective:
            best = (sol, float(m_))
    if best is None:
        raise InfeasibleDesign(f"UIO (b) relaxed, alpha={alpha:g}, phi={phi:g}: infeasible for "
                               f"every mu; " + " | ".join(errs))
    sol, m_ = best
    K = np.array([np.linalg.solve(sol["G"], sol[f"W{i}"]) for i in range(len(st["TA"]))])
    K = K * radius
    return _gains("b", st, K, sol, alpha, phi, m_, radius)


def _gains(kind, st, K, sol, alpha, phi, mu, radius):
    r = len(st["TA"])
    N = np.array([st["TA"][i] - K[i] @ st["Cbar"] for i in range(r)])
    L = np.array([K[i] + N[i] @ st["H"] for i in range(r)])
    G = np.array([st["T"] @ B for B in st["Bbar"]])
    S, R = st["_scales"]
    return UIOGains(kind, N, G, L, st["H"], K, S, R, float(np.sqrt(sol["g"])), alpha, phi, mu,
                    radius, sol)


def structure(model: UncertainLateralTS, Y=None) -> dict:
    """:func:`uio_structure` plus the scales needed to map the observer back to SI units."""
    st = uio_structure(model, Y)
    st["_scales"] = (model.scale_x.copy(), np.diag(model.output_scale()).copy())
    return st


def relaxed_from_quadratic(gains_a: UIOGains, slack: float = 1e-3, n_rules: int = 2) -> dict:
    """Remark 1, constructively: a point of (b) built from a solution of (a).

    ``P_1 = P_2 = G = P``, ``W_i`` unchanged (same gains K_i) and ``g = (1 + slack) gamma_a^2``
    (the optimum of (a) sits on its boundary, margin ~ eps). By the Schur complement of the
    ``-2 mu P`` block, the (b) matrix equals the (a) matrix plus ``mu/2 [N B]^T P [N B]``, so
    it is negative for ``mu`` small enough; check with :func:`relaxed_certificate`.
    Values are in the time-scaled units of the stored solutions.
    """
    v = gains_a.solution.values
    out = {"G": v["P"], "g": v["g"] * (1.0 + slack)}
    for i in range(n_rules):
        out[f"P{i}"] = v["P"]
        out[f"W{i}"] = v[f"W{i}"]
    return out


def relaxed_certificate(st, values: dict, alpha: float, phi: float, mu: float,
                        radius: float = 200.0):
    """Independent eigenvalue certificate of Theorem 2's LMIs at given numeric values
    (time-scaled variables, as stored in an :class:`LMISolution`)."""
    return _relaxed_design(st, alpha, phi, mu, 1e-7, radius).certify(values)


# ------------------------------------------------------------------- feasibility sweep --
def feasibility_map(model, alphas, phis, mu=(1e-6, 1e-3, 1e-2), st=None, radius: float = 200.0,
                    gamma_level: float | None = None) -> dict:
    """Best certified gamma of (a) (depends on alpha only) and (b) on an alpha x phi grid.

    Returns ``{"alpha", "phi", "gamma_a" (na,), "gamma_b" (na, nphi), "margin_a",
    "margin_b", "feasible_a" (na, nphi), "feasible_b"}`` with ``nan`` gammas where the
    LMIs have no certified solution; "feasible" means a certified solution with
    ``gamma <= gamma_level`` (any gamma when ``gamma_level`` is None).
    """
    st = structure(model) if st is None else st
    alphas, phis = np.asarray(alphas, float), np.asarray(phis, float)
    ga = np.full(len(alphas), np.nan)
    ma = np.full(len(alphas), np.nan)
    gb = np.full((len(alphas), len(phis)), np.nan)
    mb = np.full_like(gb, np.nan)
    for k, a in enumerate(alphas):
        try:
            g = design_quadratic(model, a, st, radius=radius)
            ga[k], ma[k] = g.gamma, g.min_margin
        except InfeasibleDesign:
            pass
        for j, ph in enumerate(phis):
            try:
                g = design_relaxed(model, a, ph, mu, st, radius=radius)
                gb[k, j], mb[k, j] = g.gamma, g.min_margin
            except InfeasibleDesign:
                pass
    lev = np.inf if gamma_level is None else gamma_level
    fa = np.broadcast_to((np.isfinite(ga) & (np.nan_to_num(ga, nan=np.inf) <= lev))[:, None],
                         gb.shape).copy()
    fb = np.isfinite(gb) & (np.nan_to_num(gb, nan=np.inf) <= lev)
    return {"alpha": alphas, "phi": phis, "gamma_a": ga, "gamma_b": gb, "margin_a": ma,
            "margin_b": mb, "feasible_a": fa, "feasible_b": fb}


# ---------------------------------------------------------------------- simulation -------
@njit(cache=True)
def _truth_rhs(x, delta, f, Fu, P, out):
    # P: m, Iz, lf, lr, vx, rho, a, b, c, Cf1, Cf2, Cr1, Cr2, pac, Bf, Cf, Df, Ef, Br, Cr, Dr, Er,
    # uncertain row
    m, Iz, lf, lr, vx, rho = P[0], P[1], P[2], P[3], P[4], P[5]
    af = delta + f - (x[0] + lf * x[1]) / vx
    ar = -(x[0] - lr * x[1]) / vx
    if P[13] > 0.5:
        Ff = P[16] * np.sin(P[15] * np.arctan(P[14] * (1 - P[17]) * af
                                              + P[17] * np.arctan(P[14] * af)))
        Fr = P[20] * np.sin(P[19] * np.arctan(P[18] * (1 - P[21]) * ar
                                              + P[21] * np.arctan(P[18] * ar)))
    else:
        u = abs((af - P[8]) / P[6])
        h1 = 1.0 / (1.0 + u ** (2.0 * P[7]))
        Ff = (h1 * P[9] + (1 - h1) * P[10]) * af
        Fr = (h1 * P[11] + (1 - h1) * P[12]) * ar
    k = P[22]                   # 0: uncertainty on 1/m, 1: on 1/I_z
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
    N = len(delta)
    fault = np.ascontiguousarray(np.broadcast_to(fault, (N,)), dtype=float)
    F_unc = np.ascontiguousarray(np.broadcast_to(F_unc, (N,)), dtype=float)
    for name, arr in (("delta", delta), ("fault", fault), ("F_unc", F_unc)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite (first bad sample "
                             f"{int(np.argmax(~np.isfinite(arr)))})")
    if np.any(np.abs(F_unc) > 1 + 1e-12):
        k = int(np.argmax(np.abs(F_unc) > 1 + 1e-12))
        raise ValueError(f"F_unc must satisfy |F| <= 1 (norm-bounded uncertainty (10)); "
                         f"F_unc[{k}] = {F_unc[k]}")
    if dt <= 0:
        raise ValueError(f"dt must be > 0, got {dt}")
    ty = model.tyres
    pac = np.zeros(9)
    if pacejka is not None:
        tf, tr = pacejka
        pac = np.array([1.0, tf.B, tf.C, tf.D, tf.E, tr.B, tr.C, tr.D, tr.E])
    P = np.r_[model.m, model.I_z, model.l_f, model.l_r, model.vx, model.rho, ty.a, ty.b, ty.c,
              ty.C_f[0], ty.C_f[1], ty.C_r[0], ty.C_r[1], pac, float(model.unc_row)]
    return _simulate_truth(np.asarray(x0, dtype=float).copy(), delta, fault, F_unc, float(dt),
                           int(substeps), P)


def slip_front(model: UncertainLateralTS, X, delta, fault=0.0):
    """Front slip angle (3) [rad] including the actuator fault, (N,)."""
    X = np.atleast_2d(X)
    return np.asarray(delta) + fault - (X[:, 0] + model.l_f * X[:, 1]) / model.vx


@njit(cache=True)
def _observer_rhs(z, u, ys, h, N, G, L, out):
    n = z.shape[0]
    p = ys.shape[0]
    for i in range(n):
        out[i] = 0.0
    for q in range(h.shape[0]):
        w = h[q]
        if w == 0.0:
            continue
        for i in range(n):
            s = G[q, i, 0] * u
            for j in range(n):
                s += N[q, i, j] * z[j]
            for j in range(p):
                s += L[q, i, j] * ys[j]
            out[i] += w * s


@njit(cache=True)
def _run_observer(z0, u, Ys, Hm, N, G, L, H, dt):
    """RK4 of (20) with u, y, h held over each step; returns Xhat_s (K, 3) normalised."""
    K = u.shape[0]
    n = z0.shape[0]
    p = Ys.shape[1]
    out = np.empty((K, n))
    z = z0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    for k in range(K):
        for i in range(n):
            s = z[i]
            for j in range(p):
                s += H[i, j] * Ys[k, j]
            out[k, i] = s
        _observer_rhs(z, u[k], Ys[k], Hm[k], N, G, L, k1)
        for i in range(n):
            tmp[i] = z[i] + 0.5 * dt * k1[i]
        _observer_rhs(tmp, u[k], Ys[k], Hm[k], N, G, L, k2)
        for i in range(n):
            tmp[i] = z[i] + 0.5 * dt * k2[i]
        _observer_rhs(tmp, u[k], Ys[k], Hm[k], N, G, L, k3)
        for i in range(n):
            tmp[i] = z[i] + dt * k3[i]
        _observer_rhs(tmp, u[k], Ys[k], Hm[k], N, G, L, k4)
        for i in range(n):
            z[i] += dt / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
    return out


def _check_rk4(gains: UIOGains, dt: float):
    lam = float(np.abs(gains.poles).max())
    if lam * dt > 2.5:
        raise ValueError(f"observer pole |lambda| = {lam:.3g} 1/s is too fast for RK4 at dt = "
                         f"{dt} s (|lambda| dt = {lam * dt:.2f} > 2.5); use a smaller dt")


def run_observer(gains: UIOGains, delta, y, h, dt: float, X0_hat=None):
    """Run the UIO (20) on measured steering ``delta`` (N,) [rad], outputs ``y`` (N, p) in
    SI units and memberships ``h`` (N, 2). Returns ``Xhat`` (N, 3) = ``[v_y, r, f]`` in SI.

    ``X0_hat`` (3,) initial estimate (default 0). Raises ValueError if the fastest observer
    pole makes RK4 at this ``dt`` unstable (|lambda| dt > 2.5).
    """
    delta = np.ascontiguousarray(delta, dtype=float)
    y = np.atleast_2d(np.asarray(y, dtype=float))
    h = np.ascontiguousarray(h, dtype=float)
    N = len(delta)
    p = gains.H.shape[1]
    if y.shape != (N, p):
        raise ValueError(f"y must be ({N}, {p}) (samples x outputs), got {y.shape}")
    if h.shape != (N, gains.N.shape[0]):
        raise ValueError(f"h must be ({N}, {gains.N.shape[0]}) memberships, got {h.shape}")
    if np.abs(h.sum(axis=1) - 1).max() > 1e-9 or h.min() < -1e-12:
        raise ValueError("memberships h must be >= 0 and sum to 1 on every row")
    _check_rk4(gains, dt)
    Ys = np.ascontiguousarray(y / gains.R)
    Xs0 = np.zeros(3) if X0_hat is None else np.asarray(X0_hat, dtype=float) / gains.S
    z0 = Xs0 - gains.H @ Ys[0]
    Xs = _run_observer(z0, delta, Ys, h, gains.N, gains.G, gains.L,
                       np.ascontiguousarray(gains.H), float(dt))
    return Xs * gains.S


@njit(cache=True)
def _run_observer_sched(z0, u, Ys, N, G, L, H, S, prem, dt):
    """RK4 of (20) with the memberships of the *estimated* front slip angle
    ``delta + f_hat - (v_y_hat + l_f r_hat) / v_x`` (held over each step).
    prem = [a, b, c, l_f, v_x]. Returns Xhat_s (K, 3) normalised and h (K, 2)."""
    K = u.shape[0]
    n = z0.shape[0]
    p = Ys.shape[1]
    out = np.empty((K, n))
    hh = np.empty((K, 2))
    z = z0.copy()
    hk = np.empty(2)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    for k in range(K):
        for i in range(n):
            s = z[i]
            for j in range(p):
                s += H[i, j] * Ys[k, j]
            out[k, i] = s
        af = u[k] + S[2] * out[k, 2] - (S[0] * out[k, 0] + prem[3] * S[1] * out[k, 1]) / prem[4]
        hk[0] = 1.0 / (1.0 + abs((af - prem[2]) / prem[0]) ** (2.0 * prem[1]))
        hk[1] = 1.0 - hk[0]
        hh[k, 0] = hk[0]
        hh[k, 1] = hk[1]
        _observer_rhs(z, u[k], Ys[k], hk, N, G, L, k1)
        for i in range(n):
            tmp[i] = z[i] + 0.5 * dt * k1[i]
        _observer_rhs(tmp, u[k], Ys[k], hk, N, G, L, k2)
        for i in range(n):
            tmp[i] = z[i] + 0.5 * dt * k2[i]
        _observer_rhs(tmp, u[k], Ys[k], hk, N, G, L, k3)
        for i in range(n):
            tmp[i] = z[i] + dt * k3[i]
        _observer_rhs(tmp, u[k], Ys[k], hk, N, G, L, k4)
        for i in range(n):
            z[i] += dt / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
    return out, hh


def run_observer_estimated(gains: UIOGains, tyres: FuzzyTyres, l_f: float, vx: float, delta,
                           y, dt: float, X0_hat=None):
    """Run the UIO (20) scheduled on its own estimate: memberships (5)-(7) of
    ``alpha_f_hat = delta + f_hat - (v_y_hat + l_f r_hat) / v_x`` [rad]. Inputs are only the
    measured steering ``delta`` (N,) [rad] and outputs ``y`` (N, p) (SI): no true state,
    slip angle or fault. Returns ``(Xhat (N, 3) = [v_y, r, f] in SI, h (N, 2) used)``."""
    delta = np.ascontiguousarray(delta, dtype=float)
    y = np.atleast_2d(np.asarray(y, dtype=float))
    N, p = len(delta), gains.H.shape[1]
    if y.shape != (N, p):
        raise ValueError(f"y must be ({N}, {p}) (samples x outputs), got {y.shape}")
    if gains.N.shape[0] != 2:
        raise ValueError(f"estimated premises need the two-rule bell model, got "
                         f"{gains.N.shape[0]} rules")
    _check_rk4(gains, dt)
    Ys = np.ascontiguousarray(y / gains.R)
    Xs0 = np.zeros(3) if X0_hat is None else np.asarray(X0_hat, dtype=float) / gains.S
    z0 = Xs0 - gains.H @ Ys[0]
    prem = np.array([tyres.a, tyres.b, tyres.c, l_f, vx], dtype=float)
    Xs, h = _run_observer_sched(z0, delta, Ys, gains.N, gains.G, gains.L,
                                np.ascontiguousarray(gains.H), np.asarray(gains.S, float),
                                prem, float(dt))
    return Xs * gains.S, h


def observer_rhs_readable(z, u: float, y_s, h, gains: UIOGains):
    """UIO (20), readable numpy form: ``z' = sum_i h_i (N_i z + G_i u + L_i y)``
    (normalised coordinates, z (3,), y_s (p,), h (r,)); equal to the compiled kernel."""
    return sum(h[i] * (gains.N[i] @ z + gains.G[i][:, 0] * u + gains.L[i] @ y_s)
               for i in range(len(h)))


def observer_step_readable(z, u: float, y_s, h, gains: UIOGains, dt: float):
    """One RK4 step of :func:`observer_rhs_readable` with u, y, h held [s]; returns the new
    z and the estimate ``Xhat_s = z + H y_s`` (both normalised) before the step."""
    def f(zz):
        return observer_rhs_readable(zz, u, y_s, h, gains)
    k1 = f(z)
    k2 = f(z + 0.5 * dt * k1)
    k3 = f(z + 0.5 * dt * k2)
    k4 = f(z + dt * k3)
    return z + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), z + gains.H @ y_s


def phi_bound(model: UncertainLateralTS, delta_dot_max: float, fdot_max: float, D_f: float,
              D_r: float) -> dict:
    """Assumption 2 bound ``phi >= |dh_i/dt|`` [1/s] from stated input bounds, not a run.

    ``|h'| <= max|dh_1/dalpha| |alpha_f'|`` with (3) ``alpha_f' = delta' + f' - (v_y' + l_f
    r')/v_x`` and: ``|delta'| <= delta_dot_max`` [rad/s] (driver), ``|f'| <= fdot_max``
    [rad/s]; tyre forces below the Pacejka peaks ``D_f, D_r`` [N] (friction limit), so
    ``|a_y| <= (Df + Dr)/m``, ``|v_y'| = |a_y - v_x r| <= 2 a_y,max`` (steady-state yaw-rate
    limit ``|r| <= a_y,max / v_x``), ``|r'| <= (l_f D_f + l_r D_r)/I_z``; the uncertain
    equation carries ``1 + rho``. Returns the parts and ``phi``."""
    if not (delta_dot_max >= 0 and fdot_max >= 0 and D_f > 0 and D_r > 0):
        raise ValueError(f"input bounds must be >= 0, got delta_dot_max={delta_dot_max}, "
                         f"fdot_max={fdot_max}, peak forces D_f={D_f}, D_r={D_r} > 0")
    ty = model.tyres
    al = np.linspace(ty.c - 20 * ty.a, ty.c + 20 * ty.a, 400001)
    dh = float(np.abs(gbell_derivative(al, ty.a, ty.b, ty.c)).max())
    Df, Dr = float(D_f), float(D_r)
    k_m = 1 + model.rho * (model.unc_row == 0)
    k_i = 1 + model.rho * (model.unc_row == 1)
    ay = k_m * (Df + Dr) / model.m
    rdot = k_i * (model.l_f * Df + model.l_r * Dr) / model.I_z
    adot = delta_dot_max + fdot_max + (2 * ay + model.l_f * rdot) / model.vx
    return {"delta_dot_max": float(delta_dot_max), "dh_dalpha_max": dh, "ay_max": ay,
            "rdot_max": rdot, "alpha_dot_max": adot,
            "phi": dh * adot}


# ----------------------------------------------------------------------- metrics ---------
def fault_delay(t, f_hat, f, t_fault: float, band: float = 0.1, window: int = 1) -> float:
    """Fault-estimation delay [s]: time after ``t_fault`` from which ``|f_hat - f|`` stays
    within ``band * max|f|`` until the end (``nan`` if it never settles).

    ``window`` > 1 first averages the error over that many samples (centred moving mean),
    so that isolated sensor-noise spikes do not count as loss of tracking.
    """
    t, fh, f = (np.asarray(a, dtype=float) for a in (t, f_hat, f))
    if int(window) < 1:
        raise ValueError(f"window must be >= 1 sample, got {window}")
    m = t >= t_fault
    ref = band * float(np.max(np.abs(f[m])))
    err = fh[m] - f[m]
    if window > 1:
        err = np.convolve(err, np.ones(int(window)) / int(window), mode="same")
    bad = np.flatnonzero(np.abs(err) > ref)
    if len(bad) == 0:
        return 0.0
    if bad[-1] == m.sum() - 1:
        return float("nan")
    return float(t[m][bad[-1] + 1] - t_fault)


# ----------------------------------------------------------------------- scenario --------
def steering_signal(t):
    """Fig. 3 analogue (reconstruction): a sine of 0.05 rad at 0.25 Hz plus 0.02 rad at
    0.6 Hz with a 1 s smooth start [rad]."""
    t = np.asarray(t, dtype=float)
    env = np.clip(t, 0.0, 1.0) ** 2 * (3 - 2 * np.clip(t, 0.0, 1.0))
    return env * (0.05 * np.sin(2 * np.pi * 0.25 * t) + 0.02 * np.sin(2 * np.pi * 0.6 * t))


def fault_signal(t, t_fault: float, offset: float = 0.01, amp: float = 0.005,
                 freq: float = 0.5):
    """Time-varying fault (reconstruction of Sec. 5's "variant fault") [rad]: zero before
    ``t_fault``, then ``offset + amp sin(2 pi freq (t - t_fault))``."""
    t = np.asarray(t, dtype=float)
    return np.where(t >= t_fault, offset + amp * np.sin(2 * np.pi * freq * (t - t_fault)), 0.0)


def uncertainty_signal(t, seed: int = 0):
    """``F(t)`` of (10), ``|F| <= 1``: two sines with random phases from ``seed``."""
    rng = np.random.default_rng(seed)
    ph = rng.uniform(0, 2 * np.pi, 2)
    t = np.asarray(t, dtype=float)
    return 0.6 * np.sin(2 * np.pi * 0.7 * t + ph[0]) + 0.4 * np.sin(2 * np.pi * 1.3 * t + ph[1])


def make_scenario(model: UncertainLateralTS, t_end: float, dt: float, t_fault: float, x0,
                  seed: int = 0, noise: bool = True, pacejka=None, fault_kw=None) -> dict:
    """Simulate the faulty uncertain vehicle and its sensors (Sec. 5).

    Returns t (N,), delta (N,), f (N,), F (N,), X (N, 2) true ``[v_y, r]``, y (N, 2)
    measured (``C x + F_s f`` + noise ``D_w w`` with ``w ~ N(0, I)`` from ``seed``), h
    (N, 2) memberships of the true front slip angle (truth: for Assumption 2 checks and
    comparisons, never an observer input), hdot (N, 2) [1/s] by central differences,
    alpha_f (N,) [rad].
    """
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    delta = steering_signal(t)
    f = fault_signal(t, t_fault, **(fault_kw or {}))
    F = uncertainty_signal(t, seed)
    X = simulate_truth(model, x0, delta, f, F, dt, pacejka=pacejka)
    y = X @ model.C.T + f[:, None] * model.F_s[:, 0][None, :]
    if noise:
        rng = np.random.default_rng(seed + 1)
        y = y + rng.standard_normal(y.shape) @ model.D_w.T
    af = slip_front(model, X, delta, f)
    h = model.tyres.memberships(af)
    hdot = np.gradient(h, dt, axis=0)
    return {"t": t, "delta": delta, "f": f, "F": F, "X": X, "y": y, "h": h, "hdot": hdot,
            "alpha_f": af, "dt": dt, "t_fault": t_fault}


def evaluate(gains: UIOGains, sc: dict, model: UncertainLateralTS, premise: str = "estimated",
             X0_hat=None) -> dict:
    """Run the UIO on a scenario and compute the paper's error metrics.

    ``premise="estimated"``: memberships of the observer's own slip-angle estimate
    (:func:`run_observer_estimated`; reads only ``sc["delta"], sc["y"], sc["dt"]``);
    ``"true"``: the scenario's true memberships ``sc["h"]`` (comparison only: they contain
    the true slip angle and fault). Returns Xhat (N, 3), h_used (N, 2) and rmse_vy, rmse_r,
    rmse_f after the fault appears (SI units), rmse before it, the fault-estimation delay
    (10 % band; also on the 20 ms moving mean of the error) and the peak |error| per state
    in the 0.5 s after the fault appears.
    """
    if premise == "estimated":
        Xh, hh = run_observer_estimated(gains, model.tyres, model.l_f, model.vx, sc["delta"],
                                        sc["y"], sc["dt"], X0_hat)
    elif premise == "true":
        hh = sc["h"]
        Xh = run_observer(gains, sc["delta"], sc["y"], hh, sc["dt"], X0_hat)
    else:
        raise ValueError(f"premise must be 'estimated' or 'true', got {premise!r}")
    return estimate_metrics(Xh, sc) | {"h_used": hh}


def estimate_metrics(Xh, sc: dict) -> dict:
    """Metrics of :func:`evaluate` for any estimate ``Xh`` (N, 3) = ``[v_y, r, f]`` (SI) of a
    scenario ``sc`` of :func:`make_scenario` (also used for the EKF/UKF baseline,
    :mod:`.baselines.uio_ekf`)."""
    Xh = np.asarray(Xh, dtype=float)
    if Xh.shape != (len(sc["t"]), 3):
        raise ValueError(f"Xh must be ({len(sc['t'])}, 3) = [v_y, r, f], got {Xh.shape}")
    t, tf = sc["t"], sc["t_fault"]
    after = t >= tf
    before = (t < tf) & (t >= 1.0)
    if not before.any() or not after.any():
        raise ValueError(
            f"metric windows need samples in [1 s, t_fault) and in [t_fault, t_end]: got "
            f"t_fault = {tf} s on t in [{t[0]}, {t[-1]}] s (the 'before' window skips the "
            f"first second of convergence, so t_fault must exceed 1 s)")
    ref = np.column_stack([sc["X"], sc["f"]])
    err = Xh - ref
    out = {"Xhat": Xh, "err": err}
    for k, nm in enumerate(("vy", "r", "f")):
        out[f"rmse_{nm}"] = rmse(Xh[:, k], ref[:, k], after)
        out[f"rmse_{nm}_before"] = rmse(Xh[:, k], ref[:, k], before)
    out["fault_delay"] = fault_delay(t, Xh[:, 2], sc["f"], tf)
    out["fault_delay_smoothed"] = fault_delay(t, Xh[:, 2], sc["f"], tf,
                                              window=max(1, int(round(0.02 / sc["dt"]))))
    onset = (t >= tf) & (t <= tf + 0.5)
    out["peak_err_onset"] = np.abs(err[onset]).max(axis=0)
    return out

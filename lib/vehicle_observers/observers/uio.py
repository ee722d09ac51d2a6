"""Relaxed unknown-input observer (UIO) for the uncertain T-S lateral model with a fault
acting on both the steering actuator and a sensor (paper 003, Hindawi 2020; El Youssfi et
al.), and the non-relaxed design of its reference [22].

The extracted paper lost every formula. This module is a reconstruction from its surviving
structure and the standard literature; every choice is listed here and in Notebook 06.

The plant, eqs. (1)-(15) (fuzzy cornering forces (2)/(5)-(7) identified by Levenberg-Marquardt,
uncertain faulty two-rule TS model (8)-(13), its normalised augmented form (14)-(15), the
truth simulation) is :mod:`vehicle_observers.models.uncertain_lateral`. The observer
(20) on sampled data is :class:`UIObserver` (the observer contract of
:mod:`vehicle_observers.core.protocol`).

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

Both designs are calls of the synthesis layer: the error system (24) is
:func:`vehicle_observers.design.uio.uio_system` of the augmented plant (:func:`uio_plant`,
decoupling of ``st``, time unit ``1/radius``: :func:`error_system`), (a) and (b) are
:class:`vehicle_observers.design.slack.SlackSynthesis` with ``lyapunov="quadratic"`` /
``"slack"`` (:func:`quadratic_synthesis`, :func:`relaxed_synthesis`), and each result carries
the layer's certificate rebuilt from the data (``UIOGains.data_certificate``).

Arrays: time series (N,), states (N, 2), augmented (N, 3), memberships (N, 2).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numba import njit

from vehicle_observers.core.errors import InfeasibleDesign, ObserverArgumentError
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.design.constraints import L2Gain, SpectralDisk
from vehicle_observers.design.lmi import LMISolution
from vehicle_observers.design.slack import SlackDesign, SlackSynthesis
from vehicle_observers.design.system import PolytopicSystem
from vehicle_observers.design.uio import Decoupling, uio_system
from vehicle_observers.models.uncertain_lateral import UncertainLateralTS, gbell_derivative
from vehicle_observers.observers.fixed_step import FixedStepObserver, positive, row_names


class AssumptionError(ValueError):
    """A structural existence condition of the UIO (Assumption 1 / 2) does not hold."""


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
    ``X = S * X_s``, ``y_s = y / R``). gamma: certified L2 gain; design: "a" or "b";
    T (3,3) ``I - H Cbar`` of (23a); layer: the synthesis layer's
    :class:`~vehicle_observers.design.slack.SlackDesign` (its ``P``, slack ``G``, gains in the
    time unit ``1 / radius`` and data certificate).
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
    T: np.ndarray | None = None
    layer: SlackDesign | None = None

    @property
    def certificate(self):
        """The LMI certificate of the builders (:class:`vehicle_observers.design.lmi.Certificate`,
        time-scaled units)."""
        return self.solution.certificate

    @property
    def data_certificate(self):
        """The certificate rebuilt from the data by the layer
        (:func:`vehicle_observers.design.certify.certify_slack_observer`: every LMI from the
        decoupled error system's arrays and the gains, the poles and the H-infinity norm of
        each frozen rule; time-scaled units)."""
        return None if self.layer is None else self.layer.certificate

    @property
    def min_margin(self) -> float:
        return self.solution.certificate.min_margin

    @property
    def poles(self) -> np.ndarray:
        """(r, 3) eigenvalues of N_i [1/s]."""
        return np.array([np.linalg.eigvals(n) for n in self.N])


def _check_design_args(who: str, alpha, radius, eps) -> None:
    """The decay rate ``alpha`` [1/s] >= 0, pole-disk ``radius`` [1/s] > 0 and solver
    strictness ``eps`` > 0 of both designs (:class:`ObserverArgumentError` otherwise)."""
    positive(who, "alpha (decay rate)", alpha, allow_zero=True)
    positive(who, "radius", radius)
    positive(who, "eps", eps)


def uio_plant(st: dict) -> PolytopicSystem:
    """The normalised augmented system (14)-(15) as data of the synthesis layer:
    ``X' = Abar_i X + Bbar_i u + Mbar d + Gam f'``, ``y = Cbar X + D_w w`` with the
    performance input ``omega = [f' / s_fd; w]`` (fault rate in units of its bound, unit
    measurement noise): ``E = [Gam, 0]``, ``D = [0, D_w]``, performance output the whole error
    ``e`` (``H = I``, ``Dz = 0``). ``st``: :func:`structure`."""
    p = st["Cbar"].shape[0]
    E = np.hstack([st["Gam"], np.zeros((3, p))])
    D = np.hstack([np.zeros((p, 1)), st["Dw"]])
    return PolytopicSystem(st["Abar"], st["Cbar"], B=st["Bbar"], E=E, D=D,
                           name="El Youssfi 2020 (14)-(15)")


def error_system(st: dict, radius: float, phi: float | None = None) -> PolytopicSystem:
    """The error system (24) on which the gains ``K_i`` are designed, from the layer
    (:func:`vehicle_observers.design.uio.uio_system` with the decoupling ``H, T`` of (23a)
    in ``st``): ``eps' = sum h_i ((T Abar_i - K_i Cbar) eps + (E~_i - K_i D~) omega)``,
    ``e = eps + Dz~ omega`` with ``E~_i = [T Gam, -T Abar_i H D_w]``, ``D~ = [0, (I - Cbar H)
    D_w]``, ``Dz~ = [0, -H D_w]``, in the time unit ``1 / radius`` [s] (conditioning; the L2
    gain does not change). ``phi`` [1/s]: the Assumption 2 bound ``|h_i'| <= phi`` (rate
    bounds of both rules)."""
    plant = uio_plant(st)
    if phi is not None:
        plant = dataclasses.replace(plant, rate_bounds=np.array([phi, phi], dtype=float))
    dec = Decoupling(st["H"], st["T"], float(np.abs(st["T"] @ st["Mbar"]).max()))
    return uio_system(plant, st["Mbar"], dec, time_unit=1.0 / radius)[0]


def quadratic_synthesis(st: dict, alpha: float, radius: float = 200.0, eps: float = 1e-6,
                        disk: bool = True) -> SlackSynthesis:
    """Design (a) as a call of the synthesis layer: :func:`error_system`, one gain per rule
    (``gains="pdc"``), common quadratic ``P`` (``lyapunov="quadratic"``),
    :class:`~vehicle_observers.design.constraints.L2Gain` with decay ``alpha`` (LMI ``Phi[i]``,
    free ``g = gamma^2``) and, with ``disk``, the pole disk ``|lambda| < radius``
    (:class:`~vehicle_observers.design.constraints.SpectralDisk`, ``disk[i]``)."""
    tau = 1.0 / radius
    cons = [L2Gain(alpha * tau, label="Phi")] + ([SpectralDisk(1.0)] if disk else [])
    return SlackSynthesis(error_system(st, radius), cons, gains="pdc", lyapunov="quadratic",
                          eps=eps, order="vertex",
                          name=f"UIO (a) quadratic [22], alpha={alpha:g}")


def relaxed_synthesis(st: dict, alpha: float, phi: float, mu: float, radius: float = 200.0,
                      eps: float = 1e-6, disk: bool = True) -> SlackSynthesis:
    """Design (b), Theorem 2, as a call of the synthesis layer: :func:`error_system` with the
    rate bounds ``phi`` [1/s], one gain per rule, fuzzy Lyapunov matrices ``P_1, P_2`` and the
    Finsler slack ``G`` with the scalar ``mu`` [s] (``lyapunov="slack"``),
    :class:`~vehicle_observers.design.constraints.L2Gain` (``Ups[i,+/-]``) and the pole disk in
    de Oliveira's extended form (``disk[i]``)."""
    if len(st["TA"]) != 2:
        raise ValueError(f"the relaxed design handles two rules (h_2' = -h_1'), got "
                         f"{len(st['TA'])}")
    tau = 1.0 / radius
    cons = [L2Gain(alpha * tau, label="Ups")] + ([SpectralDisk(1.0)] if disk else [])
    return SlackSynthesis(error_system(st, radius, phi), cons, gains="pdc", lyapunov="slack",
                          mu=mu / tau, eps=eps, order="constraint",
                          name=f"UIO (b) relaxed Thm 2, alpha={alpha:g}, phi={phi:g}")


def design_quadratic(model: UncertainLateralTS, alpha: float, st: dict | None = None,
                     radius: float = 200.0, eps: float = 1e-6, disk: bool = True) -> UIOGains:
    """Design (a), the non-relaxed conditions of [22]: common quadratic Lyapunov matrix.

    Minimises ``g = gamma^2`` s.t. ``P > 0`` and, per rule i,
    ``[[2 alpha P + He(P T Abar_i - W_i Cbar), P B_i, I], [*, -g I, D_e^T], [*, *, -I]] < 0``
    (:func:`quadratic_synthesis`, a call of the layer's
    :class:`~vehicle_observers.design.slack.SlackSynthesis`).
    ``disk=False`` drops the pole disk (the paper's conditions alone; ``radius`` then only sets
    the time unit). Raises InfeasibleDesign / CertificationError (either certificate).
    """
    _check_design_args("design_quadratic", alpha, radius, eps)
    st0 = structure(model) if st is None else st
    des = quadratic_synthesis(st0, alpha, radius, eps, disk).solve("gamma")
    return _gains("a", st0, des.L / (1.0 / radius), des, alpha, None, None, radius)


def design_relaxed(model: UncertainLateralTS, alpha: float, phi: float, mu=(1e-6, 1e-3, 1e-2),
                   st: dict | None = None, radius: float = 200.0,
                   eps: float = 1e-6, disk: bool = True) -> UIOGains:
    """Design (b), Theorem 2: fuzzy Lyapunov matrices + Finsler slack ``G``, scalar ``mu``.

    ``mu`` may be a sequence: the LMIs are solved for each value and the lowest certified
    gamma kept (Remark 2: mu is "chosen ... in such a way that the conditions are
    feasible"; :meth:`~vehicle_observers.design.slack.SlackSynthesis.best_mu`).
    ``disk=False``: Theorem 2 alone, without the pole disk. Raises InfeasibleDesign if no mu
    works.
    """
    who = "design_relaxed"
    _check_design_args(who, alpha, radius, eps)
    mus = np.atleast_1d(np.asarray(mu, dtype=float))
    if mus.size == 0 or not np.all(np.isfinite(mus)) or np.any(mus <= 0):
        raise ObserverArgumentError(f"{who}: need mu > 0 (Finsler scalar [s]), got mu={mus}")
    positive(who, "phi", phi, allow_zero=True)
    st = structure(model) if st is None else st
    syn = relaxed_synthesis(st, alpha, phi, float(mus[0]), radius, eps, disk)
    tau = 1.0 / radius
    des = syn.best_mu(mus / tau)
    m_ = float(mus[int(np.argmin(np.abs(mus / tau - des.synthesis.mu)))])
    return _gains("b", st, des.L * radius, des, alpha, phi, m_, radius)


def _gains(kind, st, K, des, alpha, phi, mu, radius):
    r = len(st["TA"])
    N = np.array([st["TA"][i] - K[i] @ st["Cbar"] for i in range(r)])
    L = np.array([K[i] + N[i] @ st["H"] for i in range(r)])
    G = np.array([st["T"] @ B for B in st["Bbar"]])
    S, R = st["_scales"]
    return UIOGains(kind, N, G, L, st["H"], K, S, R, float(des.gamma), alpha, phi, mu,
                    radius, des.solution, st["T"], des)


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
                        radius: float = 200.0, disk: bool = True):
    """Independent eigenvalue certificate of Theorem 2's LMIs at given numeric values
    (time-scaled variables, as stored in an :class:`LMISolution`): the layer's builders
    (:func:`relaxed_synthesis`) re-evaluated in numpy."""
    return relaxed_synthesis(st, alpha, phi, mu, radius, 1e-7, disk).lmi_design().certify(values)


# ------------------------------------------------------------------- feasibility sweep --
def feasibility_map(model, alphas, phis, mu=(1e-6, 1e-3, 1e-2), st=None, radius: float = 200.0,
                    gamma_level: float | None = None, disk: bool = True,
                    eps: float = 1e-6) -> dict:
    """Best certified gamma of (a) (depends on alpha only) and (b) on an alpha x phi grid.

    Returns ``{"alpha", "phi", "gamma_a" (na,), "gamma_b" (na, nphi), "margin_a",
    "margin_b", "status_a" (na,), "status_b" (na, nphi), "feasible_a" (na, nphi),
    "feasible_b"}`` with ``nan`` gammas where the LMIs have no solution whose signs check;
    "feasible" means a solution whose certificate status is ``"certified"`` (margins above
    round-off, :class:`~vehicle_observers.design.lmi.Certificate`; an ``"inconclusive"``
    one is not feasible) with ``gamma <= gamma_level`` (any gamma when None). ``eps``: LMI
    strictness (time-scaled units).
    """
    st = structure(model) if st is None else st
    alphas, phis = np.asarray(alphas, float), np.asarray(phis, float)
    ga = np.full(len(alphas), np.nan)
    ma = np.full(len(alphas), np.nan)
    gb = np.full((len(alphas), len(phis)), np.nan)
    mb = np.full_like(gb, np.nan)
    sa = np.full(len(alphas), "infeasible", dtype=object)
    sb = np.full(gb.shape, "infeasible", dtype=object)
    for k, a in enumerate(alphas):
        try:
            g = design_quadratic(model, a, st, radius=radius, disk=disk, eps=eps)
            ga[k], ma[k], sa[k] = g.gamma, g.min_margin, g.certificate.status
        except InfeasibleDesign:
            pass
        for j, ph in enumerate(phis):
            try:
                g = design_relaxed(model, a, ph, mu, st, radius=radius, disk=disk, eps=eps)
                gb[k, j], mb[k, j], sb[k, j] = g.gamma, g.min_margin, g.certificate.status
            except InfeasibleDesign:
                pass
    lev = np.inf if gamma_level is None else gamma_level
    fa = np.broadcast_to((np.isfinite(ga) & (sa == "certified")
                          & (np.nan_to_num(ga, nan=np.inf) <= lev))[:, None], gb.shape).copy()
    fb = np.isfinite(gb) & (sb == "certified") & (np.nan_to_num(gb, nan=np.inf) <= lev)
    return {"alpha": alphas, "phi": phis, "gamma_a": ga, "gamma_b": gb, "margin_a": ma,
            "margin_b": mb, "status_a": sa, "status_b": sb, "feasible_a": fa,
            "feasible_b": fb}


def phi_bound(model: UncertainLateralTS, delta_dot_max: float, fdot_max: float, D_f: float,
              D_r: float) -> dict:
    """Assumption 2 bound ``phi >= |dh_i/dt|`` [1/s] from stated input bounds, not a run.

    ``|h'| <= max|dh_1/dalpha| |alpha_f'|`` with (3) ``alpha_f' = delta' + f' - (v_y' + l_f
    r')/v_x`` and: ``|delta'| <= delta_dot_max`` [rad/s] (driver), ``|f'| <= fdot_max``
    [rad/s]; tyre forces below the Pacejka peaks ``D_f, D_r`` [N] (friction limit), so
    ``|a_y| <= (Df + Dr)/m``, ``|v_y'| = |a_y - v_x r| <= 2 a_y,max`` (steady-state yaw-rate
    limit ``|r| <= a_y,max / v_x``), ``|r'| <= (l_f D_f + l_r D_r)/I_z``; the uncertain
    equation carries ``1 + rho``. Returns the parts and ``phi``."""
    who = "phi_bound"
    if not (delta_dot_max >= 0 and fdot_max >= 0 and D_f > 0 and D_r > 0):
        raise ObserverArgumentError(f"{who}: input bounds must be >= 0, got delta_dot_max="
                                    f"{delta_dot_max}, fdot_max={fdot_max}, peak forces D_f="
                                    f"{D_f}, D_r={D_r} > 0")
    for name, v in (("delta_dot_max", delta_dot_max), ("fdot_max", fdot_max)):
        positive(who, name, v, allow_zero=True)
    ty = model.tyres
    al = np.linspace(ty.c - 20 * ty.a, ty.c + 20 * ty.a, 400001)
    dh = float(np.abs(gbell_derivative(al, ty.a, ty.b, ty.c)).max())
    Df, Dr = float(D_f), float(D_r)
    k_m = 1 + model.rho * (model.unc_row == 0)
    k_i = 1 + model.rho * (model.unc_row == 1)
    k_f = 1 + model.rho * (model.unc_row == 2)          # error on the front force itself
    k_r = 1 + model.rho * (model.unc_row == 3)          # on the rear force
    ay = k_m * (k_f * Df + k_r * Dr) / model.m
    rdot = k_i * (model.l_f * k_f * Df + model.l_r * k_r * Dr) / model.I_z
    adot = delta_dot_max + fdot_max + (2 * ay + model.l_f * rdot) / model.vx
    return {"delta_dot_max": float(delta_dot_max), "dh_dalpha_max": dh, "ay_max": ay,
            "rdot_max": rdot, "alpha_dot_max": adot,
            "phi": dh * adot}


# ---------------------------------------------------------------------- observer (20) ----
#: columns of the augmented state ``X = [v_y, r, f]`` (and of its scale ``S``)
X_VY, X_R, X_F = range(3)
#: index of each constant of the estimated-premise kernel: bell membership (5)-(7) ``a, b,
#: c``, ``l_f`` [m] and ``v_x`` [m/s] of the front slip angle (3)
PR_A, PR_B, PR_C, PR_LF, PR_VX = range(5)


@njit(cache=True)
def _observer_rhs(z, u, ys, h, N, G, L, out):
    """``z' = sum_i h_i (N_i z + G_i u + L_i y)`` of (20) into ``out`` (normalised)."""
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


@njit(cache=True)
def _run_observer_sched(z0, u, Ys, N, G, L, H, S, prem, dt):
    """RK4 of (20) with the memberships of the *estimated* front slip angle
    ``delta + f_hat - (v_y_hat + l_f r_hat) / v_x`` (held over each step); ``prem`` packs the
    constants at :data:`PR_A` ... :data:`PR_VX`. Returns Xhat_s (K, 3) normalised and h (K, 2)."""
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
        af = u[k] + S[X_F] * out[k, X_F] - (S[X_VY] * out[k, X_VY]
                                            + prem[PR_LF] * S[X_R] * out[k, X_R]) / prem[PR_VX]
        hk[0] = 1.0 / (1.0 + abs((af - prem[PR_C]) / prem[PR_A]) ** (2.0 * prem[PR_B]))
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


@dataclass(frozen=True, eq=False)
class UIOTrajectory(Trajectory):
    """Run of :class:`UIObserver`: the estimate ``x`` (N, 3) ``[v_y, r, f]`` (SI) and ``h``
    (N, 2) the memberships the observer used at each sample (of its own estimate, or the
    measured ones)."""

    h: np.ndarray | None = None


class UIObserver(FixedStepObserver):
    """Unknown-input observer (20) of El Youssfi 2020 (reconstruction), RK4 over each sample
    interval with ``u``, ``y`` and the memberships held, in the normalised coordinates of
    the design; estimates in SI units.

    ``gains`` (:attr:`design`): :class:`UIOGains` of :func:`design_quadratic` /
    :func:`design_relaxed`; ``model``: the uncertain TS model the gains were designed for
    (:class:`~vehicle_observers.models.uncertain_lateral.UncertainLateralTS`: memberships
    (5)-(7), ``l_f``, ``v_x``, output rows ``C``);
    ``dt`` [s]; ``premise``:

    * ``"estimated"`` (the observer): memberships of its own front slip-angle estimate
      ``alpha_f^ = delta + f^ - (v_y^ + l_f r^) / v_x``; input ``u`` (N, 1) the measured
      steering ``delta`` [rad];
    * ``"measured"`` (comparison only): ``u`` (N, 3) ``[delta, h_1, h_2]`` with given
      memberships (rows >= 0, summing to 1).

    ``y`` (N, p) the measurements ``C x + F_s f`` (+ noise) in SI units; ``x0`` (3,) initial
    estimate ``[v_y, r, f]``, default 0. Internal state ``z`` (6,): the observer state of (20)
    and the estimate ``z + H y``, both normalised. Raises
    :class:`~vehicle_observers.core.errors.ObserverArgumentError` if the fastest observer pole
    makes RK4 at this ``dt`` unstable (``|lambda| dt > 2.5``).
    """

    state_names = ("vy_mps", "yaw_rate_radps", "fault_rad")

    def __init__(self, gains: "UIOGains", model: UncertainLateralTS, dt: float,
                 premise: str = "estimated"):
        super().__init__(dt)
        who = type(self).__name__
        if premise not in ("estimated", "measured"):
            raise ObserverArgumentError(f"{who}: premise must be 'estimated' or 'measured', got "
                                        f"{premise!r}")
        r, p = gains.N.shape[0], gains.H.shape[1]
        if premise == "estimated" and r != 2:
            raise ObserverArgumentError(f"{who}: estimated premises need the two-rule bell "
                                        f"model, got {r} rules")
        if model.C.shape[0] != p:
            raise ObserverArgumentError(f"{who}: the gains read {p} outputs, the model has "
                                        f"{model.C.shape[0]} (rows of C)")
        lam = float(np.abs(gains.poles).max())
        if lam * self.dt > 2.5:
            raise ObserverArgumentError(
                f"{who}: observer pole |lambda| = {lam:.3g} 1/s is too fast for RK4 at dt = "
                f"{self.dt} s (|lambda| dt = {lam * self.dt:.2f} > 2.5); use a smaller dt")
        self.design, self.model, self.premise = gains, model, premise
        self.input_names = ("delta_roadwheel_rad",) + (
            () if premise == "estimated" else tuple(f"h{i + 1}" for i in range(r)))
        self.output_names = row_names(model.C, self.state_names[:2])
        ty = model.tyres
        self._prem = np.zeros(PR_VX + 1)
        self._prem[[PR_A, PR_B, PR_C, PR_LF, PR_VX]] = ty.a, ty.b, ty.c, model.l_f, model.vx
        self._H = np.ascontiguousarray(gains.H)
        self._S = np.asarray(gains.S, dtype=float)

    def check_data(self, t, u, y, x0=None):
        t, u, y, x0 = super().check_data(t, u, y, x0)
        if self.premise == "measured":
            h = u[:, 1:]
            if np.abs(h.sum(axis=1) - 1).max() > 1e-9 or h.min() < -1e-12:
                raise ObserverArgumentError(f"{type(self).__name__}: the memberships in u[:, 1:] "
                                            "must be >= 0 and sum to 1 on every row")
        return t, u, y, x0

    def memberships(self, Xs, delta: float) -> np.ndarray:
        """Memberships (5)-(7) ``[h_1, h_2]`` of the estimated front slip angle (3), from the
        normalised estimate ``Xs`` (3,) and the steering ``delta`` [rad]."""
        S, lf = self._S, self.model.l_f
        af = delta + S[X_F] * Xs[X_F] - (S[X_VY] * Xs[X_VY] + lf * S[X_R] * Xs[X_R]) / self.model.vx
        ty = self.model.tyres
        h1 = 1.0 / (1.0 + abs((af - ty.c) / ty.a) ** (2.0 * ty.b))
        return np.array([h1, 1.0 - h1])

    def rhs(self, z, u: float, ys, h) -> np.ndarray:
        """UIO (20), readable numpy: ``z' = sum_i h_i (N_i z + G_i u + L_i y)`` (normalised
        coordinates, ``z`` (3,), ``ys`` (p,), ``h`` (r,)); the compiled twin is
        ``_observer_rhs``."""
        g = self.design
        return sum(h[i] * (g.N[i] @ z + g.G[i][:, 0] * u + g.L[i] @ ys) for i in range(len(h)))

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        ys0 = y[0] / self.design.R
        Xs0 = np.zeros(3) if x0 is None else x0 / self._S
        z0 = Xs0 - self._H @ ys0
        return np.concatenate([z0, z0 + self._H @ ys0])

    def step(self, z, k, t, u, y) -> np.ndarray:
        """UIO (20) ``z' = sum_i h_i (N_i z + G_i u + L_i y)``, ``Xhat = z + H y`` (El Youssfi
        2020, reconstruction): one classical RK4 step of :meth:`rhs` over ``[t_{k-1}, t_k]``
        with ``u_{k-1}``, ``y_{k-1}`` and the memberships ``h_{k-1}`` held (of the estimate
        at ``k - 1``, or measured), then the estimate ``z_k + H y_k``."""
        h_, R = self.dt, self.design.R
        zi, Xs = z[0:3], z[3:6]
        delta, ys = float(u[k - 1, 0]), y[k - 1] / R
        hk = self.memberships(Xs, delta) if self.premise == "estimated" else u[k - 1, 1:]
        k1 = self.rhs(zi, delta, ys, hk)
        k2 = self.rhs(zi + 0.5 * h_ * k1, delta, ys, hk)
        k3 = self.rhs(zi + 0.5 * h_ * k2, delta, ys, hk)
        k4 = self.rhs(zi + h_ * k3, delta, ys, hk)
        zn = zi + h_ / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        return np.concatenate([zn, zn + self._H @ (y[k] / R)])

    def estimate(self, z) -> np.ndarray:
        return z[3:6] * self._S

    def run(self, t, u, y, x0=None) -> UIOTrajectory:
        """The compiled loop (``_run_observer_sched`` or ``_run_observer``): the numbers of
        :meth:`step` looped, and the memberships used per sample."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        g = self.design
        Ys = np.ascontiguousarray(y / g.R)
        z0 = self.initial_state(t, u, y, x0)[0:3]
        delta = np.ascontiguousarray(u[:, 0])
        if self.premise == "estimated":
            sec, (Xs, h) = self.timed(_run_observer_sched, z0, delta, Ys, g.N, g.G, g.L,
                                      self._H, self._S, self._prem, self.dt)
        else:
            h = np.ascontiguousarray(u[:, 1:])
            sec, Xs = self.timed(_run_observer, z0, delta, Ys, h, g.N, g.G, g.L, self._H,
                                 self.dt)
        return UIOTrajectory(t, Xs * g.S, self.state_names, seconds=sec,
                             estimator=type(self).__name__, h=h)


# ------------------------------------------ when can the relaxation enlarge the feasible set --
def kernel_direction_test(st: dict, alphas=(0.0,)) -> dict:
    """Structural test of when Theorem 2 can be feasible where the non-relaxed design of [22]
    is not, for a one-dimensional ``ker Cbar`` (two outputs on the three augmented states).

    Derivation (this reproduction, not printed in the paper). In (a) the gains enter only
    through ``-W_i Cbar``; by the projection (elimination) lemma, with ``n`` spanning
    ``ker Cbar``, the decay LMI ``He(P T Abar_i - W_i Cbar) + 2 alpha P < 0`` has a solution
    ``W_i`` iff ``n^T (He(P T Abar_i) + 2 alpha P) n < 0``, i.e. with ``v = P n``:
    ``v^T (T Abar_i + alpha I) n < 0`` for every rule and ``v^T n > 0`` (any such ``v`` is
    ``P n`` for some ``P > 0``). The L2 rows only ask for a large enough ``gamma`` (scale
    ``P, W`` by ``k`` and ``gamma^2`` by ``k^2``). By Gordan's alternative this linear
    system has no solution iff some convex combination ``A(lam) = sum lam_i T Abar_i`` has
    ``n`` as an eigenvector with eigenvalue ``>= -alpha``; that ``n`` is then a mode of
    ``A(lam) - K Cbar`` for *every* gain ``K``, so the frozen membership ``h = lam``
    (``h' = 0`` satisfies Assumption 2) already defeats Theorem 2. Hence: (a) feasible iff
    (b) can be, for every ``phi`` and every uncertainty size (``T Mbar = 0`` removes
    ``rho``): a relaxed-only cell needs ``dim ker Cbar >= 2``.

    Computed here: ``n``, ``a_i = T Abar_i n`` (SI time, normalised states), the smallest
    relative distance of ``A(lam) n`` from ``span(n)`` over ``lam`` in the simplex (two
    rules: closed form; zero means a certificate of infeasibility exists), and for each
    ``alpha`` [1/s] the LP margin ``max_v min_i -v^T (a_i + alpha n)`` with ``v^T n = 1``,
    ``|v|_inf <= 1e3`` (> 0: (a)'s decay conditions are feasible, solved by scipy's HiGHS).
    Raises :class:`AssumptionError` unless ``dim ker Cbar == 1`` and there are two rules.
    """
    from scipy.linalg import null_space
    from scipy.optimize import linprog

    Cb, TA = st["Cbar"], st["TA"]
    ker = null_space(Cb)
    if ker.shape[1] != 1 or len(TA) != 2:
        raise AssumptionError(f"kernel_direction_test needs dim ker Cbar = 1 and two rules, got "
                              f"{ker.shape[1]} and {len(TA)}")
    n = ker[:, 0]
    a = np.array([A @ n for A in TA])
    Pi = np.eye(len(n)) - np.outer(n, n)
    p1, dp = Pi @ a[0], Pi @ (a[1] - a[0])
    lam = float(np.clip(-(p1 @ dp) / max(dp @ dp, 1e-300), 0.0, 1.0))
    grid = np.unique(np.r_[np.linspace(0.0, 1.0, 1001), lam])
    rel = [np.linalg.norm(Pi @ ((1 - g) * a[0] + g * a[1]))
           / max(np.linalg.norm((1 - g) * a[0] + g * a[1]), 1e-300) for g in grid]
    k = int(np.argmin(rel))
    margins = []
    for al in np.atleast_1d(np.asarray(alphas, float)):
        c = np.r_[np.zeros(len(n)), -1.0]                       # maximise s
        A_ub = np.array([np.r_[ai + al * n, 1.0] for ai in a])  # v^T(a_i + al n) + s <= 0
        res = linprog(c, A_ub=A_ub, b_ub=np.zeros(len(a)), A_eq=[np.r_[n, 0.0]], b_eq=[1.0],
                      bounds=[(-1e3, 1e3)] * len(n) + [(None, 1e6)], method="highs")
        margins.append(float(-res.fun) if res.status == 0 else float("nan"))
    return {"n": n, "a": a, "lam_closest": float(grid[k]), "min_rel_distance": float(rel[k]),
            "alphas": np.atleast_1d(np.asarray(alphas, float)), "lp_margin": np.array(margins)}

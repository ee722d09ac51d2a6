"""EKF / UKF baseline (filterpy) for the fault-estimation problem of Notebook 06.

The filterpy EKF (and UKF) compared with the relaxed UIO of El Youssfi 2020
(:mod:`.observers.uio`, reconstruction) on the same data. The standard filter-based
alternative to a UIO for fault estimation: augment the fault as a random-walk state and run a
Kalman filter on the *nominal* model.

Model (the observer's nominal two-rule TS model, eqs. (8), (14)-(15) of the paper as
reconstructed in :mod:`.models.uncertain_lateral`, **without** the uncertainty ``M F(t) (N_a x + N_b u)``)::

    X = [v_y (m/s), r (rad/s), f (rad)],   u = delta (rad)
    X' = sum_i h_i (Abar_i X + Bbar_i u) + w_X,    Abar_i = [[A_i, B_i], [0, 0]]
    y  = Cbar X + v = C x + F_s f + v,             Cbar = [C, F_s]

``f' = w_f`` is the random-walk fault model. The memberships ``h_i`` are either the same
measured premises the UIO receives (``h`` given, the paper's measurable-premise assumption:
the model is then linear time-varying and the EKF is the exact Kalman filter of the
RK4-discretised model) or computed from the estimated front slip angle
``alpha_f = delta + f - (v_y + l_f r)/v_x`` (``h=None``: a genuinely nonlinear EKF).

Noise rule (:func:`noise_rule`, no tuning against the truth). The filter discretises a
continuous intensity ``q`` as ``Q_k = q dt`` (:mod:`.baselines.filterpy_generic`). Each disturbance is
described by a bound ``s`` on a *rate* (units per second): the fault rate ``fdot_max``
[rad/s], the uncertainty's acceleration ``d_max`` [m/s^2]. Two rules turn ``s`` into ``q``:

* **per-sample rule** (``tau=None``, the notebook's main comparison): the random-walk
  increment over one sample has standard deviation ``s dt`` (the bound times one sample),
  i.e. ``Q_k = s^2 dt^2`` and continuous intensity ``q = s^2 dt``. This is **dt-dependent**:
  the walk spreads ``s sqrt(dt T)`` in a time ``T``, at 1 kHz ``0.05 sqrt(1e-3) ~ 1.6e-3``
  rad in 1 s for the fault against the ``0.05`` rad the rate bound allows, and it would
  spread more at a lower sample rate. It assumes the disturbance changes direction every
  sample, i.e. a filter that expects very slow drifts.
* **correlation-time rule** (``tau`` [s] given, dt-independent): the disturbance keeps its
  bound for about ``tau`` (a drift at rate ``s`` sustained over ``tau`` moves the state by
  ``s tau``); white noise of intensity ``q`` moves it by ``sqrt(q tau)`` (std) in the same
  time, equal for ``q = s^2 tau``. Per sample: ``Q_k = s^2 tau dt``. ``tau`` is a stated
  modelling choice (the notebook uses 1 s, the time unit of the rate bounds), not fitted.

Both rules use:

* ``R = D_w D_w^T`` (the sensor noise variances, ``w ~ N(0, I)`` per sample);
* fault: ``s = fdot_max``, the fault-rate bound the UIO's L2 index is normalised with
  (``model.scale_fdot``): ``q_f = fdot_max^2 dt`` (per-sample) or ``fdot_max^2 tau``;
* states: the uncertainty acts along ``M`` with size ``d_max = max_i |N_a,i| scale_x[:2]``
  (the ``1/m`` or ``1/I_z`` error applied to the force part of the row ``M`` selects, at the
  model's typical state magnitudes), ``Q_x = M M^T d_max^2 dt`` (per-sample) or
  ``M M^T d_max^2 tau``.

Units: SI throughout (m/s, rad/s, rad); arrays (N, ...) over samples.
"""

from __future__ import annotations

import numpy as np

from vehicle_observers.baselines.ekf_observer import EKFObserver, EKFTrajectory, filter_trajectory
from vehicle_observers.baselines.filterpy_generic import run_ukf
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models.uncertain_lateral import UncertainLateralTS
from vehicle_observers.observers.fixed_step import positive, row_names
from vehicle_observers.observers.uio import X_F, X_R, X_VY

Array = np.ndarray


def nominal_augmented(model: UncertainLateralTS):
    """Nominal augmented rule matrices in SI units (not normalised), eqs. (14)-(15).

    Returns ``Abar (r, 3, 3)``, ``Bbar (r, 3, 1)``, ``Cbar (p, 3)`` with
    ``Abar_i = [[A_i, B_i], [0, 0]]`` (the fault adds to the steering), ``Bbar_i = [B_i; 0]``,
    ``Cbar = [C, F_s]``. No uncertainty term: the filter does not know ``F(t)``.
    """
    Ab, Bb = [], []
    for A, B in zip(model.A, model.B):
        Aa = np.zeros((3, 3))
        Aa[:2, :2], Aa[:2, 2:] = A, B
        Ab.append(Aa)
        Bb.append(np.vstack([B, [[0.0]]]))
    return np.array(Ab), np.array(Bb), np.hstack([model.C, model.F_s])


def _blend(w, Ab, Bb):
    """``sum_i w_i Abar_i`` (3, 3) and ``sum_i w_i Bbar_i`` (3,)."""
    A, B = w[0] * Ab[0], w[0] * Bb[0, :, 0]
    for i in range(1, len(w)):
        A = A + w[i] * Ab[i]
        B = B + w[i] * Bb[i, :, 0]
    return A, B


def noise_rule(model: UncertainLateralTS, dt: float, fdot_max: float | None = None,
               tau: float | None = None):
    """``(Q (3, 3) continuous intensity, R (p, p), info)`` by the rule of the module docstring.

    ``fdot_max`` [rad/s] defaults to ``model.scale_fdot``. ``tau=None``: per-sample rule
    (``q = s^2 dt``, dt-dependent); ``tau`` [s] > 0: correlation-time rule (``q = s^2 tau``,
    dt-independent). ``info`` holds ``d_max`` [m/s^2], ``fdot_max`` [rad/s] and ``tau``.
    """
    positive("noise_rule", "dt", dt)
    fd = positive("noise_rule", "fdot_max", model.scale_fdot if fdot_max is None else fdot_max)
    if tau is not None:
        positive("noise_rule", "tau (None for the per-sample rule)", tau)
    Na, _ = model.uncertainty_matrices()
    d_max = float(max(np.abs(n[0]) @ model.scale_x[:2] for n in Na))
    scale = dt if tau is None else float(tau)   # q = s^2 dt  or  q = s^2 tau
    Q = np.zeros((3, 3))
    Q[:2, :2] = model.M @ model.M.T * d_max**2 * scale
    Q[2, 2] = fd**2 * scale
    R = model.D_w @ model.D_w.T
    return Q, R, {"d_max": d_max, "fdot_max": fd, "tau": tau}


def _fault_model(model: UncertainLateralTS, premise: str):
    """``(f, jac)`` of the nominal augmented model (14)-(15) for the premise ``"measured"``
    (``u = [delta, h_1, .., h_r]``), ``"nonlinear"`` (memberships of the estimated front slip
    angle inside ``f``, ``jac`` None: numerical) or ``"estimated"`` (those memberships held
    over the step, exact RK4 map)."""
    Ab, Bb, _ = nominal_augmented(model)
    tyres, lf, vx = model.tyres, model.l_f, model.vx
    eye = np.eye(3)

    def rk4_map(w, X, u0, dt_):
        # the rule-blended model is linear with u and the memberships w held: its RK4 map is
        # exactly X+ = Phi X + Gam u, Phi = sum_k (A dt)^k / k! (k <= 4), Gam = (...) dt B
        A, B = _blend(w, Ab, Bb)
        Ad = A * dt_
        A2 = Ad @ Ad
        S = eye + Ad / 2 + A2 / 6 + A2 @ Ad / 24
        return X + Ad @ (S @ X) + dt_ * (S @ B) * u0, eye + Ad @ S

    if premise == "estimated":
        def w_est(X, u0):
            return tyres.memberships(u0 + X[X_F] - (X[X_VY] + lf * X[X_R]) / vx)

        def f(X, u):
            A, B = _blend(w_est(X, u[0]), Ab, Bb)
            return A @ X + B * u[0]

        def jac(X, u, dt_):
            # memberships of the current estimate held over the step (as the UIO does);
            # the Jacobian leaves out their derivative with respect to X
            return rk4_map(w_est(X, u[0]), X, u[0], dt_)
        return f, jac
    if premise == "measured":
        def f(X, u):
            A, B = _blend(u[1:], Ab, Bb)
            return A @ X + B * u[0]

        def jac(X, u, dt_):
            return rk4_map(u[1:], X, u[0], dt_)
        return f, jac

    def f(X, u):
        af = u[0] + X[X_F] - (X[X_VY] + lf * X[X_R]) / vx
        A, B = _blend(tyres.memberships(af), Ab, Bb)
        return A @ X + B * u[0]
    return f, None


class FaultEKF(EKFObserver):
    """filterpy EKF on the nominal augmented model (14)-(15) with the fault as a random walk,
    at the sample period ``dt`` [s] (the observer contract). ``premise``: ``"measured"``
    (input ``u`` (N, 1 + r) ``[delta, h_1, .., h_r]``, the paper's measurable premises: the
    exact Kalman filter of the RK4-discretised linear time-varying model), ``"estimated"``
    (``u`` (N, 1) ``[delta]``, memberships of the estimated front slip angle held over each
    step, as :class:`.observers.uio.UIObserver` does) or ``"nonlinear"`` (the same
    memberships inside ``f``, numerical Jacobian). ``y`` (N, p) ``C x + F_s f`` (+ noise);
    state ``[v_y, r, f]`` (SI); ``Q``, ``R`` (rule :func:`noise_rule`), ``P0``; ``x0`` (3,)."""

    def __init__(self, model: UncertainLateralTS, dt: float, Q, R, P0,
                 premise: str = "estimated", name: str = "EKF (filterpy)"):
        if premise not in ("measured", "estimated", "nonlinear"):
            raise ObserverArgumentError(f"FaultEKF: premise must be 'measured', 'estimated' or "
                                        f"'nonlinear', got {premise!r}")
        f, jac = _fault_model(model, premise)
        _, _, Cb = nominal_augmented(model)
        r = len(model.A)
        inputs = ("delta_roadwheel_rad",) + (tuple(f"h{i + 1}" for i in range(r))
                                             if premise == "measured" else ())
        states = ("vy_mps", "yaw_rate_radps", "fault_rad")
        super().__init__(f, lambda X, u: Cb @ X, dt, Q, R, P0, states, inputs,
                         row_names(model.C, states[:2]), jac=jac, hjac=lambda X, u: Cb,
                         name=name)
        self.model, self.premise = model, premise


def run_filter(model: UncertainLateralTS, delta, y, dt: float, h=None, kind: str = "ekf",
               Q=None, R=None, X0=None, P0=None, name: str | None = None) -> EKFTrajectory:
    """Run the filterpy EKF (``kind='ekf'``) or UKF (``'ukf'``) on the nominal augmented model.

    delta (N,) [rad] measured steering, y (N, p) measurements ``C x + F_s f + noise`` (SI),
    dt [s]; h (N, r) memberships (measured premises), ``None`` (memberships of the
    estimated front slip angle, numerical Jacobian) or ``"estimated"`` (the same memberships
    held over each step, as :class:`.observers.uio.UIObserver` does; exact RK4 map, Jacobian
    without the membership derivative): :class:`FaultEKF` with premise ``"measured"``,
    ``"nonlinear"`` or ``"estimated"``. ``Q``, ``R``: default :func:`noise_rule` (per-sample
    rule); ``X0`` (3,) default 0 (as the UIO's ``Xhat(0)``); ``P0`` default
    ``diag(scale_x^2)`` (the model's typical magnitudes). Returns an
    :class:`~.baselines.ekf_observer.EKFTrajectory` on ``t = k dt``: ``x`` (N, 3) = ``[v_y,
    r, f]`` posterior estimates in SI units, ``P_diag`` (N, 3).
    """
    who = "run_filter"
    delta = np.asarray(delta, dtype=float)
    if delta.ndim != 1:
        raise ObserverArgumentError(f"{who}: delta must be (N,) [rad], got shape {delta.shape}")
    _, _, Cb = nominal_augmented(model)
    N, p, r = len(delta), Cb.shape[0], len(model.A)
    y = np.asarray(y, dtype=float)
    if y.shape != (N, p):
        raise ObserverArgumentError(f"{who}: y must be ({N}, {p}) (samples x outputs), got "
                                    f"{y.shape}")
    if kind not in ("ekf", "ukf"):
        raise ObserverArgumentError(f"{who}: kind must be 'ekf' or 'ukf', got {kind!r}")
    dt = positive(who, "dt", dt)
    if isinstance(h, str):
        if h != "estimated":
            raise ObserverArgumentError(f"{who}: h must be memberships (N, {r}), None or "
                                        f"'estimated', got {h!r}")
        premise, u = "estimated", delta[:, None]
    elif h is not None:
        h = np.asarray(h, dtype=float)
        if h.shape != (N, r):
            raise ObserverArgumentError(f"{who}: h must be ({N}, {r}) memberships, got "
                                        f"{h.shape}")
        if np.abs(h.sum(axis=1) - 1).max() > 1e-9 or h.min() < -1e-12:
            raise ObserverArgumentError(f"{who}: memberships h must be >= 0 and sum to 1 on "
                                        "every row")
        premise, u = "measured", np.column_stack([delta, h])
    else:
        premise, u = "nonlinear", delta[:, None]
    Qd, Rd, _ = noise_rule(model, dt)
    Q = Qd if Q is None else Q
    R = Rd if R is None else R
    X0 = np.zeros(3) if X0 is None else np.asarray(X0, dtype=float)
    P0 = np.diag(model.scale_x**2) if P0 is None else P0
    name = name or ("EKF (filterpy)" if kind == "ekf" else "UKF (filterpy)")
    t = np.arange(N) * dt
    ekf = FaultEKF(model, dt, Q, R, P0, premise, name)
    if kind == "ekf":
        return ekf.run(t, u, y, X0)
    run = run_ukf(ekf.f, ekf.h, y, u, dt, X0, P0, Q, R, name=name)
    return filter_trajectory(t, run, ekf.state_names)

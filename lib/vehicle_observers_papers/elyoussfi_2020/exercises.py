"""Exercise checkers of notebook 06 (relaxed UIO, El Youssfi 2020 reconstruction).

Each ``check_N(answer, ...)`` computes the expected answer on its own route (a library call
or a closed form, never the notebook's solution cell), calls the student's function on more
than one input (so a hard-coded number fails) and shows one line through
:func:`vehicle_observers.results.teaching.check`: ``correct``, ``not yet`` (with a hint) or
``not attempted`` (the stub still returns ``...``).

1. (23a) by Lemma 2: ``H = Mbar (Cbar Mbar)^+`` and ``T = I - H Cbar`` for three sensor /
   uncertainty pairs.
2. Does a UIO exist for a sensor set? Rank condition of Assumption 1 and detectability of
   ``(T Abar_i, Cbar)``, against :func:`vehicle_observers.observers.uio.structure`.
3. The slowest pole [1/s] of the error dynamics (24) of a design of the yaw-rate-only sensor
   set, against the closed form ``max_i [A_i]_11`` (the unobservable open-loop lateral mode).
4. A constant fault [rad] from the residual ``y_gyro - y_wheel`` of two simulated runs of the
   yaw-rate-only sensor set.
5. The steady fault error [rad] under a ramp fault, from the closed form of (24), against the
   error dynamics (24) with the memberships frozen, integrated by scipy.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from vehicle_observers.observers import uio
from vehicle_observers.results.teaching import check

from vehicle_observers_papers.elyoussfi_2020 import constants as P
from vehicle_observers_papers.elyoussfi_2020 import scenario as sn

#: sensor sets of exercise 2: name -> (C (p, 2), F_s (p, 1), M (2, 1), noise stds (p,))
SENSOR_SETS = {
    "v_y and gyro (C = I), rear cornering-force error (this notebook)":
        ([[1, 0], [0, 1]], [[0], [1]], "rear", [0.02, 0.002]),
    "gyro + wheel-speed yaw rate, rear cornering-force error":
        ([[0, 1], [0, 1]], [[1], [0]], "rear", [0.002, 0.005]),
    "gyro + wheel-speed yaw rate, error on 1/I_z (previous reconstruction)":
        ([[0, 1], [0, 1]], [[1], [0]], [[0], [1]], [0.002, 0.005]),
    "gyro only, error on 1/m": ([[0, 1]], [[1]], [[1], [0]], [0.002]),
    "gyro only, error on 1/I_z": ([[0, 1]], [[1]], [[0], [1]], [0.002]),
    "v_y and gyro (C = I), error on 1/m": ([[1, 0], [0, 1]], [[0], [1]], [[1], [0]], [0.02, 0.002]),
    "v_y and gyro (C = I), error on 1/I_z": ([[1, 0], [0, 1]], [[0], [1]], [[0], [1]], [0.02, 0.002]),
}


def sensor_model(model, name: str):
    """``model`` with the sensors and uncertainty direction of :data:`SENSOR_SETS` ``[name]``."""
    C, F_s, M, sd = SENSOR_SETS[name]
    if M == "rear":                        # the rear-force direction [1/m, -l_r/I_z]^T
        M = [[1.0 / model.m], [-model.l_r / model.I_z]]
    return dataclasses.replace(model, C=np.array(C, float), F_s=np.array(F_s, float),
                               M=np.array(M, float), D_w=np.diag(np.array(sd, float)))


def _is_empty(r) -> bool:
    """The stub's answer: ``...`` or ``None`` (also inside a tuple)."""
    return r is None or r is Ellipsis or (isinstance(r, tuple)
                                           and any(x is None or x is Ellipsis for x in r))


def _collect(f, cases):
    """``f(*case)`` for every case, stacked into one flat array; the first result as is when
    it is still the stub's ``...`` (so the checker says "not attempted")."""
    outs = []
    for case in cases:
        r = f(*case)
        if _is_empty(r):
            return r
        outs.append(np.concatenate([np.ravel(np.asarray(x, dtype=float))
                                    for x in (r if isinstance(r, tuple) else (r,))]))
    return np.concatenate(outs)


def _lemma2_cases(model):
    cases = []
    for m in (model, P.build_model(variant="full")):
        _, _, Cb, Mb, _, _ = m.augmented()
        cases.append((Cb, Mb))
    cases.append((np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]), np.array([[1.0], [2.0], [0.0]])))
    return cases


def check_1(uio_matrices, model):
    """Exercise 06.1: ``uio_matrices(Cbar, Mbar) -> (H, T)`` of (23a) by Lemma 2, on the
    normalised ``Cbar, Mbar`` of this notebook's model, of the ``C = I`` variant, and of a
    made-up 2 x 3 pair. Expected: :func:`uio.pinv_general_solution` and ``I - H Cbar``."""
    cases = _lemma2_cases(model)
    want = []
    for Cb, Mb in cases:
        H = uio.pinv_general_solution(Cb @ Mb, Mb)
        want.append(np.concatenate([H.ravel(), (np.eye(Cb.shape[1]) - H @ Cb).ravel()]))
    return check("06.1", lambda: _collect(uio_matrices, cases), np.concatenate(want),
                 rtol=1e-6, atol=1e-9,
                 hint="the answers are flattened H entries first, then T (3 x 3); check yours: "
                      "H (Cbar Mbar) must equal Mbar with the minimum norm (Lemma 2), "
                      "T Mbar must be 0 and T + H Cbar the identity")


def check_2(uio_exists, model):
    """Exercise 06.2: ``uio_exists(m) -> bool`` for the models of :data:`SENSOR_SETS`
    (:func:`sensor_model`). Expected: whether :func:`uio.structure` (Assumption 1 and the PBH
    detectability test of ``(T Abar_i, Cbar)``) accepts the sensor set."""
    models = [sensor_model(model, n) for n in SENSOR_SETS]
    want = []
    for m in models:
        try:
            uio.structure(m)
            want.append(1.0)
        except uio.AssumptionError:
            want.append(0.0)

    def one(m):
        r = uio_exists(m)
        return r if _is_empty(r) else float(bool(r))

    return check("06.2", lambda: _collect(one, [(m,) for m in models]), np.array(want),
                 hint="one 1/0 per sensor set, in the order of ex.SENSOR_SETS; a set fails if "
                      "(23a) has no solution, or if the error dynamics keep a mode no gain "
                      "moves that does not decay (Re >= 0): which of the two did you test?")


def check_3(slowest_pole, st, gains, model):
    """Exercise 06.3: ``slowest_pole(st, g) -> float``, the largest real part [1/s] of the
    eigenvalues of ``N_i = T Abar_i - K_i Cbar`` over both rules, for every design in
    ``gains``. Expected (closed form): ``max_i [A_i]_11 = -min_i (C_fi + C_ri) / (m v_x)``,
    the unobservable lateral-velocity mode no gain moves."""
    a11 = max(float(A[0, 0]) for A in model.A)
    return check("06.3", lambda: _collect(slowest_pole, [(st, g) for g in gains]),
                 np.full(len(gains), a11), rtol=1e-6,
                 hint="one value per design, in 1/s; the error dynamics (24) of rule i are "
                      "N_i of (23b) (SI time); the slowest pole is the largest real part over "
                      "both rules, and its value does not depend on the design: why?")


def residual_scenarios(model, offsets=(0.012, -0.02), t_end: float = 12.0, seed: int = 5):
    """Two noisy runs (:func:`scenario.make_scenario`) with constant faults ``offsets`` [rad]
    from ``P.t_fault`` (no sine): the data of exercise 4."""
    return [sn.make_scenario(model, t_end, P.dt, P.t_fault, P.x0_true, seed=seed,
                             fault_kw={"offset": o, "amp": 0.0}) for o in offsets]


def check_4(fault_from_residual, model, offsets=(0.012, -0.02)):
    """Exercise 06.4: ``fault_from_residual(sc) -> float`` [rad], a constant fault from the
    residual of the two yaw-rate sources, on two runs with different fault sizes. Expected:
    the true offsets; tolerance 4 standard errors of a mean over the 3.5 s window 0.5 s
    after the onset, ``4 sqrt(s_gyro^2 + s_wheel^2 / n)``."""
    scs = residual_scenarios(model, offsets)
    n = int(round((scs[0]["t"][-1] - P.t_fault - 0.5) / P.dt))
    atol = max(4 * float(np.sqrt(np.sum(np.diag(model.D_w) ** 2) / n)), 1e-9)
    return check("06.4", lambda: _collect(fault_from_residual, [(sc,) for sc in scs]),
                 np.array(offsets, float), rtol=0.0, atol=atol,
                 hint="one value per run, in rad (the runs' faults have opposite signs); "
                      "which combination of the two measurements cancels the state? average it "
                      "over t >= t_fault + 0.5 s")


def ramp_runs(model, gains, rates=(0.002, -0.001), t_end: float = 20.0):
    """Exercise 5's data: for each fault rate ``c`` [rad/s] of ``rates``, the truth with a
    ramp fault ``f = c t``, no steering, no uncertainty signal and no noise, and every design
    of ``gains`` run on it fed the true memberships. Returns rows ``(c, g, h_end, e_f)``: the
    memberships (2,) and the fault error ``f - f_hat`` [rad] at ``t_end``."""
    from vehicle_observers.models import uncertain_lateral as ul

    n = int(round(t_end / P.dt)) + 1
    t = np.arange(n) * P.dt
    rows = []
    for c in rates:
        f, delta = c * t, np.zeros(n)
        X = ul.simulate_truth(model, np.zeros(2), delta, f, 0.0, P.dt)
        y = X @ model.C.T + f[:, None] * model.F_s[:, 0]
        h = model.tyres.memberships(ul.slip_front(model, X, delta, f))
        u = np.column_stack([delta, h])
        rows += [(c, g, h[-1], f[-1] - uio.UIObserver(g, model, P.dt, premise="measured")
                  .run(t, u, y).x[-1, 2]) for g in gains]
    return rows


def check_5(ramp_fault_error, model, gains, rates=(0.002, -0.001)):
    """Exercise 06.5: ``ramp_fault_error(g, h, c) -> float`` [rad], the steady fault error
    ``f - f_hat`` of design ``g`` under a ramp fault of rate ``c`` [rad/s] with memberships
    ``h`` (2,) frozen, from the closed form of (24). Expected: (24) itself,
    ``eps' = N_h eps + T Gam c / s_fd`` from ``eps = 0``, integrated by scipy (LSODA) over
    20 s (the slowest pole has decayed by e^-200 or more), for both designs, two rates and
    the memberships the truth reaches at the end of :func:`ramp_runs`; relative tolerance
    1e-6."""
    from scipy.integrate import solve_ivp

    st = uio.structure(model)
    hs = {c: h for c, _, h, _ in ramp_runs(model, gains[:1], rates)}
    cases, want = [], []
    for c in rates:
        h = np.asarray(hs[c], float)
        for g in gains:
            Nh = h[0] * g.N[0] + h[1] * g.N[1]
            b = st["TG"][:, 0] * c / P.scale_fdot
            sol = solve_ivp(lambda t, e, Nh=Nh, b=b: Nh @ e + b, (0.0, 20.0), np.zeros(3),
                            method="LSODA", rtol=1e-11, atol=1e-14)
            cases.append((g, h, c))
            want.append(float(sol.y[2, -1] * g.S[2]))
    return check("06.5", lambda: _collect(ramp_fault_error, cases), np.array(want), rtol=1e-6,
                 hint="one value per (design, rate), in rad: f - f_hat, not f_hat - f; the "
                      "steady state of (24) has eps' = 0 with the fault rate as its input "
                      "(normalised by s_fd); the fault is the third normalised state, scaled "
                      "back to rad by g.S")

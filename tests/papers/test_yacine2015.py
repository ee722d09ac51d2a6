"""Printed constants of Yacine et al. (IEEE TCST 23(2), 2015) and the chosen (not printed)
Pacejka coefficients, checked against the paper's numbers and its sector bounds; Theorem 1's
bound (34) against the error of the library's observer on a TS-exact truth."""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from vehicle_observers.data import scenarios
from vehicle_observers.models import lateral
from vehicle_observers.observers import ts_premise as to
from vehicle_observers_papers.yacine_2015 import constants as Y
from vehicle_observers_papers.yacine_2015 import theorem1 as T1


def test_table_I_constants():
    assert (Y.m, Y.I_z, Y.a_f, Y.a_r) == (1500.0, 2454.0, 1.1, 1.44)
    assert Y.l_s == 0.5
    assert Y.r_relax == 0.1                       # r_f = r_r = 0.1 (Table I)
    p = Y.params
    assert (p.m, p.I_z, p.a_f, p.a_r, p.l_s, p.r_f, p.r_r) == (1500.0, 2454.0, 1.1, 1.44, 0.5,
                                                                0.1, 0.1)


def test_section_IV_constants():
    assert (Y.M_f1, Y.M_f2, Y.M_r1, Y.M_r2) == (4.2e4, 3.3e4, 4.9e4, 3.3e4)
    assert (Y.vx_min, Y.vx_max) == (0.2, 17.0)
    assert Y.alpha_decay == 0.001
    assert Y.Ts == 0.001
    assert Y.alpha_slip_max == pytest.approx(np.radians(8.0))   # "not exceeding 8 deg" (II-A)


@pytest.mark.parametrize("tire,M1,M2", [(Y.tire_f, 4.2e4, 3.3e4), (Y.tire_r, 4.9e4, 3.3e4)])
def test_chosen_pacejka_gives_exactly_the_sector_bounds(tire, M1, M2):
    """Secant stiffness f(alpha) = F/alpha (16): f(0) = B C D = M_1 and min over |alpha| <= 8
    deg = f(8 deg) = M_2 (f decreasing in |alpha|), so (17)'s bounds are exactly the paper's."""
    assert tire.cornering_stiffness == pytest.approx(M1, rel=1e-12)
    assert tire.secant_stiffness(0.0) == pytest.approx(M1, rel=1e-12)
    assert tire.secant_stiffness(np.radians(8.0)) == pytest.approx(M2, rel=1e-10)
    a = np.linspace(0, np.radians(8.0), 4001)
    f = tire.secant_stiffness(a)
    assert np.all(np.diff(f) < 0)                                   # monotone on [0, 8 deg]
    np.testing.assert_allclose(tire.secant_stiffness(-a), f)        # even
    fmin, fmax = tire.sector_bounds(np.radians(8.0))
    assert fmin == pytest.approx(M2, rel=1e-9) and fmax == pytest.approx(M1, rel=1e-12)
    # the peak is beyond 8 deg (force still rising at the sector edge): slope > 0 there
    da = 1e-6
    assert tire.force(np.radians(8.0) + da) > tire.force(np.radians(8.0))
    assert (tire.C, tire.E) == (1.3, 0.0)


def test_ts_model_vertices_match_eq_21():
    """Vertex matrices of (24) against the printed entries of (21) computed independently."""
    ts = Y.ts_model()
    m, Iz, af, ar, r = Y.m, Y.I_z, Y.a_f, Y.a_r, Y.r_relax
    assert ts.n_rules == 8
    for (Mr, Mf, vx), A, B in zip(ts.z_vertices, ts.A, ts.B, strict=True):
        A21 = np.array([
            [0, -vx, 1, 0],
            [0, 0, 0, 1],
            [-(Mf + Mr) / (m * r), -(af * Mf - ar * Mr) / (m * r), -vx / r, 0],
            [-(af * Mf - ar * Mr) / (Iz * r), -(af**2 * Mf + ar**2 * Mr) / (Iz * r), 0, -vx / r]])
        np.testing.assert_allclose(A, A21, rtol=1e-14)
        np.testing.assert_allclose(B[:, 0], [0, 0, vx * Mf / (m * r), af * vx * Mf / (Iz * r)],
                                   rtol=1e-14)


def test_shipped_vehicle_file_is_the_papers_car():
    """The library's default car (vehicle file ``yacine2015``) is exactly the paper module's."""
    from vehicle_observers.models.vehicle import load_vehicle
    from vehicle_observers_papers.yacine_2015 import constants as yacine2015

    assert load_vehicle("yacine2015").params == yacine2015.params


# ------------------------------------------------------------------ Theorem 1, bound (34) --
@pytest.fixture(scope="module")
def design():
    return to.design_theorem1(Y.ts_model())


@pytest.fixture(scope="module")
def quick_clean():
    return scenarios.emulated_satory(seed=0, quick=True, noise_scale=0.0)


@pytest.fixture(scope="module")
def ts_exact(quick_clean):
    """Noise-free truth of the model the TS form represents exactly ((13) with slip (4)),
    replayed from the curve entry (t = 12 s) so the differentiators start mid-transient."""
    log = scenarios.replay(quick_clean.segment(12.0, 40.0), exact_slip=False)
    log.t = log.t - log.t[0]
    return log


def _scalar_error(t, k, gamma, delta0, T, e0):
    """Closed form of e' = -k e + gamma delta with delta = delta0 on [0, T], 0 after."""
    eT = e0 * np.exp(-k * T) + gamma * delta0 / k * (1 - np.exp(-k * T))
    during = e0 * np.exp(-k * t) + gamma * delta0 / k * (1 - np.exp(-k * t))
    return np.where(t <= T, during, eT * np.exp(-k * (t - T)))


def test_bound_34_is_tight_on_a_scalar_error_and_fails_with_a_wrong_gain():
    """Independent check of the reconstructed bound (34)/(45) where it is tight: the scalar error
    e' = -k e + gamma delta with P = 1 satisfies (33) iff c >= gamma^2 / (2k - alpha); with
    k = alpha and the smallest c = gamma^2 / alpha, Young's inequality in the proof (40) is an
    equality at the steady state e = gamma delta0 / alpha, so the ISS branch meets the error
    there (ratio 1 - e^{-alpha T} at T) and (45) after T starts at the same value. A gain 20 %
    too small (k = 0.8 alpha) with the same c and alpha must break the bound."""
    alpha, gamma, delta0, T, e0 = 1.0, 2.0, 0.5, 4.0, 0.1
    design = SimpleNamespace(alpha=alpha, c=gamma**2 / alpha, alpha1=1.0, alpha2=1.0)
    t = np.arange(0.0, 12.0, 1e-3)
    dn = np.where(t <= T, delta0, 0.0)
    b = T1.bound_34(t, e0, dn, T, design)
    # the two branches in closed form
    iss = np.sqrt(e0**2 * np.exp(-alpha * t) + gamma**2 / alpha**2 * delta0**2)
    np.testing.assert_allclose(b["iss"], iss, rtol=1e-12)
    after = np.sqrt(e0**2 + gamma**2 / alpha**2 * delta0**2 * np.exp(alpha * T)) * np.exp(-alpha * t / 2)
    np.testing.assert_allclose(b["paper"], np.where(t <= T, iss, after), rtol=1e-12)
    assert b["delta_max_T"] == pytest.approx(delta0)
    e = _scalar_error(t, alpha, gamma, delta0, T, e0)
    ratio = np.abs(e) / b["paper"]
    assert ratio.max() <= 1.0 and ratio.max() > 0.97                  # holds, and tight
    assert ratio[t <= T].max() == pytest.approx(1 - np.exp(-alpha * T), rel=2e-3)
    wrong = np.abs(_scalar_error(t, 0.8 * alpha, gamma, delta0, T, e0)) / b["paper"]
    assert wrong.max() > 1.1                                           # a wrong gain fails it


def test_bound_34_on_ts_exact_truth_holds_but_cannot_tell_a_gain_from_none(design, ts_exact):
    """Theorem 1 on the vehicle: noise-free run whose truth is (13)+(4) (exactly the TS form
    inside the sector), observer started 2.9 away. The error norm stays below the bound at
    every sample (ISS form (40) with the measured delta(t) of (30), and the two-branch form
    with T = the differentiator's convergence time), but more than 100 times below it, and
    the open-loop model (all L_i = 0) stays below it too: on this run the bound proves little
    about the gains (the informative test is the scalar one above)."""
    log = ts_exact
    pe = to.estimate_premises(log)
    x0 = np.array([0.5, 0.1, 2.0, -2.0])
    xt = lateral.to_transformed(np.column_stack([log.vy, log.yaw_rate, log.Ff, log.Fr]), Y.params)
    zt = to.ts_premises(log.vy, log.yaw_rate, log.delta, log.vx)
    ts = design.ts
    assert np.all((zt >= ts.zmin) & (zt <= ts.zmax))        # truth inside the sector
    T = T1.convergence_time(log.t, pe.vy - log.vy, band=1e-3)
    ratios = {}
    for name, d in (("designed", design), ("open loop", replace(design, L=0 * design.L))):
        run = to.run_observer(log, d, pe, x0=x0)
        full, dl = T1.premise_mismatch(ts, xt, log.delta, zt, run.z)
        assert np.abs(full[:, :2]).max() < 1e-12            # only Gamma-rows, as in (29)
        en = np.linalg.norm(xt - run.x, axis=1)
        b = T1.bound_34(log.t, en[0], np.linalg.norm(dl, axis=1), T, design)
        assert np.all(en <= b["iss"]) and np.all(en <= b["paper"])
        ratios[name] = (en / b["paper"]).max()
        if name == "designed":
            assert en[0] > 2.5 and en[log.t > 5].max() < 1e-3        # and the error did converge
    assert ratios["designed"] < 0.01 and ratios["open loop"] < 0.01


def test_convergence_time_modes():
    t = np.arange(0.0, 10.0, 0.01)
    err = np.where(t < 2.0, 1.0, 0.0)
    err[(t > 6.0) & (t < 6.5)] = 1.0            # a later excursion (re-convergence)
    assert T1.convergence_time(t, err, 0.5, mode="first") == pytest.approx(2.0)
    assert T1.convergence_time(t, err, 0.5, mode="last") == pytest.approx(6.5)
    assert np.isnan(T1.convergence_time(t, np.ones_like(t), 0.5, mode="first"))
    with pytest.raises(ValueError, match="mode"):
        T1.convergence_time(t, err, 0.5, mode="mid")

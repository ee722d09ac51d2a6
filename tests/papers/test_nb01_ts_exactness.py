"""Helpers of notebook 01 (ts_exactness.py) that are not covered by the notebook test."""

import matplotlib

matplotlib.use("Agg")

from dataclasses import replace  # noqa: E402

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from vehicle_observers.core.errors import ObserverArgumentError  # noqa: E402
from vehicle_observers.models.ts import memberships  # noqa: E402
from vehicle_observers_papers.yacine_2015 import constants as Y  # noqa: E402
from vehicle_observers_papers.yacine_2015 import ts_exactness as exactness  # noqa: E402


def _independent_s1(p, t, delta, vx):
    """(1) with relaxation (6), small-angle slips (4) and Pacejka (7), in the physical state
    (v_y, r, F_f, F_r), written here from the paper's equations and integrated by scipy's
    adaptive Runge-Kutta (DOP853) with the inputs linearly interpolated half a sample late (the
    midpoint of the library's held input): shares no code with the library's TS form or its RK4
    loop."""
    from scipy.integrate import solve_ivp

    h = (t[1] - t[0]) / 2

    def rhs(tt, X):
        vy, r, Ff, Fr = X
        d, v = np.interp(tt - h, t, delta), np.interp(tt - h, t, vx)
        af = d - vy / v - p.a_f * r / v
        ar = -vy / v + p.a_r * r / v
        D = lambda tyre, a: tyre.D * np.sin(tyre.C * np.arctan(tyre.B * a))     # (7) with E = 0
        return [(Ff + Fr) / p.m - v * r, (p.a_f * Ff - p.a_r * Fr) / p.I_z,
                v / p.r_f * (D(p.tire_f, af) - Ff), v / p.r_r * (D(p.tire_r, ar) - Fr)]

    sol = solve_ivp(rhs, (t[0], t[-1]), np.zeros(4), t_eval=t, method="DOP853", rtol=1e-10,
                    atol=1e-10, max_step=1e-3)
    return sol.y.T


def _ts_run(ts, t, delta, vx):
    from vehicle_observers.models import lateral

    x, oob = lateral.simulate_ts(ts, np.zeros(4), delta, vx, t[1] - t[0], Y.params, substeps=4)
    assert not oob.any()
    return x


def test_ts_form_integrates_to_the_nonlinear_model_by_an_independent_integration():
    """Yacine 2015 Sec. III-B: the 8-rule TS form (24) with the printed sector, integrated by
    itself, equals the nonlinear model (1)+(4)+(6)+(7) integrated independently (scipy DOP853 on
    the physical state, transformed by (12) here), inside the sector. The agreement is limited by
    the two integrators (input held vs interpolated), not by the model: 1.5e-4 relative. A TS form
    with a wrong premise factor (the slip's 1/v_x kept, so B(z) and A(z) scale with v_x) or a wrong
    sign is off by tens of percent; catches both."""
    from vehicle_observers.models import lateral

    p, ts = Y.params, Y.ts_model()
    t, delta, vx = exactness.excitation(6.0, 1e-3, 0.12, (6.0, 14.0))
    X = _independent_s1(p, t, delta, vx)
    x_ref = np.column_stack([X[:, 0], X[:, 1], (X[:, 2] + X[:, 3]) / p.m,
                             (p.a_f * X[:, 2] - p.a_r * X[:, 3]) / p.I_z])
    scale = np.abs(x_ref).max(axis=0)
    gap = (np.abs(_ts_run(ts, t, delta, vx) - x_ref) / scale).max()
    assert gap < 1e-3           # measured 1.5e-4
    # the same TS machinery with a wrong premise factor: the v_x of the relaxation not
    # cancelled against the slip's 1/v_x (A's force rows and B multiplied by v_x / 10)
    wrong = lateral.yacine_ts(p, Mf=(Y.M_f2, Y.M_f1), Mr=(Y.M_r2, Y.M_r1), vx_bounds=(Y.vx_min, Y.vx_max))
    wrong.A = wrong.A.copy()
    wrong.B = wrong.B.copy()
    for i, zv in enumerate(wrong.z_vertices):
        wrong.A[i, 2:, :2] *= zv[2] / 10
        wrong.B[i, 2:] *= zv[2] / 10
    assert (np.abs(_ts_run(wrong, t, delta, vx) - x_ref) / scale).max() > 0.1
    # and a wrong sign (the rear slip's +l_r r / v_x taken as -)
    # (a planted model error, not a car: LateralParams refuses a negative l_r when built, so the
    # sign is flipped on a copy after construction)
    import copy

    p_bad = copy.copy(p)
    object.__setattr__(p_bad, "a_r", -p.a_r)
    bad = lateral.yacine_ts(p_bad, Mf=(Y.M_f2, Y.M_f1), Mr=(Y.M_r2, Y.M_r1), vx_bounds=(Y.vx_min, Y.vx_max))
    x_bad, _ = lateral.simulate_ts(bad, np.zeros(4), delta, vx, 1e-3, p, substeps=4)
    assert (np.abs(x_bad - x_ref) / scale).max() > 0.1


def test_emulated_fig1_fits_the_paper_car_and_not_a_wrong_model():
    """Fig. 1 on the paper's configuration (noise-free emulated lap, 40 s): the TS model of the
    paper's car follows the true v_y to a few mm/s (only the small-angle slip (4) and the
    relaxation differ from the truth's exact slip); the same run with a TS model whose front
    sector is that of another tyre (M_f scaled by 0.7) misses by more than ten times as much.
    Catches a Fig. 1 that cannot tell a right model from a wrong one."""
    from vehicle_observers.data import scenarios
    from vehicle_observers.models import lateral
    from vehicle_observers.models.tires import Pacejka

    log = scenarios.emulated_satory(seed=0, quick=True, noise_scale=0.0, v_max=16.5)
    good = exactness.emulated_fig1(Y.params, Y.ts_model(), log)["fits"]["TS, relaxation"]
    soft = Pacejka.from_sector(0.7 * Y.M_f1, 0.7 * Y.M_f2, Y.alpha_slip_max, C=1.3, E=0.0)
    p_soft = replace(Y.params, tire_f=soft)
    ts_soft = lateral.yacine_ts(p_soft, Mf=(0.7 * Y.M_f2, 0.7 * Y.M_f1), Mr=(Y.M_r2, Y.M_r1),
                                vx_bounds=(Y.vx_min, Y.vx_max))
    bad = exactness.emulated_fig1(p_soft, ts_soft, log)["fits"]["TS, relaxation"]
    assert good["vy_rmse"] < 0.005 and good["yaw_corr"] > 0.999
    assert bad["vy_rmse"] > 10 * good["vy_rmse"]


def test_revs_fig1_refuses_a_fit_window_outside_the_log():
    with pytest.raises(ObserverArgumentError, match="fit_fraction"):
        exactness.revs_fig1(None, None, None, fit_fraction=1.0)


@pytest.mark.parametrize("z", [33000.0, 37123.4, 42000.0])
def test_sector_weights_blend_back_to_the_premise(z):
    h1, h2 = exactness.sector_weights(z, Y.M_f2, Y.M_f1)
    assert h1 * Y.M_f2 + h2 * Y.M_f1 == pytest.approx(z, rel=1e-14)
    assert 0 <= h1 <= 1 and h1 + h2 == pytest.approx(1.0)
    # the library's weights (vertex 0 = upper bound) are (h2, h1)
    assert memberships(np.array([z]), [Y.M_f2], [Y.M_f1]) == pytest.approx([h2, h1])


def test_sector_weights_leave_the_unit_interval_outside():
    h1, h2 = exactness.sector_weights(30000.0, Y.M_f2, Y.M_f1)
    assert h1 == pytest.approx(1 + 3000 / 9000) and h2 < 0


def _units_on_every_axis(fig):
    for ax in fig.axes:
        for lab in (ax.get_xlabel(), ax.get_ylabel()):
            if lab:
                assert "[" in lab and "]" in lab, lab


def _legends_off_the_data(fig):
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    n = 0
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is not None:
            n += 1
            assert leg.get_window_extent(r).x0 >= ax.get_window_extent(r).x1 - 1
    return n


def test_tyre_sector_figure_units_and_legends():
    fig = exactness.tyre_sector_figure({"front": Y.tire_f, "rear": Y.tire_r}, np.radians(8.0),
                                       {"front": (Y.M_f2, Y.M_f1), "rear": (Y.M_r2, Y.M_r1)})
    _units_on_every_axis(fig)
    assert _legends_off_the_data(fig) == 2
    assert all(ax.get_xlabel() and ax.get_ylabel() for ax in fig.axes)
    # forces drawn in kN: the front curve peaks near D = 6.49 kN inside 1.5 x 8 deg
    y = fig.axes[0].lines[0].get_ydata()
    assert y.max() == pytest.approx(Y.tire_f.force(np.radians(12.0)) / 1e3, rel=1e-6)
    plt.close(fig)


def test_exactness_figure_difference_column():
    t = np.linspace(0, 1, 11)
    x = np.column_stack([np.sin(t), np.cos(t)])
    fig = exactness.exactness_figure(t, x, x + 1e-15, [(r"x_1 = \beta", "rad"), (r"x_2 = \psi_\beta", "1/m")],
                                     "title")
    _units_on_every_axis(fig)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == [r"$x_1 = \beta$ [rad]", r"$\Delta x_1$ [rad]", r"$x_2 = \psi_\beta$ [1/m]",
                      r"$\Delta x_2$ [1/m]"]
    assert np.allclose(fig.axes[1].lines[0].get_ydata(), 1e-15)
    plt.close(fig)


def test_sector_sweep_weights_follow_the_premise():
    fig, update = exactness.sector_sweep_figure(Y.tire_f, np.radians(8.0), np.radians(11.0))
    a = np.radians(5.0)
    update(a)
    bars = [p.get_height() for p in fig.axes[1].patches[:2]]
    h1, h2 = exactness.sector_weights(Y.tire_f.secant_stiffness(a), Y.M_f2, Y.M_f1)
    assert bars == pytest.approx([h1, h2])
    update(np.radians(10.0))  # outside: the lower-bound weight exceeds 1
    assert fig.axes[1].patches[0].get_height() > 1 and "OUTSIDE" in fig.axes[0].get_title()
    plt.close(fig)


def test_sector_range_error_zero_inside_and_positive_outside():
    fig = exactness.sector_range_figure(Y.tire_f, np.radians(8.0), np.radians(15.0))
    deg, err = fig.axes[1].lines[0].get_data()
    assert np.abs(err[deg <= 7.9]).max() < 1e-9
    # at 15 deg: the blend is M_f2 alpha against the saturated tyre (closed form)
    a = np.radians(15.0)
    F = Y.tire_f.force(np.linspace(1e-6, a, 400))
    assert err[-1] == pytest.approx(100 * (Y.M_f2 * a - Y.tire_f.force(a)) / F.max(), rel=1e-6)
    plt.close(fig)


def test_exactness_figure_legend_overlaps_no_panel():
    """The legend of the exactness figure sits in its own strip, over no panel (it used to cover
    the input row)."""
    t = np.linspace(0, 1, 11)
    x = np.column_stack([np.sin(t), np.cos(t)])
    fig = exactness.exactness_figure(t, x, x + 1e-15, [(r"x_1 = \beta", "rad"), (r"x_2 = \psi_\beta", "1/m")],
                                     "title", inputs={"$u$ [rad]": t, "$v$ [m/s]": t})
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    (leg,) = fig.legends
    box = leg.get_window_extent(r)
    assert not any(box.overlaps(ax.get_window_extent(r)) for ax in fig.axes)
    plt.close(fig)

"""Helpers of notebook 01 (ts_exactness.py) that are not covered by the notebook test."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from vehicle_observers.core.errors import ObserverArgumentError  # noqa: E402
from vehicle_observers.models.ts import memberships  # noqa: E402
from vehicle_observers_papers.yacine_2015 import constants as Y  # noqa: E402
from vehicle_observers_papers.yacine_2015 import ts_exactness as exactness  # noqa: E402

FIT = {"yaw_rmse": 0.07, "yaw_corr": 0.98, "yaw_fit": 72.0, "vy_rmse": 0.35, "vy_corr": 0.9}


def _fits():
    return {name: {k: v + i for k, v in FIT.items()} for i, name in enumerate(exactness.FIT_KEYS)}


def test_revs_fit_metrics_names_units_and_values():
    m = exactness.revs_fit_metrics(_fits(), "revs_heldout", "held-out half")
    want = {f"revs_heldout_{key}_{k}" for key in exactness.FIT_KEYS.values() for k in FIT}
    assert set(m) == want
    assert m["revs_heldout_nl_yaw_rmse"][:2] == (0.07, "rad/s")
    assert m["revs_heldout_ts_vy_rmse"][:2] == (pytest.approx(1.35), "m/s")
    assert m["revs_heldout_lin_yaw_fit"][:2] == (74.0, "")
    assert m["revs_heldout_lin_yaw_fit"][2] == "linear bicycle: yaw-rate fit [%] (held-out half)"


def test_fit_rows_by_model_and_column():
    t = exactness.fit_rows(_fits())
    rows = {r["model"]: r for r in t.rows}
    assert set(rows) == set(exactness.FIT_KEYS)
    assert rows["linear bicycle"]["yaw-rate RMSE [rad/s]"] == pytest.approx(2.07)
    assert rows["TS, relaxation"]["v_y correlation"] == pytest.approx(1.9)


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

"""Independent-plant benchmark helpers: the stiffness box the plant needs (known answer),
the open-loop linear reference, and targets computed from the rows (never typed)."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.lateral import simulate_s1
from vehicle_observers_papers.benchmark_study import figures, plant_study


def _linear_log(scale_f=1.0, scale_r=1.0):
    veh = plant_study.plant_vehicle()
    p = veh.params
    t = np.arange(0, 10, 0.01)
    d = 0.03 * np.sin(2 * np.pi * 0.5 * t)
    vx = np.full_like(t, 20.0)
    from dataclasses import replace

    from vehicle_observers.models.tires import LinearTire
    true = replace(p, tire_f=LinearTire(scale_f * p.tire_f.cornering_stiffness),
                   tire_r=LinearTire(scale_r * p.tire_r.cornering_stiffness))
    X = simulate_s1([0.0, 0.0], d, vx, 0.01, true, exact=False, relaxation=False, substeps=4)
    ex = {"vx_true_mps": vx, "yaw_rate_true_radps": X[:, 1], "delta_true_rad": d}
    return DriveLog(t=t, vx=vx, delta=d, yaw_rate=X[:, 1], vy=X[:, 0], Ff=X[:, 2], Fr=X[:, 3],
                    extra=ex), p


def test_stiffness_box_known_answer():
    log, p = _linear_log(0.8, 1.15)
    box = plant_study.plant_stiffness_box(log, p)
    assert box["cf_ratio_min"] == pytest.approx(0.8, rel=1e-9)
    assert box["cf_ratio_max"] == pytest.approx(0.8, rel=1e-9)
    assert box["cr_ratio_min"] == pytest.approx(1.15, rel=1e-9)


def test_open_loop_linear_is_exact_on_its_own_model():
    log, p = _linear_log()
    assert np.abs(plant_study.open_loop_linear(log, p) - log.vy).max() < 1e-9


def test_targets_are_computed_from_rows():
    rows = [{"dataset": "d", "observer": "open-loop-linear", "rmse_vy": 0.10,
             "cf_ratio_min": 0.9, "cf_ratio_max": 1.1, "cr_ratio_min": 0.9, "cr_ratio_max": 1.1},
            {"dataset": "d", "observer": "ekf", "rmse_vy": 0.07},
            {"dataset": "d", "observer": "rts", "rmse_vy": 0.09},
            {"dataset": "d", "observer": "interval-coordinates", "rmse_vy": 0.2,
             "enclosure_vy": 0.97, "width_vy": 0.3}]
    t = {x["target"]: x for x in plant_study.plant_targets(rows)}
    best = t["best observer <= 0.8 x open loop"]
    assert best["value"] == pytest.approx(0.7) and best["met"] and "ekf" in best["detail"]
    assert t["RTS <= EKF"]["value"] == pytest.approx(0.09 / 0.07) and not t["RTS <= EKF"]["met"]
    enc = t["interval enclosure of v_y (mismatch)"]
    assert enc["value"] == 0.97 and not enc["met"]


def test_fig_plant_draws_one_bar_per_row():
    import matplotlib

    matplotlib.use("Agg")
    rows = [{"dataset": "plant_a", "observer": "open-loop-linear", "rmse_vy": 0.1},
            {"dataset": "plant_a", "observer": "ekf", "rmse_vy": 0.05},
            {"dataset": "plant_b", "observer": "open-loop-linear", "rmse_vy": 0.2},
            {"dataset": "plant_b", "observer": "ekf", "rmse_vy": 0.3}]
    fig = figures.fig_plant(rows)
    assert [a.get_title() for a in fig.axes] == ["a", "b"]          # one panel per manoeuvre
    for ax, want in zip(fig.axes, ({"open-loop-linear": 0.1, "ekf": 0.05},
                                   {"open-loop-linear": 0.2, "ekf": 0.3})):
        names = [t.get_text() for t in ax.get_xticklabels()]
        got = dict(zip(names, (p.get_height() for p in ax.patches)))
        assert got == pytest.approx(want)
        # the target line: 0.8 x the open-loop RMSE of this manoeuvre
        (line,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == ":"]
        assert line.get_ydata()[0] == pytest.approx(0.8 * want["open-loop-linear"])


def test_rts_target_explanation_is_computed():
    diag = {"matched_rts_over_ekf": 0.88, "innov_p_r": 1e-9, "innov_p_ay": 0.3, "q_b": 0.5,
            "dvy_db_r2": 0.6, "smoother_correct": True, "model_mismatch": True}
    t = plant_study.rts_target("d", 0.12, 0.10, diag)
    assert not t["met"] and t["explained"] and "0.880" in t["detail"]
    assert not plant_study.rts_target("d", 0.12, 0.10, {**diag, "smoother_correct": False})["explained"]
    assert not plant_study.rts_target("d", 0.12, 0.10, {**diag, "model_mismatch": False})["explained"]
    met = plant_study.rts_target("d", 0.09, 0.10, diag)
    assert met["met"] and not met["explained"]
    assert "explained" not in plant_study.rts_target("d", 0.12, 0.10)


def test_diagnosis_metrics_names_and_missing_ay():
    diag = {"matched_rts_over_ekf": 0.88, "innov_p_r": 1e-9, "innov_p_ay": 0.3}
    m = plant_study.diagnosis_metrics("plant_x", diag)
    assert m == {"plant_x_rts_matched_ratio": 0.88, "plant_x_innov_p_r": 1e-9,
                 "plant_x_innov_p_ay": 0.3}
    m = plant_study.diagnosis_metrics("revs", {**diag, "innov_p_ay": float("nan")})
    assert set(m) == {"revs_rts_matched_ratio", "revs_innov_p_r"}     # no a_y channel

"""Notebook 07 (benchmark of every observer) in quick mode: key numbers against independent
computations, the issue's targets and the theory of each estimator."""

import numpy as np
import pytest
from vehicle_observers.baselines import kalman as K
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import load_revs
from vehicle_observers.papers import revs250lm as R

pytestmark = [pytest.mark.notebook, pytest.mark.xdist_group("nb07")]


@pytest.fixture(scope="module")
def m(run_notebook):
    return run_notebook("07_benchmark")


def test_real_log_numbers_are_the_library_ekf(m):
    """Recompute the real-log EKF from the tuning the notebook reports: same RMSE."""
    tun = K.KalmanTuning.from_theta(m["revs_tuning"])
    log = load_revs()
    res = K.ekf(log, R.params, tun)
    assert m["revs.ekf.rmse_vy"] == pytest.approx(rmse(res.vy, log.vy), rel=1e-9)
    assert m["revs.ekf.samples"] == len(log) == 55001


def test_real_log_accuracy_target(m):
    # issue 8: best causal estimator <= 0.24 m/s over the whole run (vy = 0 gives 0.743)
    assert m["revs.best_causal_rmse_vy"] <= 0.24
    assert m["revs.best_causal"] in ("ekf", "ukf", "interval-ifqir2017")
    # the interval observer's midpoint is a worse point estimate than the EKF (its model is a
    # linear bicycle with +-10 % stiffness, no a_y); its vy box encloses the INS reference
    # only part of the time on this car (tyres leave the linear range)
    assert m["revs.interval-ifqir2017.rmse_vy"] > m["revs.ekf.rmse_vy"]
    assert 0.4 < m["revs.interval-ifqir2017.enclosure_vy"] < 0.95
    assert m["revs.interval-ifqir2017.enclosure_r"] > 0.95


def test_emulated_runs_follow_theory(m):
    for ds in ("satory_n1", "satory_n3"):
        # truth = the filter's model family (+ relaxation, exact slip): mm/s-level error
        assert m[f"{ds}.ekf.rmse_vy"] < 0.01
        # the smoother is as accurate as the filter here, not better: the truth has tyre
        # relaxation and exact slip angles that the filters' model lacks, so the error is
        # model mismatch, which smoothing does not remove (smoother < filter on the exact
        # model: tests/test_kalman.py::test_rts_equals_filterpy_smoother_on_linear_model)
        assert m[f"{ds}.rts.rmse_vy"] < 0.01
        # interval observer: the Metzler guarantee encloses the truth (speeds clipped into
        # the bands void it on a few samples at the 17 m/s edge)
        assert m[f"{ds}.interval-ifqir2017.enclosure_vy"] >= 0.99
        assert m[f"{ds}.ts-yacine2015.rmse_vy"] < 0.02
    # three times the sensor noise costs the EKF more than nothing
    assert m["satory_n3.ekf.rmse_vy"] > m["satory_n1.ekf.rmse_vy"]
    # interval width grows with the measurement-noise bound (4 sigma of each channel)
    assert m["satory_n3.interval-ifqir2017.width_vy"] > m["satory_n1.interval-ifqir2017.width_vy"]
    # nonlinear manoeuvre (7 deg front slip at 17 m/s): the nonlinear filters stay accurate
    assert m["swd.ekf.rmse_vy"] < 0.02
    # the UKF runs on a window that starts with the filter's own start-up transient; on the
    # same window it is not worse than the same-model EKF (filterpy) by more than 10 %
    assert m["swd.ukf.samples"] == m["swd.ekf-filterpy.samples"]
    assert m["swd.ukf.rmse_vy"] <= 1.1 * m["swd.ekf-filterpy.rmse_vy"]


def test_speed(m):
    assert m["min_speedup_vs_filterpy_ekf"] >= 20
    assert m["speedup_ekf_numba_vs_filterpy"] >= 20
    # 350 s at 1 kHz within 2 s for the numba EKF (extrapolated from the quick run)
    assert m["ekf_numba_350s_1khz_s"] < 2.0
    for ds in ("satory_n1", "revs"):
        assert np.isfinite(m[f"{ds}.interval-ifqir2017.design_s"])


def test_claims_and_figures(m):
    claims = {c["item"]: c for c in m["_doc"]["claims"]}
    assert claims["accuracy target on the real log"]["verdict"] == "reproduced"
    assert claims["RTS smoother frames every RMSE"]["verdict"] in ("reproduced", "differs")
    for f in ("rmse_cost.png", "revs_vy.png", "losses_revs.png"):
        assert (m["_dir"] / f).exists()


def test_where_the_real_log_is_lost(m):
    # the estimates overshoot the INS amplitude; the smoother more than the filter
    assert m["revs_amplitude_ratio_ekf"] < 1.0
    assert m["revs_amplitude_ratio_rts"] < m["revs_amplitude_ratio_ekf"]
    # the EKF error grows with the lateral acceleration (tyre saturation region)
    lo = m["revs_losses"]["|a_y| [m/s^2] [0, 4)"]["ekf"]
    hi = m["revs_losses"]["|a_y| [m/s^2] [10, 20)"]["ekf"]
    assert hi > 1.5 * lo

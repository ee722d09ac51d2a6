"""The compiled UKF (:mod:`vehicle_observers.baselines.ukf`, registered as ``ukf``) equals
filterpy's UnscentedKalmanFilter (``ukf-filterpy``, the reference) to round-off, with and
without the a_y channel, including the covariance and the repairs counted."""

from dataclasses import replace

import numpy as np
import pytest
from vehicle_observers.baselines import kalman as K
from vehicle_observers.baselines.ukf import _sym_eig_extremes, ukf
from vehicle_observers.data.logs import load_revs
from vehicle_observers.estimation import available
from vehicle_observers.models.vehicle import KalmanTuning, load_vehicle

TUNING = KalmanTuning(q_vy=0.27, q_r=0.002, q_b=0.4, R_r=1.6e-5, R_ay=1.3)


@pytest.fixture(scope="module")
def seg():
    return load_revs().segment(300.0, 310.0)


@pytest.mark.parametrize("use_ay", [True, False])
def test_compiled_ukf_equals_filterpy_to_round_off(seg, use_ay):
    log = seg if use_ay else replace(seg, ay=None)
    par = load_vehicle("revs250lm").params
    a = ukf(log, par, TUNING)
    b = K.ukf_filterpy(log, par, TUNING)
    scale = np.abs(b.X).max(axis=0)
    assert np.all(np.abs(a.X - b.X).max(axis=0) <= 1e-9 * np.maximum(scale, 1e-3))
    assert np.abs(a.P - b.P).max() <= 1e-9 * np.abs(b.P).max()
    assert np.allclose(a.Ff, b.Ff, rtol=1e-9, atol=1e-6)
    assert a.info["spd_repairs"] == b.info["spd_repairs"]
    assert a.info["use_ay"] == use_ay


def test_registered_names():
    obs = available()
    assert obs["ukf"].run is not obs["ukf-filterpy"].run
    assert "numba" in obs["ukf"].description and "filterpy" in obs["ukf-filterpy"].description


def test_closed_form_eigenvalues_match_lapack():
    rng = np.random.default_rng(0)
    for _ in range(200):
        A = rng.standard_normal((3, 3))
        S = A @ A.T * 10 ** rng.uniform(-6, 3)
        w = np.linalg.eigvalsh(S)
        lo, hi = _sym_eig_extremes(S)
        assert abs(lo - w[0]) <= 1e-12 * w[-1] and abs(hi - w[-1]) <= 1e-12 * w[-1]
    assert _sym_eig_extremes(np.diag([3.0, 1.0, 2.0])) == (1.0, 3.0)

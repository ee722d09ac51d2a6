"""Rabhi 2004 prints structure, not numbers: the block dimensions of (9) and (24)-(30)."""

import numpy as np
from vehicle_observers.observers import sliding_mode as smo
from vehicle_observers.papers import rabhi2004 as R


def test_part_a_dimensions():
    model = smo.ForceObserverModel.from_params(R.planar)
    Om, Hm = np.empty(R.omega_shape), np.empty(R.H_shape)
    smo._omega_h(0.1, model.as_array(), Om, Hm)
    # Omega maps the 4 forces to the 3 accelerations, H the longitudinal forces to wheels
    assert Om.shape == (R.n_x2, R.n_x4) and Hm.shape == (R.n_x3, R.n_x4)
    Psi = np.empty((R.n_x4, R.n_theta))
    smo._psi(20.0, 0.1, 0.05, 67.0, 67.0, 0.02, np.zeros(4), model.as_array(), Psi)
    # Delta Psi = -x21 x~4 on the 1/sigma columns (printed): columns 0, 2, 4, 6
    Psi2 = np.empty_like(Psi)
    F = np.array([100.0, -50.0, 30.0, 10.0])
    smo._psi(20.0, 0.1, 0.05, 67.0, 67.0, 0.02, F, model.as_array(), Psi2)
    np.testing.assert_allclose((Psi2 - Psi)[np.arange(4), [0, 2, 4, 6]], -20.0 * F)
    W = np.vstack([Om, -Hm])
    assert np.linalg.matrix_rank(W) == R.n_x4  # x~4 recoverable from the injections


def test_part_b_dimensions():
    M, C, K, A11, B11 = R.fullcar.matrices()
    assert M.shape == C.shape == K.shape == (R.n_dof, R.n_dof)
    assert K[:4, :4].shape == R.K11_shape and K[:4, 4:].shape == R.K12_shape
    assert K[4:, :4].shape == R.K21_shape and K[4:, 4:].shape == R.K22_shape
    assert A11.shape == R.A11_shape and B11.shape == R.B11_shape
    # C11, K11 diagonal (paper: "C11 is a positive diagonal matrix")
    for X in (C[:4, :4], K[:4, :4]):
        np.testing.assert_allclose(X, np.diag(np.diag(X)))
        assert np.all(np.diag(X) > 0)
    # wheel order of (26): rear wheels first
    S = R.fullcar.S
    assert np.all(S[:2, 1] < 0) and np.all(S[2:, 1] > 0)

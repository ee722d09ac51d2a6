"""The exercise checkers of notebook 06 accept a worked solution (written here, apart from the
notebook's), say "not attempted" for the stub and reject a wrong answer."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.observers import uio
from vehicle_observers.results.teaching import CORRECT, EMPTY, WRONG
from vehicle_observers_papers.elyoussfi_2020 import constants as P
from vehicle_observers_papers.elyoussfi_2020 import exercises as ex
from vehicle_observers_papers.elyoussfi_2020 import relaxed_uio as us


@pytest.fixture(scope="module")
def case():
    model = P.build_model()
    st = uio.structure(model)
    ga, gb = us.designs(model, st, P.alpha_design, us.phi_design(model)["phi"])
    return {"model": model, "st": st, "gains": [ga, gb]}


@pytest.fixture(scope="module")
def yaw():
    """The yaw-rate-only sensor set (exercises 1, 3 and 4 of the lesson)."""
    model = P.build_model(variant="yaw")
    st = uio.structure(model)
    ga, gb = us.designs(model, st, P.alpha_yaw, us.phi_design(model)["phi"])
    return {"model": model, "st": st, "gains": [ga, gb]}


def _status(outcome):
    return outcome.status


def test_check_1_lemma2(case, monkeypatch):
    monkeypatch.setattr(ex, "check", _shown_off(ex.check))

    def good(Cb, Mb):
        H = Mb @ np.linalg.pinv(Cb @ Mb)
        return H, np.eye(Cb.shape[1]) - H @ Cb

    def wrong(Cb, Mb):                     # transpose instead of the pseudo-inverse
        H = Mb @ (Cb @ Mb).T
        return H, np.eye(Cb.shape[1]) - H @ Cb

    assert ex.check_1(good, case["model"]).status == CORRECT
    assert ex.check_1(wrong, case["model"]).status == WRONG
    assert ex.check_1(lambda Cb, Mb: (..., ...), case["model"]).status == EMPTY


def test_check_2_existence(case, monkeypatch):
    monkeypatch.setattr(ex, "check", _shown_off(ex.check))

    def good(m):
        _, _, Cb, Mb, _, _ = m.augmented()
        if np.linalg.matrix_rank(Cb @ Mb) != np.linalg.matrix_rank(Mb):
            return False
        T = np.eye(3) - Mb @ np.linalg.pinv(Cb @ Mb) @ Cb
        for A in m.augmented()[0]:
            for lam in np.linalg.eigvals(T @ A):
                if lam.real >= -1e-12 and np.linalg.matrix_rank(
                        np.vstack([lam * np.eye(3) - T @ A, Cb]), tol=1e-9) < 3:
                    return False
        return True

    def rank_only(m):                      # forgets detectability
        _, _, Cb, Mb, _, _ = m.augmented()
        return np.linalg.matrix_rank(Cb @ Mb) == np.linalg.matrix_rank(Mb)

    assert ex.check_2(good, case["model"]).status == CORRECT
    assert ex.check_2(rank_only, case["model"]).status == WRONG
    assert ex.check_2(lambda m: ..., case["model"]).status == EMPTY


def test_check_3_slowest_pole(yaw, monkeypatch):
    monkeypatch.setattr(ex, "check", _shown_off(ex.check))

    def good(st, g):
        return max(np.linalg.eigvals(st["TA"][i] - g.K[i] @ st["Cbar"]).real.max()
                   for i in range(2))

    def fastest(st, g):
        return min(np.linalg.eigvals(n).real.min() for n in g.N)

    args = (yaw["st"], yaw["gains"], yaw["model"])
    assert ex.check_3(good, *args).status == CORRECT
    assert ex.check_3(fastest, *args).status == WRONG
    assert ex.check_3(lambda st, g: -0.989, *args).status == WRONG   # rule 1 is -4.05: hard-coded


def test_check_4_fault_from_residual(yaw, monkeypatch):
    monkeypatch.setattr(ex, "check", _shown_off(ex.check))

    def good(sc):
        m = sc["t"] >= sc["t_fault"] + 0.5
        return float(np.mean(sc["y"][m, 0] - sc["y"][m, 1]))

    def gyro_only(sc):                     # reads the gyro, forgets the yaw rate in it
        m = sc["t"] >= sc["t_fault"] + 0.5
        return float(np.mean(sc["y"][m, 0]))

    assert ex.check_4(good, yaw["model"]).status == CORRECT
    assert ex.check_4(gyro_only, yaw["model"]).status == WRONG
    assert ex.check_4(lambda sc: 0.012, yaw["model"]).status == WRONG   # one size for both


def _shown_off(check):
    """``check`` returning its Outcome instead of displaying it."""
    return lambda *a, **k: check(*a, **{**k, "show": False})


def test_check_5_ramp_fault_error(case, monkeypatch):
    monkeypatch.setattr(ex, "check", _shown_off(ex.check))
    st = case["st"]

    def good(g, h, c):
        Nh = h[0] * g.N[0] + h[1] * g.N[1]
        return float(-np.linalg.solve(Nh, st["TG"][:, 0])[2] * c / P.scale_fdot * g.S[2])

    def rule_one(g, h, c):                 # N_1 only, memberships ignored
        return float(-np.linalg.solve(g.N[0], st["TG"][:, 0])[2] * c / P.scale_fdot * g.S[2])

    args = (case["model"], case["gains"])
    assert ex.check_5(good, *args).status == CORRECT
    assert ex.check_5(rule_one, *args).status == WRONG
    assert ex.check_5(lambda g, h, c: ..., *args).status == EMPTY

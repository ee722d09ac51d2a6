"""check_observer: the protocol checks a plug-in writer runs, each shown failing on a
planted defect (so a check that cannot fail would be caught)."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.core.protocol import ObserverBase, run_readable
from vehicle_observers.data.logs import load_revs
from vehicle_observers.estimation import check_observer
from vehicle_observers.estimation.references import LinearKalman
from vehicle_observers.models.vehicle import load_vehicle


@pytest.fixture(scope="module")
def revs():
    return load_revs(min_vx=None)


class Leaky(ObserverBase):
    """dv_y/dt = a_y - v_x r - k v_y (explicit Euler on samples k-1), readable loop only."""

    state_names = ("vy_mps",)
    input_names = ("vx_mps", "ax_mps2")
    output_names = ("yaw_rate_radps", "ay_mps2")
    k = 2.0

    def initial_state(self, t, u, y, x0=None):
        return np.zeros(1)

    def step(self, z, k, t, u, y):
        return z + (t[k] - t[k - 1]) * (y[k - 1, 1] - u[k - 1, 0] * y[k - 1, 0] - self.k * z)

    def estimate(self, z):
        return z


class ReadsTheFuture(Leaky):
    def step(self, z, k, t, u, y):
        j = min(k + 5, len(t) - 1)                     # planted: sample k + 5
        return z + (t[k] - t[k - 1]) * (y[j, 1] - u[j, 0] * y[j, 0] - self.k * z)


class WrongCompiled(Leaky):
    def run(self, t, u, y, x0=None):                   # planted: 1e-6 relative error
        tr = run_readable(self, t, u, y, x0)
        return self.trajectory(tr.t, tr.x * (1 + 1e-6))


class BadShape(Leaky):
    def estimate(self, z):
        return np.r_[z, z]


class NoUnit(Leaky):
    input_names = ("vx", "ax_mps2")


def test_a_correct_observer_passes_on_the_revs_log(revs):
    """A compiled library observer and a readable plug-in reading ax_mps2 pass every check;
    the readable-only one says the comparison proves nothing."""
    rep = check_observer(LinearKalman(load_vehicle("revs250lm")), revs)
    assert rep.ok, str(rep)
    assert [c for c, _, _ in rep.results] == ["names and units", "shapes",
                                               "compiled equals readable", "causality"]
    rep = check_observer(Leaky(), revs)
    assert rep.ok and "nothing to compare" in str(rep)
    rep.raise_if_failed()


@pytest.mark.parametrize("obs, check", [(ReadsTheFuture(), "causality"),
                                        (WrongCompiled(), "compiled equals readable"),
                                        (BadShape(), "shapes"),
                                        (NoUnit(), "names and units")])
def test_each_planted_defect_fails_its_check(revs, obs, check):
    """Catches a check that passes whatever the observer does."""
    rep = check_observer(obs, revs)
    assert [c for c, _ in rep.failed()] == [check], str(rep)
    with pytest.raises(AssertionError, match=check):
        rep.raise_if_failed()

"""The observer contract: Trajectory (the one result type), argument checks, run_readable."""

import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import (
    Observer,
    ObserverBase,
    Trajectory,
    bound_name,
    check_data,
    run_readable,
    split_unit,
)


def test_names_and_bound_names():
    assert split_unit("vy_mps") == ("vy", "mps")
    assert split_unit("yaw_rate_radps") == ("yaw_rate", "radps")
    assert bound_name("vy_mps", "lo") == "vy_lo_mps"
    assert bound_name("yaw_rate_radps", "hi") == "yaw_rate_hi_radps"


def test_from_columns_round_trip_with_bounds_and_flags():
    t = np.arange(5.0)
    cols = {"vy_mps": t * 0.1, "yaw_rate_radps": t * 0.2, "vy_lo_mps": t * 0.1 - 1,
            "vy_hi_mps": t * 0.1 + 1, "low_speed": np.array([1, 0, 0, 0, 0], bool)}
    tr = Trajectory.from_columns(t, cols, seconds=2.0, estimator="x")
    assert tr.names == ("vy_mps", "yaw_rate_radps")
    assert tr.interval and np.all(np.isnan(tr.hi[:, 1]))
    assert list(tr.columns) == ["vy_mps", "yaw_rate_radps", "vy_lo_mps", "vy_hi_mps"]
    assert list(tr.table()) == ["t_s", "vy_mps", "yaw_rate_radps", "vy_lo_mps", "vy_hi_mps",
                                "low_speed"]
    for k, v in cols.items():
        got = tr.table()[k]
        assert np.array_equal(got, v) and got.dtype == np.asarray(v).dtype
    assert tr.us_per_step == pytest.approx(1e6 * 2.0 / 5)
    with pytest.raises(KeyError, match="has no 'Ff_N'"):
        tr.index("Ff_N")


def test_trajectory_refuses_inconsistent_shapes():
    t = np.arange(4.0)
    with pytest.raises(ObserverArgumentError, match="must be"):
        Trajectory(t, np.zeros((3, 1)), ("vy_mps",))
    with pytest.raises(ObserverArgumentError, match="lo and hi"):
        Trajectory(t, np.zeros(4), ("vy_mps",), lo=np.zeros(4))
    with pytest.raises(ObserverArgumentError, match="flag"):
        Trajectory(t, np.zeros(4), ("vy_mps",), flags={"reinit": np.zeros(3, bool)})
    with pytest.raises(ObserverArgumentError, match="no estimate column"):
        Trajectory.from_columns(t, {"vy_lo_mps": t, "vy_hi_mps": t})


@pytest.mark.parametrize("t, u, y, x0, msg", [
    ([0.0], np.zeros((1, 1)), np.zeros((1, 1)), None, "N >= 2"),
    ([0.0, 0.1, 0.1], np.zeros((3, 1)), np.zeros((3, 1)), None, "strictly increasing"),
    ([0.0, 0.1, np.nan], np.zeros((3, 1)), np.zeros((3, 1)), None, "strictly increasing"),
    ([0.0, 0.1, 0.2], np.zeros((3, 2)), np.zeros((3, 1)), None, "u must be"),
    ([0.0, 0.1, 0.2], np.zeros((3, 1)), [[0.0], [np.nan], [0.0]], None, "y has a non-finite value at row 1"),
    ([0.0, 0.1, 0.2], np.zeros((3, 1)), np.zeros((3, 1)), [1.0, 2.0, 3.0], "x0 must be 2"),
])
def test_check_data_names_the_argument(t, u, y, x0, msg):
    with pytest.raises(ObserverArgumentError, match=msg):
        check_data(t, u, y, x0, 1, 1, 2, "obs")


class FirstOrderLag(ObserverBase):
    """x' = (y - x)/tau, exact discretisation: x_k = y_{k-1} + (x_{k-1} - y_{k-1}) e^(-dt/tau)."""

    state_names = ("vy_mps",)
    input_names = ("vx_mps",)
    output_names = ("vy_mps",)

    def __init__(self, tau):
        self.tau = tau

    def initial_state(self, t, u, y, x0=None):
        return np.zeros(1) if x0 is None else np.asarray(x0, float)

    def step(self, z, k, t, u, y):
        a = np.exp(-(t[k] - t[k - 1]) / self.tau)
        return y[k - 1] + (z - y[k - 1]) * a

    def estimate(self, z):
        return z

    def run(self, t, u, y, x0=None):
        return run_readable(self, t, u, y, x0)


def test_run_readable_follows_the_one_meaning_of_step():
    """A step input y = 1 from x = 0: x(t) = 1 - e^(-t/tau) exactly on any grid."""
    obs = FirstOrderLag(0.5)
    assert isinstance(obs, Observer)
    t = np.sort(np.random.default_rng(0).uniform(0, 3, 50))
    tr = obs.run(t, np.ones(50), np.ones(50), x0=[0.0])
    np.testing.assert_allclose(tr["vy_mps"], 1 - np.exp(-(t - t[0]) / 0.5), rtol=0, atol=1e-14)
    assert tr.estimator == "FirstOrderLag (readable)" and tr.lo is None

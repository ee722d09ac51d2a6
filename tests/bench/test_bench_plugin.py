"""The speed bench times one plug-in (``--only``) from a ``.py`` file on a log it names."""

from __future__ import annotations

from vehicle_observers.bench import estimators
from vehicle_observers.data.logs import load_log, revs_log_path, write_csv

PLUGIN = '''
import numpy as np

from vehicle_observers.core.protocol import ObserverBase
from vehicle_observers.estimation import register_observer


class AxOnly(ObserverBase):
    state_names = ("vy_mps",)
    input_names = ("ax_mps2",)
    output_names = ("yaw_rate_radps",)

    def __init__(self, vehicle, dt):
        pass

    def initial_state(self, t, u, y, x0=None):
        return np.zeros(1)

    def step(self, z, k, t, u, y):
        return z + 0.0 * u[k - 1, 0]

    def estimate(self, z):
        return z


register_observer("bench-ax", AxOnly, "reads ax_mps2 (bench test)")
'''


def test_only_times_a_plugin_file_reading_ax_on_revs(tmp_path, capsys):
    """Catches ``--plugin FILE.py`` failing in the bench (module names only), ``--only``
    ignored (every estimator timed), and a plug-in reading ``ax_mps2`` refused on a log
    that has it."""
    (tmp_path / "bench_ax_obs.py").write_text(PLUGIN)
    log = load_log(revs_log_path(), min_vx=None)
    k = log.t - log.t[0] <= 5.0
    write_csv(tmp_path / "revs5.csv", {c: v[k] for c, v in log.columns().items()})
    code = estimators.main(["--plugin", str(tmp_path / "bench_ax_obs.py"), "--only",
                            "bench-ax", "--log", str(tmp_path / "revs5.csv"), "--vehicle",
                            "revs250lm"])
    out = capsys.readouterr().out
    assert code == 0
    rows = [ln.split() for ln in out.splitlines() if ln.strip().startswith(("bench-ax",
                                                                             "ekf-filterpy"))]
    assert [r[0] for r in rows] == ["ekf-filterpy", "bench-ax"], out
    assert rows[1][1] == str(int(k.sum())) and "Error" not in out
    from vehicle_observers.estimation import registry

    registry.unregister("bench-ax")

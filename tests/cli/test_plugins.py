"""A user's own observer, defined outside this repository, in the command line and the registry.

The README's example (section "Adding your own observer") is run as written: through
``--plugin FILE``, ``$VEHICLE_OBSERVERS_PLUGINS``, and an installed entry point (a
``*.dist-info`` folder on ``sys.path``, which is what ``pip install`` of a package declaring
``[project.entry-points."vehicle_observers.estimators"]`` leaves). Its numbers are checked
against theory: on data from its own linear model the estimation error vanishes.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap

import control
import numpy as np
import pytest
from conftest import emulate, save
from vehicle_observers.core.errors import RegistryError
from vehicle_observers.core.metrics import rmse
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.data.logs import repo_root
from vehicle_observers.estimation import registry
from vehicle_observers.models.vehicle import load_vehicle

README = repo_root() / "README.md"


def readme_example() -> str:
    """The Python block after the sentence naming ``my_observer.py`` in the README."""
    text = README.read_text()
    at = text.index("## Adding your own observer")
    m = re.search(r"```python\n(.*?)```", text[at:], re.S)
    assert m, "no python block in the README section"
    return m.group(1)


def cli(*argv, env=None, cwd=None):
    e = {**os.environ, **(env or {})}
    p = subprocess.run([sys.executable, "-m", "vehicle_observers", *map(str, argv)],
                       capture_output=True, text=True, env=e, cwd=cwd, timeout=300)
    return p.returncode, p.stdout, p.stderr


@pytest.fixture(scope="module")
def plugin_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("plugin")
    (d / "my_observer.py").write_text(readme_example())
    return d


@pytest.fixture(scope="module")
def user_log(tmp_path_factory):
    d = tmp_path_factory.mktemp("log")
    log = emulate(T=30.0, fs=100.0, seed=3, profile=lambda t: np.full_like(t, 15.0))
    save(log, d / "log.csv")
    return d / "log.csv", log


def test_readme_example_is_the_file_the_readme_names():
    text = README.read_text()
    assert "`my_observer.py`, is a complete" in text
    assert "register_observer(\"luenberger-yaw\"" in readme_example()


def test_plugin_file_in_observers_and_estimate(plugin_dir, user_log, tmp_path):
    code, out, err = cli("--plugin", plugin_dir / "my_observer.py", "observers")
    assert code == 0, err
    assert "luenberger-yaw" in out and "ekf" in out
    log_path, log = user_log
    est = tmp_path / "est.csv"
    code, out, err = cli("--plugin", plugin_dir / "my_observer.py", "estimate", log_path,
                         "--vehicle", "yacine2015", "--observer", "luenberger-yaw", "--out", est)
    assert code == 0, err
    got = np.genfromtxt(est, delimiter=",", names=True)
    assert {"t_s", "vy_mps", "yaw_rate_radps", "low_speed", "reinit"} <= set(got.dtype.names)
    np.testing.assert_allclose(got["t_s"], log.t, rtol=1e-15)
    # a real estimate: closer to the reference v_y than the trivial v_y = 0, on the emulated
    # log whose truth has Pacejka tyres (not the observer's linear model)
    e_obs, e_zero = rmse(got["vy_mps"], log.vy), rmse(np.zeros_like(log.vy), log.vy)
    assert e_obs < 0.5 * e_zero, (e_obs, e_zero)
    assert "metrics against the log's reference columns" in out


def test_plugin_by_environment_variable(plugin_dir):
    code, out, err = cli("observers", env={"VEHICLE_OBSERVERS_PLUGINS": "my_observer",
                                          "PYTHONPATH": f"{plugin_dir}{os.pathsep}"
                                                        f"{os.environ.get('PYTHONPATH', '')}"})
    assert code == 0, err
    assert "luenberger-yaw" in out


def test_plugin_by_entry_point(plugin_dir, user_log, tmp_path):
    """An installed distribution declaring the entry point: found with no option at all."""
    site = tmp_path / "site"
    pkg = site / "my_package"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "my_observer.py").write_text(readme_example())
    info = site / "my_package-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-package\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent("""\
        [vehicle_observers.estimators]
        luenberger = my_package.my_observer
        """))
    env = {"PYTHONPATH": f"{site}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    code, out, err = cli("observers", env=env)
    assert code == 0, err
    assert "luenberger-yaw" in out
    log_path, _ = user_log
    code, out, err = cli("estimate", log_path, "--vehicle", "yacine2015", "--observer",
                         "luenberger-yaw", "--out", tmp_path / "e.csv", env=env)
    assert code == 0, err


def test_a_broken_plugin_is_one_line_naming_it(tmp_path):
    bad = tmp_path / "broken_obs.py"
    bad.write_text("raise ImportError('needs a package that is not installed')\n")
    code, out, err = cli("--plugin", bad, "observers")
    assert code == 3                 # the plug-in's code raised: never "bad input"
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "broken_obs" in lines[0] and "not installed" in lines[0], err
    assert f"{bad}:1" in lines[0], err           # its file:line
    code, out, err = cli("--plugin", tmp_path / "missing.py", "observers")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "missing.py" in err


def test_a_plugin_returning_no_trajectory_is_named(tmp_path, user_log):
    (tmp_path / "wrong_obs.py").write_text(textwrap.dedent("""\
        from vehicle_observers.estimation import estimator

        @estimator("wrong-shape")
        def run(log, vehicle, **_):
            \"\"\"returns a dict instead of a Trajectory\"\"\"
            return {"vy_mps": log.vx * 0}
        """))
    log_path, _ = user_log
    code, out, err = cli("--plugin", tmp_path / "wrong_obs.py", "estimate", log_path,
                         "--vehicle", "yacine2015", "--observer", "wrong-shape", "--out",
                         tmp_path / "o.csv")
    assert code == 3, err            # a plug-in's defect, not bad input
    assert len(err.strip().splitlines()) == 1 and "wrong-shape" in err and "Trajectory" in err
    assert not (tmp_path / "o.csv").exists()


def test_decorator_registers_in_process_and_duplicates_are_refused(user_log):
    from vehicle_observers.estimation import available, estimator

    @estimator("zero-vy", "the trivial estimate v_y = 0")
    def zero(log, vehicle, **_):
        return Trajectory(log.t, np.zeros(len(log)), ("vy_mps",), estimator="zero-vy")

    try:
        specs = available()
        assert "zero-vy" in specs and specs["zero-vy"].origin == __name__
        _, log = user_log
        tr = specs["zero-vy"].estimate(log, load_vehicle("yacine2015"))
        assert np.all(tr["vy_mps"] == 0.0)
        with pytest.raises(RegistryError, match="registered twice"):
            registry.register(registry.EstimatorSpec("zero-vy", "other", zero, origin="elsewhere"))
        with pytest.raises(RegistryError, match="without spaces"):
            registry.register(registry.EstimatorSpec("two words", "x", zero, origin=__name__))
    finally:
        registry.unregister("zero-vy")
    assert "zero-vy" not in available()


def test_readme_observer_converges_on_its_own_linear_model(plugin_dir):
    """Theory: on noise-free data from the linear single-track model the observer was built
    on, the error e = x - x_hat obeys de/dt = (A - L C) e (stable here: eigenvalues -4.3 and
    -23.8 1/s at 15 m/s for the yacine2015 car), so it decays from 1 m/s to the explicit-Euler
    discretisation error. The truth comes from python-control, not from the observer."""
    sys.path.insert(0, str(plugin_dir))
    try:
        import my_observer
    finally:
        sys.path.remove(str(plugin_dir))
    v = load_vehicle("yacine2015")
    p, vx = v.params, 15.0
    m, Iz, a, b, Cf, Cr = p.m, p.I_z, p.a_f, p.a_r, v.C_f, v.C_r
    A = [[-(Cf + Cr) / (m * vx), -vx - (a * Cf - b * Cr) / (m * vx)],
         [-(a * Cf - b * Cr) / (Iz * vx), -(a * a * Cf + b * b * Cr) / (Iz * vx)]]
    B = [[Cf / m], [a * Cf / Iz]]
    sys_ = control.ss(A, B, np.eye(2), 0)
    t = np.arange(0.0, 4.0, 1e-4)
    delta = 0.03 * np.sin(2 * np.pi * 0.5 * t)
    x = control.forced_response(sys_, t, delta).outputs.T        # (N, 2) [v_y, r]
    obs = my_observer.YawRateLuenberger(v)
    u = np.column_stack([np.full_like(t, vx), delta])
    tr = obs.run(t, u, x[:, 1:2], x0=[x[0, 0] + 1.0, x[0, 1]])
    assert isinstance(tr, Trajectory) and tr.names == ("vy_mps", "yaw_rate_radps")
    late = t > 3.0       # e^(-4.3 * 3) = 2.5e-6 of the initial error left
    err = np.abs(tr["vy_mps"][late] - x[late, 0]).max()
    assert abs(tr["vy_mps"][0] - x[0, 0]) == pytest.approx(1.0)
    assert err < 1e-3 * np.abs(x[:, 0]).max() + 1e-6, err

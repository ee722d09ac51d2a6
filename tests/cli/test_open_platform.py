"""An observer written outside the repository: any log column, options, provenance, errors.

The plug-ins are written to a temporary folder and loaded by path (``--plugin FILE.py``), as
a researcher would; every run is on the shipped Revs log (or its first 60 s, which has the
same columns: ``ax_mps2``, ``beta_rad``, ``deltaFL_rad``, ... beyond the schema's).
"""

from __future__ import annotations

import hashlib
import json
import textwrap

import numpy as np
import pytest
from plugin_sources import AX_PLUGIN
from vehicle_observers.cli.main import main
from vehicle_observers.core.protocol import run_readable
from vehicle_observers.data.logs import load_log, revs_log_path, write_csv
from vehicle_observers.estimation import registry


@pytest.fixture(scope="module")
def revs60(tmp_path_factory):
    """The first 60 s of the Revs log, every column kept."""
    log = load_log(revs_log_path(), min_vx=None)
    k = log.t - log.t[0] <= 60.0
    cols = {c: v[k] for c, v in log.columns().items()}
    p = tmp_path_factory.mktemp("revs") / "revs60.csv"
    write_csv(p, cols)
    return p


@pytest.fixture(scope="module")
def plugins(tmp_path_factory):
    """Plug-in files: ``ax_vy_obs.py`` (correct), and broken ones, each a separate module."""
    d = tmp_path_factory.mktemp("plugins")
    (d / "ax_vy_obs.py").write_text(AX_PLUGIN.format(name="ax-vy"))
    bugs = {
        "name_error_obs": ("+ 0.0 * ax)", "+ 0.0 * axx)"),                 # NameError in step
        "shape_bug_obs": ("return z + (t[k]", "return np.ones(2) + z + (t[k]"),  # ValueError
        "exit_obs": ("self.k = float(gain)", "raise SystemExit(1)"),        # SystemExit
        "warn_obs": ("+ 0.0 * ax)", "+ 0.0 * np.log(ax - 1e9))"),           # RuntimeWarning
    }
    for mod, (old, new) in bugs.items():
        src = AX_PLUGIN.format(name=mod.replace("_obs", "").replace("_", "-"))
        assert old in src
        (d / f"{mod}.py").write_text(src.replace(old, new))
    (d / "flagless_obs.py").write_text(textwrap.dedent('''
        from vehicle_observers.core.protocol import Trajectory
        from vehicle_observers.estimation import estimator


        @estimator("flagless", "v_y = 0, no row flags")
        def run(log, vehicle, **_):
            return Trajectory(log.t, 0.0 * log.vx, ("vy_mps",), estimator="flagless")
        '''))
    yield d
    for n in ("ax-vy", "name-error", "shape-bug", "exit", "warn", "flagless"):
        registry.unregister(n)


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_plugin_reading_ax_mps2_runs_on_revs_with_its_option(capsys, plugins, tmp_path):
    """Catches a loader that reads only the schema's columns (``ax_mps2`` refused as missing
    although it is in the header), ``--set`` not reaching ``build`` (the estimate is
    compared with the observer built with gain 3 and looped independently), and a missing
    or wrong provenance sidecar."""
    out = tmp_path / "est.csv"
    f = plugins / "ax_vy_obs.py"
    code, o, err = run_cli(capsys, "--plugin", f, "estimate", revs_log_path(), "--vehicle",
                           "revs250lm", "--observer", "ax-vy", "--set", "gain=3", "--out", out)
    assert code == 0, err
    got = np.genfromtxt(out, delimiter=",", names=True)
    log = load_log(revs_log_path(), min_vx=None)
    obs = registry.get("ax-vy")
    assert obs.columns == ("ax_mps2", "ay_mps2") and obs.options == {"gain": 2.0}
    import ax_vy_obs

    ref = run_readable(ax_vy_obs.AxVy(None, log.dt, gain=3.0), log.t,
                       np.column_stack([log.vx, log.extra["ax_mps2"]]),
                       np.column_stack([log.yaw_rate, log.ay]))
    assert got["low_speed"].sum() == 0 and got["reinit"].sum() == 0   # one stretch
    np.testing.assert_allclose(got["vy_mps"], ref.x[:, 0], rtol=1e-12, atol=1e-12)
    side = json.loads((tmp_path / "est.csv.provenance.json").read_text())
    assert side["options"] == {"ax-vy": {"gain": 3.0}}
    sha = hashlib.sha256(f.read_bytes()).hexdigest()
    assert side["estimators"]["ax-vy"]["source_sha256"] == sha
    assert side["plugins"] == {"ax_vy_obs.py": sha}
    assert "compiled kernels" not in o and "plug-in's run loop" in o


@pytest.mark.parametrize("argv, what", [
    (("--set", "gian=3"), "has no option 'gian' (its options: gain=2.0)"),
    (("--set", "gain=fast"), "option gain='fast': expected a number"),
    (("--set", "gain"), "expected KEY=VALUE"),
])
def test_set_refuses_unknown_key_and_bad_value_in_one_line(capsys, plugins, revs60, tmp_path,
                                                           argv, what):
    """Catches an option silently swallowed (the run built by ``register_observer`` used to
    ignore extra keywords) or an untyped one reaching the observer as text."""
    out = tmp_path / "est.csv"
    code, _, err = run_cli(capsys, "--plugin", plugins / "ax_vy_obs.py", "estimate", revs60,
                           "--vehicle", "revs250lm", "--observer", "ax-vy", *argv, "--out", out)
    assert code == 2 and len(err.strip().splitlines()) == 1 and what in err, err
    assert not out.exists()


@pytest.mark.parametrize("mod, name, exc, marker", [
    ("name_error_obs", "name-error", "NameError", "axx"),
    ("shape_bug_obs", "shape-bug", "ValueError", "np.ones(2)"),
    ("exit_obs", "exit", "SystemExit", "raise SystemExit"),
])
def test_plugin_exception_is_exit_3_naming_plugin_file_and_line(capsys, plugins, revs60,
                                                               tmp_path, mod, name, exc, marker):
    """Catches a plug-in's bug reported as bad input (exit 2: a shape bug's ValueError), as an
    anonymous "internal error" without file and line, a SystemExit ending the process, and
    output written before the error."""
    out = tmp_path / "est.csv"
    f = plugins / f"{mod}.py"
    line = 1 + next(i for i, ln in enumerate(f.read_text().splitlines()) if marker in ln)
    code, _, err = run_cli(capsys, "--plugin", f, "estimate", revs60, "--vehicle", "revs250lm",
                           "--observer", name, "--out", out)
    assert code == 3, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    if exc == "ValueError":
        # the step returns shape (2,) for (1,): numpy raises when the readable loop stores it
        assert f"plug-in estimator {name!r} raised {exc} at {f}, raised in " in lines[0], err
        assert "protocol.py" in lines[0] and "run_readable" in lines[0]
    else:
        assert f"plug-in estimator {name!r} raised {exc} at {f}:{line}" in lines[0], err
    assert "no output written" in lines[0] and "--debug" in lines[0]
    assert not out.exists() and not (tmp_path / "est.csv.provenance.json").exists()


def test_debug_shows_the_traceback_and_warnings_reach_the_user(plugins, revs60, tmp_path):
    """Catches a global warnings filter / ``np.errstate(all="ignore")`` hiding a plug-in's
    numerical problem (log of a negative number: NaN, then refused as NaN output), the NaN
    output of a plug-in reported as bad input (exit 2) instead of the plug-in's error (exit
    3, naming the file:line of its ``step``), and ``--debug`` not showing the traceback. A
    separate process: pytest records warnings itself."""
    import subprocess
    import sys

    def cli(*argv):
        p = subprocess.run([sys.executable, "-m", "vehicle_observers", *map(str, argv)],
                           capture_output=True, text=True, timeout=300)
        return p.returncode, p.stderr

    out = tmp_path / "est.csv"
    common = ("estimate", revs60, "--vehicle", "revs250lm", "--out", out, "--observer")
    code, err = cli("--plugin", plugins / "name_error_obs.py", "--debug", *common, "name-error")
    assert code == 3 and "Traceback (most recent call last)" in err
    assert "name 'axx' is not defined" in err and "name_error_obs.py" in err
    f = plugins / "warn_obs.py"
    step = 1 + next(i for i, ln in enumerate(f.read_text().splitlines())
                    if ln.strip().startswith("def step("))
    code, err = cli("--plugin", f, "--debug", *common, "warn")
    assert code == 3 and "RuntimeWarning: invalid value encountered in log" in err, err
    code, err = cli("--plugin", f, *common, "warn")
    lines = err.strip().splitlines()
    assert code == 3 and len(lines) == 2, err
    assert lines[0].startswith("warning: plug-in code raised ") and f"{f}:" in lines[0]
    assert "plug-in estimator 'warn' produced" in lines[1] and "NaN/inf" in lines[1]
    assert f"{f}:{step} (in AxVy.step)" in lines[1] and "no output written" in lines[1]
    assert not out.exists()


@pytest.mark.parametrize("observer", ["mbds-kf", "mbds-fg", "mbds-fg-lag5", "vy-zero",
                                      "flagless"])
def test_estimators_without_row_flags_exit_0(capsys, plugins, revs60, tmp_path, observer):
    """Catches the report reading ``low_speed`` / ``reinit`` that an estimator need not give
    (it wrote the output, then exited 3 with KeyError 'low_speed')."""
    out = tmp_path / "est.csv"
    code, o, err = run_cli(capsys, "--plugin", plugins / "flagless_obs.py", "estimate",
                           revs60, "--vehicle", "revs250lm", "--observer", observer,
                           "--out", out)
    assert code == 0, err
    assert out.exists()
    if observer != "mbds-kf":          # mbds-kf runs per stretch in motion: it has row flags
        assert "no row flags" in o


def test_observers_lists_real_needs_options_and_plugins(capsys, plugins):
    """Catches ``observers`` listing ``linear-kf`` as needing no extra column (it refuses a
    log without ``ay_mps2``) and a plug-in's non-schema column or options not shown."""
    code, o, err = run_cli(capsys, "--plugin", plugins / "ax_vy_obs.py", "observers")
    assert code == 0, err
    lines = o.splitlines()

    def block(name):
        i = next(i for i, ln in enumerate(lines) if ln.startswith(f"{name} "))
        return "\n".join(lines[i:i + 4])

    assert "needs columns: ay_mps2;" in block("linear-kf")
    b = block("ax-vy")
    assert "needs columns: ax_mps2, ay_mps2" in b and "options (--set): gain=2.0" in b
    assert "ax_vy_obs.py" in b


def test_linear_kf_refuses_a_log_without_ay(tmp_path):
    """The need listed by ``observers`` is the real one: the registry's check refuses the log
    (independent of the listing: the estimator itself is run)."""
    from vehicle_observers.core.errors import LogFormatError
    from vehicle_observers.data.logs import DriveLog
    from vehicle_observers.models.vehicle import load_vehicle

    t = np.arange(200) * 0.01
    log = DriveLog(t=t, vx=np.full(200, 15.0), delta=0.01 * np.sin(t), yaw_rate=0.05 * np.sin(t))
    with pytest.raises(LogFormatError, match="ay_mps2"):
        registry.get("linear-kf").estimate(log, load_vehicle("yacine2015"))


def test_registry_refuses_a_name_without_unit_and_accepts_any_unit_column():
    """Catches the registry accepting only the 11 schema names (``ax_mps2`` refused), or
    accepting a name without a unit suffix."""
    from vehicle_observers.core.errors import RegistryError
    from vehicle_observers.data.logs import is_log_column

    assert is_log_column("ax_mps2") and is_log_column("deltaFL_rad")
    assert not is_log_column("ax") and not is_log_column("ax_g")
    with pytest.raises(RegistryError, match="not a log column name"):
        registry.register_observer("no-unit", lambda v, dt: None, columns=("ax",))

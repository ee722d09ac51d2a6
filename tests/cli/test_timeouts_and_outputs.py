"""``estimate --timeout`` stops a run that never returns, and an output that cannot be
written is one line (exit 2) for every command.

A plug-in whose run never returns (a busy loop, a sleep, a wait on an event) is stopped
after ``--timeout`` seconds with one line and exit status 2; the partial output is removed
and a previous ``--out`` is left as it was (never replaced by a partial file). ``--out`` on a
read-only file system is one line for ``estimate``, ``identify``, ``campaign`` and
``campaign report``."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import KALMAN, emulate, save
from vehicle_observers.models.vehicle import builtin_vehicles

ROOT = Path(__file__).resolve().parents[2]
BASE = builtin_vehicles()["yacine2015"].read_text()

HANGS = {
    "busy loop": "while True:\n        pass",
    "sleep": "time.sleep(10 ** 6)",
    "event wait": "threading.Event().wait()",
}


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "lib"), env.get("PYTHONPATH", "")])
    return env


@pytest.fixture()
def run(tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    save(emulate(T=20.0, profile=lambda t: np.full_like(t, 15.0)), d / "log.csv")
    (d / "car.toml").write_text(BASE.replace("vx_min = 0.2", "vx_min = 2.0") + KALMAN)
    return d


def _plugin(d: Path, body: str) -> Path:
    f = d / "hanging_plugin.py"
    f.write_text("import threading\nimport time\n\n"
                 "from vehicle_observers.estimation.registry import estimator\n\n\n"
                 "@estimator('test-hangs', 'never returns (tests)')\n"
                 f"def hangs(log, vehicle, **_):\n    {body}\n")
    return f


@pytest.mark.parametrize("how", list(HANGS))
def test_plugin_that_never_returns_is_stopped_by_timeout(run, how):
    """Catches: ``estimate`` hanging for ever on a plug-in, or replacing the old output."""
    plug = _plugin(run, HANGS[how])
    out = run / "est.csv"
    out.write_text("old result\n")
    t0 = time.monotonic()
    p = subprocess.run([sys.executable, "-m", "vehicle_observers", "--plugin", str(plug),
                        "estimate", str(run / "log.csv"), "--vehicle", str(run / "car.toml"),
                        "--observer", "test-hangs", "--out", str(out), "--no-progress",
                        "--timeout", "2"], capture_output=True, text=True, env=_env(), timeout=120)
    assert time.monotonic() - t0 < 60
    assert p.returncode == 2, p.stderr
    assert p.stderr.count("\n") == 1 and "ran longer than --timeout 2 s" in p.stderr
    assert "test-hangs" in p.stderr
    assert out.read_text() == "old result\n"
    assert sorted(f.name for f in run.iterdir()) == ["car.toml", "est.csv", "hanging_plugin.py",
                                                     "log.csv"]


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf"])
def test_timeout_must_be_positive(run, capsys, value):
    """Catches: a timeout of 0 or NaN accepted (a run stopped at once, or never)."""
    from vehicle_observers.cli.main import main

    code = main(["estimate", str(run / "log.csv"), "--vehicle", str(run / "car.toml"),
                 "--observer", "ekf", "--out", str(run / "e.csv"), "--timeout", value])
    err = capsys.readouterr().err
    assert code == 2 and "--timeout must be" in err and not (run / "e.csv").exists()


def test_timeout_not_reached_changes_nothing(run, capsys):
    """Catches: a watchdog that fires after a run finished, or changes its output."""
    from vehicle_observers.cli.main import main

    args = ["estimate", str(run / "log.csv"), "--vehicle", str(run / "car.toml"), "--observer",
            "ekf", "--no-progress"]
    assert main([*args, "--out", str(run / "a.csv")]) == 0
    assert main([*args, "--out", str(run / "b.csv"), "--timeout", "600"]) == 0
    assert (run / "a.csv").read_bytes() == (run / "b.csv").read_bytes()


@pytest.fixture()
def ro_fs(tmp_path):
    """A read-only tmpfs holding a file and a finished tiny campaign folder (root only);
    skipped where it cannot be mounted."""
    d = tmp_path / "ro"
    d.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs",
                                            str(d)], capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        yield d
    finally:
        subprocess.run(["umount", str(d)], capture_output=True)


def test_out_on_a_read_only_file_system_is_one_line(run, ro_fs, tmp_path):
    """Catches: an internal error (exit 3) for an output on a read-only file system."""
    sys.path.insert(0, str(ROOT / "tests" / "campaign"))
    from campaignkit import TINY
    from vehicle_observers.campaign import run as run_campaign
    from vehicle_observers.campaign.spec import dump_toml

    camp = ro_fs / "camp"
    run_campaign({**TINY, "lmi_map": {**TINY["lmi_map"], "stiffness_rel": [0.05]}, "repetitions": 1,
                  "estimators": ["ekf"]}, camp, engine="serial", progress=False)
    spec = tmp_path / "s.toml"
    spec.write_text(dump_toml(TINY))
    assert subprocess.run(["mount", "-o", "remount,ro", str(ro_fs)]).returncode == 0
    cmds = {
        "estimate": ["estimate", str(run / "log.csv"), "--vehicle", str(run / "car.toml"),
                     "--observer", "ekf", "--out", str(ro_fs / "e.csv")],
        "identify": ["identify", str(run / "log.csv"), "--out", str(ro_fs / "v.toml"),
                     "--mass", "1500", "--inertia", "2500", "--a-f", "1.2", "--a-r", "1.4"],
        "campaign": ["campaign", str(spec), "--out", str(ro_fs / "c"), "--engine", "serial"],
        "campaign report": ["campaign", "report", str(camp)],
    }
    for name, argv in cmds.items():
        p = subprocess.run([sys.executable, "-m", "vehicle_observers", *argv], capture_output=True,
                           text=True, env={**_env(), "MPLBACKEND": "Agg"}, timeout=300)
        assert p.returncode == 2, (name, p.stderr)
        assert p.stderr.count("\n") == 1 and "read-only file system" in p.stderr.lower(), \
            (name, p.stderr)
    shutil.rmtree(tmp_path / "run", ignore_errors=True)

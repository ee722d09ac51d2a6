"""Notebook 00 (start here) in quick mode: the metrics it records, two of its RMSEs recomputed by
independent routes (the command line on the real log, an exact discretisation of the open-loop
bicycle with scipy on the common manoeuvre), its exercises and its learning path."""

import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.linalg import expm
from vehicle_observers.data.logs import load_revs, repo_root
from vehicle_observers.models.vehicle import load_vehicle
from vehicle_observers_papers.course import families, path

pytestmark = [pytest.mark.notebook, pytest.mark.xdist_group("nb00")]
#: metrics are stored at 4 significant digits
REL = 1e-3
NAME = "00_start_here"
REPORT = "00_start_here_report"


@pytest.fixture(scope="module")
def m(run_notebook):
    return run_notebook(REPORT)


def test_every_estimator_scored_on_both_datasets(m):
    for n in families.ESTIMATORS:
        assert 0 < m[f"swd.{n}.rmse_vy"] < 0.2, n
        if n == "ts-yacine2015":          # needs the camera, which the Revs log lacks
            assert f"revs.{n}.rmse_vy" not in m
        else:
            assert 0 < m[f"revs.{n}.rmse_vy"] < 1.0, n
    # quick mode: the first 120 s of the Revs log (100 Hz); the manoeuvre: 3 s lead, sine with
    # dwell of 0.75/0.7 + 0.5 + 0.25/0.7 s, 4 s after, sampled at 1 kHz
    assert m["revs.window_s"] == pytest.approx(families.QUICK_WINDOW_S, abs=0.01)
    assert m["swd.duration_s"] == pytest.approx(3.0 + 1.0 / 0.7 + 0.5 + 4.0, abs=1e-3)
    assert m["_doc"]["claims"] == []                          # no paper claim in this notebook
    assert {"learning_path.png", "rmse_vy_by_estimator.png"} <= set(m["_doc"]["files"])


def test_feedback_beats_the_open_loop_bicycle_on_its_own_model(m):
    """On the emulated manoeuvre the filters and the TS observer feed back the yaw rate through
    the truth's tyre family: far below the open-loop linear bicycle."""
    ol = m["swd.open-loop-linear.rmse_vy"]
    for n in ("ts-yacine2015", "ekf", "ukf", "rts"):
        assert m[f"swd.{n}.rmse_vy"] < 0.25 * ol, n


def test_real_log_ekf_rmse_is_the_command_lines(m, tmp_path):
    """The EKF through the command line on the whole Revs CSV (its own ML tuning over the first
    120 s in motion), scored over the notebook's quick window: the same RMSE (the filter is
    causal, so the whole-log estimate cut to the window is the window's)."""
    log = load_revs()
    out = tmp_path / "ekf.csv"
    env = dict(os.environ, VEHICLE_OBSERVERS_CACHE=str(tmp_path / "cache"))
    csv = repo_root() / "data" / "revs_250lm_2014" / "revs_250lm_2014.csv.gz"
    r = subprocess.run([sys.executable, "-m", "vehicle_observers", "estimate", str(csv), "--vehicle",
                        "revs250lm", "--observer", "ekf", "--out", str(out), "--no-progress"],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    d = np.genfromtxt(out, delimiter=",", names=True)
    np.testing.assert_allclose(d["t_s"], log.t)
    w = d["t_s"] <= d["t_s"][0] + families.QUICK_WINDOW_S
    cli = float(np.sqrt(np.mean((d["vy_mps"][w] - log.vy[w]) ** 2)))
    assert m["revs.ekf.rmse_vy"] == pytest.approx(cli, rel=REL)


def test_open_loop_rmse_is_the_exact_discretisation(m):
    """The open-loop linear bicycle recomputed with the exact zero-order-hold transition
    (scipy expm) of the textbook single-track model at every sample's measured speed, from
    v_y = 0 and the first measured yaw rate (RK4 per 1 ms sample differs by ~1e-11 m/s)."""
    log = families.common_manoeuvre(0)
    veh = load_vehicle("yacine2015")
    p = veh.params
    mass, Iz, lf, lr, Cf, Cr = p.m, p.I_z, p.a_f, p.a_r, veh.C_f, veh.C_r
    x, vy = np.array([0.0, log.yaw_rate[0]]), np.zeros(len(log))
    for k in range(1, len(log)):
        vx, h = log.vx[k - 1], log.t[k] - log.t[k - 1]
        M = np.zeros((3, 3))
        M[:2, :2] = h * np.array([[-(Cf + Cr) / (mass * vx), -(lf * Cf - lr * Cr) / (mass * vx) - vx],
                                  [-(lf * Cf - lr * Cr) / (Iz * vx), -(lf**2 * Cf + lr**2 * Cr) / (Iz * vx)]])
        M[:2, 2] = h * np.array([Cf / mass, lf * Cf / Iz])
        E = expm(M)
        x = E[:2, :2] @ x + E[:2, 2] * log.delta[k - 1]
        vy[k] = x[0]
    keep = log.t - log.t[0] >= 2.0
    want = float(np.sqrt(np.mean((vy[keep] - log.vy[keep]) ** 2)))
    assert m["swd.open-loop-linear.rmse_vy"] == pytest.approx(want, rel=REL)


def test_lesson_runs_and_saves_its_figures(run_notebook):
    """The lesson (no metrics) runs and saves its three figures into its own folder."""
    les = run_notebook(NAME)
    names = sorted(p.stem for p in (les["_dir"] / "lesson").glob("*.png"))
    assert names == ["learning_path", "rmse_vy_by_estimator", "vy_manoeuvre"]


def test_learning_path_covers_every_notebook_in_order():
    files = path.notebook_files()
    assert set(files) <= {s.number for s in path.STEPS}, "a notebook missing from the path"
    depth = path.levels()             # raises if a prerequisite comes later in the numbering
    assert depth["00"] == 0 and depth["02"] == depth["01"] + 1
    assert path.step("07").needs == ("02", "03") and "07" in path.step("08").needs
    words, code = path.notebook_size(files["00"])
    row = next(r for r in path.reading_times() if r["notebook"] == NAME)
    assert row["reading [min]"] == int(np.ceil(words / 200 + code))

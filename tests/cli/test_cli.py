"""End-to-end tests of ``python -m vehicle_observers`` on a segment of the shipped real log,
including every error path (one-line message, non-zero exit, no traceback, no output)."""

import subprocess
import sys

import numpy as np
import pytest
from conftest import save
from vehicle_observers.baselines import kalman as K
from vehicle_observers.cli.main import EXIT_INPUT, main
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import load_log, load_revs
from vehicle_observers.estimation import kalman_runs as RG
from vehicle_observers.models.vehicle import builtin_vehicles, load_vehicle

KALMAN_TABLE = """
[kalman]
q_vy = 0.27
q_r = 0.002
q_b = 0.4
R_r = 1.6e-5
R_ay = 1.3
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    seg = load_revs().segment(300.0, 330.0)
    log = d / "revs_seg.csv"
    seg.to_csv(log)
    base = builtin_vehicles()["revs250lm"].read_text()
    veh = d / "revs_fixed.toml"
    veh.write_text(base + KALMAN_TABLE)
    return {"dir": d, "log": log, "veh": veh, "base": base, "seg": seg}


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code, err, *needles):
    assert code == EXIT_INPUT
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("error: ") and "Traceback" not in err
    for n in needles:
        assert n in lines[0], (n, lines[0])


def test_observers_lists_everything_with_needs(capsys):
    code, out, _ = run_cli(capsys, "observers")
    assert code == 0
    for name in ("ekf", "ekf-filterpy", "ukf", "rts", "interval-ifqir2017", "ts-yacine2015"):
        assert f"\n{name} " in "\n" + out
    assert "yL_m, psiL_rad" in out          # the TS observer needs vision
    assert "OFFLINE" in out                 # the smoother is flagged


def test_estimate_ekf_matches_library_and_prints_metrics(capsys, files):
    out_csv = files["dir"] / "est_ekf.csv"
    code, out, err = run_cli(capsys, "estimate", files["log"], "--vehicle", files["veh"],
                             "--observer", "ekf", "--out", out_csv, "--no-progress")
    assert code == 0, err
    est = load_log(out_csv, required=("t_s", "vy_mps", "yaw_rate_radps"), min_vx=None)
    seg = load_log(files["log"])
    veh = load_vehicle(files["veh"])
    ref = K.ekf(seg, veh.params, veh.kalman)
    assert np.allclose(est.t, seg.t)
    assert np.abs(est.vy - ref.vy).max() < 1e-8           # %.10g round trip
    assert {"beta_rad", "vy_std_mps"} <= set(est.extra)
    assert est.Ff is not None and est.Fr is not None
    e = rmse(ref.vy, seg.vy)
    assert f"vy    RMSE {e:.4g} m/s" in out
    assert "real-time factor" in out


def test_estimate_ml_tuning_and_interval_observer_subprocess(files):
    """Through the real entry point: ML tuning (no [kalman] table) and an interval observer."""
    out1 = files["dir"] / "est_rts.csv"
    p = subprocess.run([sys.executable, "-m", "vehicle_observers", "estimate", str(files["log"]),
                        "--vehicle", "revs250lm", "--observer", "rts", "--out", str(out1),
                        "--tune-window", "10"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "OFFLINE" in p.stdout and "vy    RMSE" in p.stdout
    out2 = files["dir"] / "est_iv.csv"
    p = subprocess.run([sys.executable, "-m", "vehicle_observers", "estimate", str(files["log"]),
                        "--vehicle", "revs250lm", "--observer", "interval-ifqir2017",
                        "--out", str(out2)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    est = load_log(out2, required=("t_s", "vy_lo_mps", "vy_hi_mps"), min_vx=None)
    lo, hi = est.extra["vy_lo_mps"], est.extra["vy_hi_mps"]
    assert np.all(lo <= hi)
    assert "enclosure" in p.stdout


def test_error_unknown_observer(capsys, files):
    out = files["dir"] / "never.csv"
    code, _, err = run_cli(capsys, "estimate", files["log"], "--vehicle", files["veh"],
                           "--observer", "kalman9000", "--out", out)
    assert_one_line_error(code, err, "unknown observer 'kalman9000'", "ekf")
    assert not out.exists()


def test_error_missing_column_named(capsys, files):
    seg = files["seg"]
    cols = seg.columns()
    cols.pop("yaw_rate_radps")
    bad = files["dir"] / "no_yaw.csv"
    from vehicle_observers.data.logs import write_csv

    write_csv(bad, cols)
    out = files["dir"] / "never.csv"
    code, _, err = run_cli(capsys, "estimate", bad, "--vehicle", files["veh"], "--observer",
                           "ekf", "--out", out)
    assert_one_line_error(code, err, "'yaw_rate_radps'")
    # an observer-specific column: the TS observer needs vision, which the real log lacks
    code, _, err = run_cli(capsys, "estimate", files["log"], "--vehicle", files["veh"],
                           "--observer", "ts-yacine2015", "--out", out)
    assert_one_line_error(code, err, "missing column 'yL_m'", "ts-yacine2015")
    assert not out.exists()


def test_error_bad_values_in_log(capsys, files):
    text = files["log"].read_text().splitlines()
    header = text[0].split(",")
    row = text[5].split(",")
    row[header.index("vx_mps")] = "nan"
    bad = files["dir"] / "nan.csv"
    bad.write_text("\n".join(text[:5] + [",".join(row)] + text[6:]) + "\n")
    out = files["dir"] / "never.csv"
    code, _, err = run_cli(capsys, "estimate", bad, "--vehicle", files["veh"], "--observer",
                           "ekf", "--out", out)
    assert_one_line_error(code, err, "'vx_mps'", "row 4")
    code, _, err = run_cli(capsys, "estimate", files["dir"] / "absent.csv", "--vehicle",
                           files["veh"], "--observer", "ekf", "--out", out)
    assert_one_line_error(code, err, "no such file")
    assert not out.exists()


@pytest.mark.parametrize("edit, needle", [
    (lambda s: s.replace("m = 982.0\n", ""), "missing key 'm'"),
    (lambda s: s.replace("D = 5583.369675", "D = -3.0"), "key 'tire_front.D'"),
    (lambda s: s.replace('model = "pacejka"', 'model = "magic"', 1), "key 'tire_front.model'"),
    (lambda s: s.replace("I_z = ", "I_z = \"big\" #"), "key 'I_z'"),
    (lambda s: s + "\n[kalman]\nq_vy = 1\n", "missing key 'kalman.q_r'"),
    (lambda s: s.replace("vx_max = 62.0", "vx_max = 5.0"), "'uncertainty.vx_min'"),
    (lambda s: s.replace("[tire_rear]", "[tire_rear"), "not valid TOML"),
])
def test_error_vehicle_file_names_the_key(capsys, files, edit, needle):
    veh = files["dir"] / "bad_vehicle.toml"
    veh.write_text(edit(files["base"]))
    out = files["dir"] / "never.csv"
    code, _, err = run_cli(capsys, "estimate", files["log"], "--vehicle", veh, "--observer",
                           "ekf", "--out", out)
    assert_one_line_error(code, err, "bad_vehicle.toml", needle)
    assert not out.exists()


def test_error_interval_needs_uncertainty_and_infeasible_design(capsys, files):
    out = files["dir"] / "never.csv"
    veh = files["dir"] / "no_box.toml"
    base = files["base"]
    veh.write_text(base[:base.index("[uncertainty]")])
    code, _, err = run_cli(capsys, "estimate", files["log"], "--vehicle", veh, "--observer",
                           "interval-ifqir2017", "--out", out)
    assert_one_line_error(code, err, "'uncertainty.stiffness_rel'")
    # +-50 % stiffness: no Metzler gain exists (needs c_r l_r > c_f l_f on the whole box)
    veh2 = files["dir"] / "wide_box.toml"
    veh2.write_text(base.replace("stiffness_rel = 0.10", "stiffness_rel = 0.5"))
    code, _, err = run_cli(capsys, "estimate", files["log"], "--vehicle", veh2, "--observer",
                           "interval-ifqir2017", "--out", out)
    assert_one_line_error(code, err, "design infeasible", "Metzler condition (20)")
    assert not out.exists()


def test_error_output_path_and_existing_file_untouched(capsys, files):
    code, _, err = run_cli(capsys, "estimate", files["log"], "--vehicle", files["veh"],
                           "--observer", "ekf", "--out", files["dir"] / "nodir" / "e.csv")
    assert_one_line_error(code, err, "does not exist")
    keep = files["dir"] / "keep.csv"
    keep.write_text("precious\n")
    code, _, err = run_cli(capsys, "estimate", files["log"], "--vehicle", files["veh"],
                           "--observer", "nope", "--out", keep)
    assert code == EXIT_INPUT
    assert keep.read_text() == "precious\n"
    code, _, err = run_cli(capsys, "estimate", files["log"], "--vehicle", files["veh"],
                           "--observer", "ekf", "--out", files["dir"])
    assert_one_line_error(code, err, "is a directory")


def test_zero_speed_row_is_estimated_by_the_low_speed_model_and_usage(capsys, files):
    text = files["log"].read_text().splitlines()
    header = text[0].split(",")
    row = text[3].split(",")
    row[header.index("vx_mps")] = "0"
    stop = files["dir"] / "stop.csv"
    stop.write_text("\n".join(text[:3] + [",".join(row)] + text[4:]) + "\n")
    out = files["dir"] / "stop_est.csv"
    code, _, err = run_cli(capsys, "estimate", stop, "--vehicle", files["veh"], "--observer",
                           "ekf", "--out", out)
    assert code == 0, err
    est = load_log(out, required=("t_s", "low_speed"), min_vx=None)
    # row 2 alone is slow; rows 0-1 form a stretch shorter than MIN_RUN: kinematic as well
    assert np.flatnonzero(est.extra["low_speed"]).tolist() == [0, 1, 2]
    assert np.isfinite(est.vy).all()
    code, _, err = run_cli(capsys, "estimate", files["log"], "--observer", "ekf")
    assert code == EXIT_INPUT and "Traceback" not in err and "--vehicle" in err


def test_tune_prints_a_kalman_table_that_the_loader_accepts(capsys, files):
    code, out, err = run_cli(capsys, "tune", files["log"], "--vehicle", "revs250lm",
                             "--tune-window", "10")
    assert code == 0, err
    assert "[kalman]" in out and "ML on measured channels" in out
    veh = files["dir"] / "tuned.toml"
    veh.write_text(files["base"] + "\n" + out)
    v = load_vehicle(veh)
    seg = load_log(files["log"]).segment(300.0, 310.0)
    ref = K.tune(seg, load_vehicle("revs250lm").params, max_rate_hz=RG.TUNE_RATE_HZ)
    # the printed table (6 significant digits) is the library's tuning of that window, thinned
    # to the command line's tuning rate
    assert np.allclose(v.kalman.theta(), ref.theta(), rtol=1e-5)
    code, _, err = run_cli(capsys, "tune", files["log"], "--vehicle", "nonexistent.toml")
    assert_one_line_error(code, err, "nonexistent.toml")


def test_closed_stdout_exits_quietly():
    """A reader that closes the pipe (``| head -1``) ends the command as SIGPIPE would: exit
    141 and nothing on stderr (no 'internal error')."""
    p = subprocess.Popen([sys.executable, "-m", "vehicle_observers", "observers"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()                                   # before the child writes anything
    err = p.stderr.read()
    assert p.wait(timeout=120) == 141 and err == b""


def test_reference_column_jump_is_warned_not_refused(stopgo, vehicle_file, tmp_path, capsys):
    """A step by x17.5 in the reference v_y (an INS re-initialised) is no reason to refuse a log no
    estimator reads it from: the estimate runs (exit 0) with one warning naming the reference
    column and a jump, not a unit such as the steering-wheel angle; the same factor in the
    yaw rate, which the EKF reads, still refuses the log (catches checks on the wrong
    columns and a cause named from the factor alone)."""
    from vehicle_observers.data.logs import _step_why

    def jump(col, f=17.5):
        def edit(cols):
            x = cols[col]
            k = int(np.argmax(np.abs(x) > 0.5 * np.abs(x).max()))
            x[k:] *= f
        return edit

    log = save(stopgo, tmp_path / "ref.csv", edit=jump("vy_mps"))
    rc = main(["estimate", str(log), "--vehicle", str(vehicle_file), "--observer", "ekf",
               "--out", str(tmp_path / "e.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert "reference column" in err and "'vy_mps'" in err and "jump" in err
    assert "steering-wheel" not in err
    bad = save(stopgo, tmp_path / "yaw.csv", edit=jump("yaw_rate_radps"))
    rc = main(["estimate", str(bad), "--vehicle", str(vehicle_file), "--observer", "ekf",
               "--out", str(tmp_path / "f.csv"), "--no-progress"])
    assert rc == 2 and "'yaw_rate_radps'" in capsys.readouterr().err
    kmh = save(stopgo, tmp_path / "kmh.csv", edit=jump("vy_mps", 3.6))
    assert main(["estimate", str(kmh), "--vehicle", str(vehicle_file), "--observer", "ekf",
                 "--out", str(tmp_path / "g.csv"), "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "reference column" in err and "km/h" in err, err
    assert "steering-wheel" in _step_why(15.0, "delta_roadwheel_rad")
    assert "steering-wheel" not in _step_why(15.0, "vy_mps")

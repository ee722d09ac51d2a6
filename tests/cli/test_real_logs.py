"""``python -m vehicle_observers estimate/tune`` on bad and unusual logs (each a small generated
file): every bad input exits 2 with one line naming the column/key; every legitimate one
(standstill, stops, gaps, jitter, 5 kHz, 10 Hz) gives a finite estimate close to the truth."""

import gzip
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import KALMAN, emulate, save, speed_profile, take
from vehicle_observers.cli.main import EXIT_INPUT, CLIError, _check_output, main
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import load_log
from vehicle_observers.estimation import kalman_runs as RG
from vehicle_observers.estimation import segments as SG
from vehicle_observers.models.vehicle import builtin_vehicles


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(code, err, *needles):
    assert code == EXIT_INPUT, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("error: ") and "Traceback" not in err
    for n in needles:
        assert n in lines[0], (n, lines[0])


def estimate(capsys, log_path, veh, observer="ekf", *extra, out=None):
    out = out or log_path.with_name(log_path.stem + f"_{observer}_est.csv")
    code, stdout, err = run_cli(capsys, "estimate", log_path, "--vehicle", veh, "--observer",
                                observer, "--out", out, "--no-progress", *extra)
    return code, stdout, err, out


def read_est(path):
    return load_log(path, required=("t_s", "vy_mps", "low_speed", "reinit"), min_vx=None)


@pytest.fixture(scope="module")
def cruise():
    """20 s at a constant 15 m/s with a 0.25 Hz steering sine (no stop)."""
    return emulate(T=20.0, profile=lambda t: np.full_like(t, 15.0))


@pytest.fixture(scope="module")
def car(tmp_path_factory):
    """yacine2015 with a [kalman] table and the interval speed box starting at 2 m/s (the
    shipped 0.2 m/s needs epsilon above 1/dt at 100 Hz)."""
    d = tmp_path_factory.mktemp("car")
    base = builtin_vehicles()["yacine2015"].read_text()
    p = d / "car.toml"
    p.write_text(base.replace("vx_min = 0.2", "vx_min = 2.0") + KALMAN)
    return {"path": p, "base": base, "dir": d}


# ------------------------------------------------------------------ unit mistakes ---------
def _deg(c):
    c["delta_roadwheel_rad"] = np.degrees(c["delta_roadwheel_rad"])


def _small_deg(c):
    c["delta_roadwheel_rad"] = np.degrees(0.25 * c["delta_roadwheel_rad"])


def _wheel(c):
    c["delta_roadwheel_rad"] = 15.0 * c["delta_roadwheel_rad"]


def _flip(c):
    c["delta_roadwheel_rad"] = -c["delta_roadwheel_rad"]


def _yaw_deg(c):
    c["yaw_rate_radps"] = np.degrees(c["yaw_rate_radps"])


def _kmh(c):
    c["vx_mps"] = 3.6 * c["vx_mps"]


def _ms(c):
    c["t_s"] = 1000.0 * c["t_s"]


def _absurd(col, row=7):
    def edit(c):
        c[col][row] = 1e300
    return edit


UNIT_CASES = [
    (_deg, ("'delta_roadwheel_rad'", "degrees")),
    (_small_deg, ("'delta_roadwheel_rad'", "degrees")),          # within +-0.8: cross-check
    (_wheel, ("'delta_roadwheel_rad'", "steering-wheel angle")),
    (_flip, ("'delta_roadwheel_rad'", "'yaw_rate_radps'", "opposite signs")),
    (_yaw_deg, ("'yaw_rate_radps'", "deg/s")),
    (_kmh, ("'vx_mps'", "km/h")),                                # 54 km/h: cross-check a_y
    (_ms, ("'t_s'", "milliseconds")),
    (_absurd("vx_mps"), ("'vx_mps'", "absurd", "row 7")),
    (_absurd("ay_mps2"), ("'ay_mps2'", "absurd")),
    (_absurd("vy_mps"), ("'vy_mps'", "absurd")),
    (_absurd("yL_m"), ("'yL_m'", "absurd")),
]


@pytest.mark.parametrize("edit, needles", UNIT_CASES, ids=[
    "steer-deg", "steer-small-deg", "steering-wheel", "sign", "yaw-degps", "kmh", "ms",
    "1e300-vx", "1e300-ay", "1e300-vy", "1e300-yL"])
def test_unit_mistakes_and_absurd_values_refused(capsys, tmp_path, cruise, car, edit, needles):
    p = save(cruise, tmp_path / "log.csv", edit=edit)
    code, _, err, out = estimate(capsys, p, car["path"])
    one_line_error(code, err, *needles)
    assert sorted(x.name for x in tmp_path.iterdir() if x.name != "cache") == ["log.csv"]
    if "absurd" not in needles:
        assert "--accept-out-of-range" in err
    else:   # absurd values are refused even when out-of-range values are accepted
        code, _, err, _ = estimate(capsys, p, car["path"], "ekf", "--accept-out-of-range")
        one_line_error(code, err, "absurd")


def test_highway_speed_in_kmh_refused_by_range(capsys, tmp_path, car):
    log = emulate(T=10.0, profile=lambda t: np.full_like(t, 30.0))
    p = save(log, tmp_path / "kmh.csv", edit=_kmh)
    code, _, err, _ = estimate(capsys, p, car["path"])
    one_line_error(code, err, "'vx_mps'", "km/h", "[-15, 90]")


def test_accept_out_of_range_runs_a_log_that_is_meant(capsys, tmp_path, car):
    """A race car at 100 m/s is out of the road range: refused, then accepted on request."""
    log = emulate(T=10.0, profile=lambda t: np.full_like(t, 15.0))
    p = save(log, tmp_path / "fast.csv", edit=lambda c: c["vx_mps"].__setitem__(slice(0, 50),
                                                                                  100.0))
    code, _, err, _ = estimate(capsys, p, car["path"])
    one_line_error(code, err, "'vx_mps'")
    code, _, err, out = estimate(capsys, p, car["path"], "ekf", "--accept-out-of-range")
    assert code == 0, err
    assert np.isfinite(read_est(out).vy).all()


# ------------------------------------------------------------------ vehicle files ---------
VEHICLE_CASES = [
    (lambda s: s.replace("I_z = 2454.0", "I_z = 1e-300"), ("'I_z'", "plausible range")),
    (lambda s: s.replace("m = 1500.0", "m = 1e300"), ("key 'm'", "plausible range")),
    (lambda s: s.replace("l_s = 0.5", "l_s = 0.5\nls = 3.0"), ("unknown key 'ls'",)),
    (lambda s: s.replace('model = "pacejka"', 'model = "pacejka"\nBx = 3.0', 1),
     ("unknown key 'tire_front.Bx'",)),
    (lambda s: s.replace("[uncertainty]", "[uncertainty]\nvxmax = 3.0"),
     ("unknown key 'uncertainty.vxmax'",)),
    (lambda s: s.replace("B = 4.980377161962178", "B = 1e9"), ("'tire_front.B'",)),
    (lambda s: s.replace("D = 6486.997120307183", "D = 1e-300"), ("'tire_front.D'",)),
]


@pytest.mark.parametrize("edit, needles", VEHICLE_CASES,
                         ids=["tiny-Iz", "huge-m", "typo-ls", "typo-tyre", "typo-box",
                              "huge-B", "tiny-D"])
def test_vehicle_file_errors_name_the_key(capsys, tmp_path, cruise, car, edit, needles):
    p = save(cruise, tmp_path / "log.csv")
    veh = tmp_path / "bad.toml"
    veh.write_text(edit(car["base"]))
    for obs in ("ekf", "ts-yacine2015"):
        code, _, err, out = estimate(capsys, p, veh, obs)
        one_line_error(code, err, "bad.toml", *needles)
        assert not out.exists()


def test_linear_tyres_with_ts_observer_is_a_clear_error(capsys, tmp_path, cruise):
    p = save(cruise, tmp_path / "log.csv")
    veh = tmp_path / "lin.toml"
    veh.write_text("m = 1500\nI_z = 2454\na_f = 1.1\na_r = 1.44\n"
                   "[tire_front]\nmodel = \"linear\"\ncornering_stiffness = 42000\n"
                   "[tire_rear]\nmodel = \"linear\"\ncornering_stiffness = 49000\n"
                   "[uncertainty]\nvx_min = 2.0\nvx_max = 17.0\nslip_max_deg = 8.0\n"
                   "stiffness_rel = 0.1\n" + KALMAN)
    code, _, err, _ = estimate(capsys, p, veh, "ts-yacine2015")
    one_line_error(code, err, "'tire_front.model'", "Pacejka")
    code, _, err, out = estimate(capsys, p, veh, "ekf")     # the EKF takes linear tyres
    assert code == 0, err       # (the zero-slip stiffness of the car's Pacejka tyres)
    assert rmse(read_est(out).vy, cruise.vy) < 0.3 * rmse(0 * cruise.vy, cruise.vy)


def test_lmi_design_with_nan_data_raises_the_package_error():
    from vehicle_observers.design.lmi import LMIDataError, LMIDesign

    A = np.array([[-1.0, np.nan], [0.0, -2.0]])
    d = LMIDesign("lyap")
    d.symmetric("P", 2)
    d.positive("P>0", lambda V: V.P)
    d.negative("AtP+PA<0", lambda V: A.T @ V.P + V.P @ A)
    with pytest.raises(LMIDataError, match="'AtP\\+PA<0' has NaN"):
        d.solve()


def test_diagnose_infeasible_returns_instead_of_leaking_solver_errors():
    from vehicle_observers.models.lateral import yacine_ts
    from vehicle_observers.models.vehicle import load_vehicle
    from vehicle_observers.observers import ts_premise as TO

    par = load_vehicle("yacine2015").params
    a = np.radians(8.0)
    ts = yacine_ts(par, Mf=par.tire_f.sector_bounds(a), Mr=par.tire_r.sector_bounds(a),
                   vx_bounds=(0.2, 17.0))
    ts.A[0] *= 1e14                                  # absurdly scaled: the solver may fail
    out = TO.diagnose_infeasible(ts, 1e-3)
    assert set(out) == {"t", "worst", "largest_eig"}
    ts.A[0][0, 0] = np.inf
    out = TO.diagnose_infeasible(ts, 1e-3)
    assert out["worst"] is None and np.isnan(out["t"])


# ------------------------------------------------------------------ files and options -----
def test_truncated_gzip_long_field_and_bom(capsys, tmp_path, cruise, car):
    p = save(cruise, tmp_path / "log.csv")
    gz = tmp_path / "cut.csv.gz"
    gz.write_bytes(gzip.compress(p.read_bytes())[:4000])
    code, _, err, _ = estimate(capsys, gz, car["path"])
    one_line_error(code, err, "cut.csv.gz", "truncated")
    lines = p.read_text().splitlines()
    row = lines[5].split(",")
    row[2] = "0." + "1" * 140_000
    long = tmp_path / "long.csv"
    long.write_text("\n".join(lines[:5] + [",".join(row)] + lines[6:]) + "\n")
    code, _, err, _ = estimate(capsys, long, car["path"])
    one_line_error(code, err, "line 6", "131072")
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    code, _, err, out = estimate(capsys, bom, car["path"])
    assert code == 0, err
    assert rmse(read_est(out).vy, cruise.vy) < 0.05


@pytest.mark.parametrize("argv, needles", [
    (("--tune-window", "1e-9"), ("--tune-window 1e-09 s holds 1 row(s)",)),
    (("--tune-window", "nan"), ("--tune-window must be",)),
    (("--tune-window", "-3"), ("--tune-window must be",)),
    (("--max-gap", "0"), ("--max-gap must be",)),
])
def test_bad_options(capsys, tmp_path, cruise, argv, needles):
    p = save(cruise, tmp_path / "log.csv")
    code, _, err, _ = estimate(capsys, p, "yacine2015", "ekf", *argv)
    one_line_error(code, err, *needles)
    code, _, err = run_cli(capsys, "tune", p, "--vehicle", "yacine2015", *argv)
    one_line_error(code, err, *needles)


def test_tune_needs_a_stretch_in_motion(capsys, tmp_path, cruise, stopgo):
    one = save(cruise, tmp_path / "one.csv", edit=lambda c: [c.__setitem__(k, v[:1])
                                                             for k, v in list(c.items())])
    code, _, err = run_cli(capsys, "tune", one, "--vehicle", "yacine2015")
    one_line_error(code, err, "no stretch of 50 rows in motion", "[kalman]")
    still = save(stopgo, tmp_path / "still.csv", edit=lambda c: c["vx_mps"].__imul__(0.0))
    code, _, err = run_cli(capsys, "tune", still, "--vehicle", "yacine2015")
    one_line_error(code, err, "no stretch of 50 rows in motion")


def test_tune_on_a_log_starting_at_rest_uses_the_first_stretch_in_motion(capsys, tmp_path,
                                                                         stopgo):
    p = save(stopgo, tmp_path / "stopgo.csv")
    code, out, err = run_cli(capsys, "tune", p, "--vehicle", "yacine2015", "--tune-window", "8")
    assert code == 0, err
    from vehicle_observers.baselines import kalman as K
    from vehicle_observers.models.vehicle import load_vehicle

    veh = load_vehicle("yacine2015")
    win = RG.tuning_window(load_log(p, min_vx=None), veh, 8.0)
    assert win.vx.min() >= SG.V_LOW and win.t[0] > 3.0       # after the standstill
    ref = K.tune(win, veh.params, max_rate_hz=RG.TUNE_RATE_HZ)
    printed = dict(line.split(" = ") for line in out.splitlines() if " = " in line)
    assert np.allclose([float(printed[k]) for k in ("q_vy", "q_r", "q_b", "R_r", "R_ay")],
                       ref.theta(), rtol=1e-5)
    # second call: same numbers from the cache
    code, out2, _ = run_cli(capsys, "tune", p, "--vehicle", "yacine2015", "--tune-window", "8")
    assert code == 0 and "(cached)" in out2
    assert out2.splitlines()[1:] == out.splitlines()[1:]


# ------------------------------------------------------------------ output hygiene --------
def test_out_equal_to_log_refused_and_log_untouched(capsys, tmp_path, cruise, car):
    p = save(cruise, tmp_path / "log.csv")
    before = p.read_bytes()
    code, _, err, _ = estimate(capsys, p, car["path"], out=p)
    one_line_error(code, err, "is the input log")
    code, _, err, _ = estimate(capsys, p, car["path"], out=tmp_path / "." / "log.csv")
    one_line_error(code, err, "is the input log")
    assert p.read_bytes() == before


def test_unwritable_target_fails_before_reading_the_log(capsys, tmp_path, car):
    # the log does not even exist: the output check comes first, so no computing is wasted
    code, _, err, _ = estimate(capsys, tmp_path / "absent.csv", car["path"],
                               out="/proc/self/est.csv")
    one_line_error(code, err, "--out /proc/self/est.csv", "cannot write there")
    if os.geteuid() != 0:   # permission bits do not stop root
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o555)
        code, _, err, _ = estimate(capsys, tmp_path / "absent.csv", car["path"],
                                   out=ro / "e.csv")
        one_line_error(code, err, "cannot write there")


def test_output_has_normal_permissions_and_flags(capsys, tmp_path, cruise, car):
    p = save(cruise, tmp_path / "log.csv")
    code, _, err, out = estimate(capsys, p, car["path"])
    assert code == 0, err
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask
    e = read_est(out)
    assert set(np.unique(e.extra["low_speed"])) == {0.0} and e.extra["reinit"].sum() == 0


def test_nan_or_diverged_output_is_an_error_not_a_result():
    """A built-in estimator's NaN output is a CLIError (exit 2: its input made it diverge);
    a plug-in's NaN output is tested in test_open_platform (exit 3)."""
    from vehicle_observers.estimation import registry

    ekf = registry.get("ekf")
    t = np.arange(3.0)
    with pytest.raises(CLIError, match="produced 1 NaN/inf value\\(s\\) in 'vy_mps', first at row 1"):
        _check_output(ekf, {"t_s": t, "vy_mps": np.array([0.0, np.nan, 0.0])}, False)
    with pytest.raises(CLIError, match="diverged: 'vy_mps' = 49"):
        _check_output(ekf, {"t_s": t, "vy_mps": np.array([0.0, 49.0, 0.0])}, False)
    _check_output(ekf, {"t_s": t, "vy_mps": np.array([0.0, 49.0, 0.0])}, True)


def _spawn(log, veh, out, observer="ekf-filterpy"):
    return subprocess.Popen([sys.executable, "-m", "vehicle_observers", "estimate", str(log),
                             "--vehicle", str(veh), "--observer", observer, "--out", str(out),
                             "--no-progress"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def _partials(out, pid):
    return list(out.parent.glob(f".{out.name}.{pid}-*.partial"))


def _wait_for_partial(out, proc, timeout=120.0):
    t0 = time.time()
    while not _partials(out, proc.pid):
        assert proc.poll() is None, proc.communicate()
        assert time.time() - t0 < timeout
        time.sleep(0.05)
    return _partials(out, proc.pid)[0]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP])
def test_termination_signals_leave_no_file_behind(tmp_path, car, sig):
    """SIGTERM, SIGINT and SIGHUP: the partial file and its record are removed, one line,
    exit 128 + signum."""
    log = emulate(T=60.0, profile=lambda t: np.full_like(t, 15.0))
    d = tmp_path / "run"
    d.mkdir()
    p = save(log, d / "log.csv")
    out = d / "est.csv"
    proc = _spawn(p, car["path"], out)           # the pure-Python EKF: ~1 ms/row
    _wait_for_partial(out, proc)
    time.sleep(0.5)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + sig, err
    what = "interrupted" if sig == signal.SIGINT else "terminated"
    name = signal.Signals(sig).name
    assert err.strip().splitlines() == [f"error: {what} by {name} (no output written)"]
    assert sorted(x.name for x in d.iterdir()) == ["log.csv"]
    assert not list((tmp_path / "cache" / "partials").glob("*.json"))


def test_sigkill_partial_removed_by_the_next_run(capsys, tmp_path, car):
    """SIGKILL: the partial file is left, and the next run removes it (it recorded it)."""
    log = emulate(T=60.0, profile=lambda t: np.full_like(t, 15.0))
    d = tmp_path / "run"
    d.mkdir()
    p = save(log, d / "log.csv")
    out = d / "est.csv"
    proc = _spawn(p, car["path"], out)
    part = _wait_for_partial(out, proc)
    proc.kill()
    proc.wait(timeout=60)
    assert part.exists() and not out.exists()
    code, _, err, _ = estimate(capsys, p, car["path"], "ekf", out=out)
    assert code == 0, err
    assert sorted(x.name for x in d.iterdir()) == ["est.csv", "est.csv.provenance.json",
                                                   "est.csv.verdict.json", "log.csv"]


def test_subprocess_error_is_one_line_without_warnings(tmp_path, car):
    log = emulate(T=5.0, profile=lambda t: np.full_like(t, 15.0))
    p = save(log, tmp_path / "log.csv", edit=_yaw_deg)
    r = subprocess.run([sys.executable, "-W", "always", "-m", "vehicle_observers", "estimate",
                        str(p), "--vehicle", str(car["path"]), "--observer", "ekf", "--out",
                        str(tmp_path / "e.csv")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "'yaw_rate_radps'" in r.stderr


# ------------------------------------------------------------------ legitimate logs -------
def _check_estimate(est, log, tol, exclude_s=2.0):
    """Finite everywhere; kinematic rows equal the kinematic model; model rows at least
    ``exclude_s`` s after a (re)start have v_y RMSE <= ``tol`` x that of v_y = 0."""
    assert all(np.isfinite(v).all() for v in est.columns().values())
    low = est.extra["low_speed"].astype(bool)
    start = np.flatnonzero(np.diff(np.r_[1, low.astype(int)]) == -1)
    settled = ~low
    for k in start:
        settled &= ~((est.t >= est.t[k]) & (est.t < est.t[k] + exclude_s))
    assert settled.sum() > 100
    e = rmse(est.vy, log.vy, settled)
    e0 = rmse(np.zeros_like(log.vy), log.vy, settled)
    assert e <= tol * e0, (e, e0)
    return e, e0, low


@pytest.mark.parametrize("observer, tol", [("ekf", 0.15), ("rts", 0.15),
                                           ("interval-ifqir2017", 0.6),
                                           ("ts-yacine2015", 0.3)])
def test_standstill_both_ends_and_a_stop_in_the_middle(capsys, tmp_path, stopgo, car,
                                                       observer, tol):
    p = save(stopgo, tmp_path / "stopgo.csv")
    code, out, err, est_path = estimate(capsys, p, car["path"], observer)
    assert code == 0, err
    est = read_est(est_path)
    _, _, low = _check_estimate(est, stopgo, tol)
    assert np.array_equal(low, stopgo.vx < SG.V_LOW)       # exactly the slow rows
    assert "low-speed model on %d row(s)" % low.sum() in out
    # at rest the estimate is the kinematic one: v_y = 0, the sideslip of the steering
    # geometry (the measured steering is noise around 0 there: about 0, not 90 deg)
    rest = stopgo.vx == 0
    assert np.abs(est.vy[rest]).max() == 0.0 and np.abs(est.extra["beta_rad"][rest]).max() < 0.01
    if observer == "interval-ifqir2017":
        lo, hi = est.extra["vy_lo_mps"], est.extra["vy_hi_mps"]
        inside = (lo <= stopgo.vy) & (stopgo.vy <= hi)
        assert np.all(lo <= hi) and inside[low].all()     # the kinematic box at low speed
        assert np.mean(inside[~low]) > 0.95


def test_tiny_speed_at_the_start_gives_no_90_degree_sideslip(capsys, tmp_path, stopgo, car):
    def creep(c):
        c["vx_mps"][:300] = 1e-9
        c["delta_roadwheel_rad"][:300] = 0.02
        c["yaw_rate_radps"][:300] = 0.01
    p = save(stopgo, tmp_path / "creep.csv", edit=creep)
    code, _, err, out = estimate(capsys, p, car["path"])
    assert code == 0, err
    est = read_est(out)
    beta = est.extra["beta_rad"][:300]
    # kinematic sideslip of the steering geometry: atan(a_r tan(delta) / L), about 0.011 rad
    assert np.allclose(beta, np.arctan(1.44 * np.tan(0.02) / 2.54))
    assert np.abs(est.vy[:300]).max() < 1e-9


@pytest.mark.parametrize("gap_s", [5.0, 100.0])
def test_time_gaps_reinitialise_and_are_marked(capsys, tmp_path, stopgo, car, gap_s):
    """5 s of rows removed at t = 15 s (cruising), and later times shifted by ``gap_s``."""
    keep = (stopgo.t < 15.0) | (stopgo.t >= 20.0)

    def gap(c):
        for k in c:
            c[k] = c[k][keep]
        c["t_s"] = np.where(c["t_s"] >= 20.0, c["t_s"] - 5.0 + gap_s, c["t_s"])
    p = save(stopgo, tmp_path / "gap.csv", edit=gap)
    sub = take(stopgo, keep)
    for observer, tol in (("ekf", 0.15), ("interval-ifqir2017", 0.6)):
        code, out, err, est_path = estimate(capsys, p, car["path"], observer)
        assert code == 0, err
        est = read_est(est_path)
        k = int(np.argmax(est.t >= 20.0 - 5.0 + gap_s))
        assert np.flatnonzero(est.extra["reinit"]).tolist() == [k]
        assert "1 re-initialisation(s)" in out
        e, _, _ = _check_estimate(est, sub, tol)
        assert np.abs(est.vy).max() < 1.0
    # the interval observer restarts at the gap: its box there is the initial one again
    assert est.extra["vy_hi_mps"][k] - est.extra["vy_lo_mps"][k] == pytest.approx(4.0)


def test_jitter_uses_real_timestamps(capsys, tmp_path, car):
    """Samples at 100 Hz +- 3 ms jitter (drawn from a 1 kHz truth)."""
    fine = emulate(T=30.0, fs=1000.0, profile=lambda t: np.full_like(t, 15.0))
    rng = np.random.default_rng(3)
    idx = np.arange(5, len(fine) - 5, 10) + rng.integers(-3, 4, size=(len(fine) - 10) // 10)
    p = save(fine, tmp_path / "jitter.csv", edit=lambda c: [c.__setitem__(k, v[idx])
                                                            for k, v in list(c.items())])
    truth = take(fine, idx)
    for observer, tol in (("ekf", 0.15), ("interval-ifqir2017", 0.6)):
        code, _, err, est_path = estimate(capsys, p, car["path"], observer)
        assert code == 0, err
        _check_estimate(read_est(est_path), truth, tol)
    code, _, err, _ = estimate(capsys, p, car["path"], "ts-yacine2015")
    one_line_error(code, err, "'t_s' is irregular", "ts-yacine2015")


def test_interval_runs_on_equal_steps_chain_exactly():
    """Splitting the run at each change of the step gives the same boxes as one run where
    the step is constant (the state is carried over exactly)."""
    from vehicle_observers.estimation.adapters import dt_runs, interval_design, interval_real_dt
    from vehicle_observers.models.vehicle import load_vehicle

    veh = load_vehicle("revs250lm")
    des, _ = interval_design(veh, 0.01)
    t = np.arange(0.0, 3.0, 0.01)
    vx = np.full_like(t, 20.0)
    u = 0.01 * np.sin(t)
    y = 0.05 * np.sin(t)
    one = interval_real_dt(des, t, vx, u - 1e-3, u + 1e-3, y, [-2, -1], [2, 1], 0.01)
    t2 = t.copy()
    t2[150:] += 0.005          # one longer step, from row 149 to 150: three runs
    assert [(a, b) for a, b, _ in dt_runs(t2)] == [(0, 149), (149, 150), (150, 299)]
    two = interval_real_dt(des, t2, vx, u - 1e-3, u + 1e-3, y, [-2, -1], [2, 1], 0.01)
    for k in (0, 1):   # same boxes up to row 149 (the mean step differs by round-off only)
        np.testing.assert_allclose(one[k][:150], two[k][:150], rtol=1e-9, atol=1e-12)
        assert np.abs(one[k][150:] - two[k][150:]).max() > 1e-6   # round-off: 1e-12


@pytest.mark.parametrize("fs, every, tol", [(5000.0, 1, 0.15), (1000.0, 100, 0.3)],
                         ids=["5kHz", "10Hz"])
def test_sampling_rates(capsys, tmp_path, car, fs, every, tol):
    T = 12.0 if fs > 1000 else 60.0
    stops = ((0.0, 1.0), (T - 1.0, T))
    fine = emulate(T=T, fs=fs, profile=lambda t: speed_profile(t, stops=stops, ramp=3.0))
    idx = np.arange(0, len(fine), every)
    p = save(fine, tmp_path / "rate.csv", edit=lambda c: [c.__setitem__(k, v[idx])
                                                          for k, v in list(c.items())])
    truth = take(fine, idx)
    code, _, err, est_path = estimate(capsys, p, car["path"], "ekf")
    assert code == 0, err
    est = read_est(est_path)
    _check_estimate(est, truth, tol)
    # at 10 Hz one RK4 step per sample is unstable below ~5 m/s for this car: kinematic there
    from vehicle_observers.models.vehicle import load_vehicle

    stable = SG.moving_rows(truth, load_vehicle(car["path"]))
    assert np.array_equal(est.extra["low_speed"].astype(bool), ~stable)
    if every > 1:
        assert (~stable & (truth.vx >= SG.V_LOW)).any()

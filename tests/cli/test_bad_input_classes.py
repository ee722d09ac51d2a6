"""Classes of bad input of ``python -m vehicle_observers``, each with cases beyond the ones
first reported: every bad input exits 2 with exactly one line on stderr naming the problem,
creates no file and loses none (directory listings and input bytes compared before and
after); every legitimate variant gives a correct result.

Classes: outputs that would overwrite an input or be mislabelled; signals and special files;
``identify`` sharing ``estimate``'s checks; vehicle files that cannot be the log's car;
changes of unit inside a log; options that defeat the estimator; one-line usage errors.
"""

from __future__ import annotations

import errno
import gzip
import os
import stat
import subprocess
import sys

import numpy as np
import pytest
from conftest import KALMAN, emulate, save
from vehicle_observers.cli.main import EXIT_INPUT, main
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data import logs as L
from vehicle_observers.data.logs import DriveLog, load_log, load_revs, write_csv
from vehicle_observers.models.vehicle import builtin_vehicles, load_vehicle

BASE = builtin_vehicles()["yacine2015"].read_text()


# ------------------------------------------------------------------ helpers ---------------
def snapshot(*dirs):
    """Names of every entry of ``dirs`` (recursively, the test's cache folder excepted) with
    the bytes of the regular files."""
    out = {}
    for d in dirs:
        for root, subdirs, files in os.walk(d):
            subdirs[:] = [s for s in subdirs if s != "cache"]
            for f in files + subdirs:
                p = os.path.join(root, f)
                st = os.lstat(p)
                out[p] = (open(p, "rb").read() if stat.S_ISREG(st.st_mode) else
                          stat.S_IFMT(st.st_mode))
    return out


def refused(capsys, argv, *needles, dirs=()):
    """Run the command line: exit 2, one stderr line with every needle, nothing changed in
    ``dirs``. Returns the line."""
    before = snapshot(*dirs)
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == EXIT_INPUT, err
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for n in needles:
        assert n in lines[0], (n, lines[0])
    assert snapshot(*dirs) == before
    return lines[0]


def ran(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert code == 0, err
    return out, err


def est_argv(log, veh, out, observer="ekf", *extra):
    return ["estimate", log, "--vehicle", veh, "--observer", observer, "--out", out,
            "--no-progress", *extra]


@pytest.fixture(scope="module")
def cruise():
    """20 s at 15 m/s, 100 Hz, 0.25 Hz steering sine (the yacine2015 car)."""
    return emulate(T=20.0, profile=lambda t: np.full_like(t, 15.0))


@pytest.fixture()
def run(tmp_path, cruise):
    """A folder with a log and a vehicle file (yacine2015 with a [kalman] table and the
    interval speed box from 2 m/s)."""
    d = tmp_path / "run"
    d.mkdir()
    save(cruise, d / "log.csv")
    (d / "car.toml").write_text(BASE.replace("vx_min = 0.2", "vx_min = 2.0") + KALMAN)
    return d


def car_file(path, text_edit=None, base=BASE):
    text = base.replace("vx_min = 0.2", "vx_min = 2.0") + KALMAN
    path.write_text(text if text_edit is None else text_edit(text))
    return path


def geometry(veh="yacine2015"):
    p = load_vehicle(veh).params
    return ["--mass", p.m, "--inertia", p.I_z, "--a-f", p.a_f, "--a-r", p.a_r]


# ================================================================== 1. files lost or mislabelled
def test_out_onto_the_vehicle_file_refused(capsys, run):
    line = refused(capsys, est_argv(run / "log.csv", run / "car.toml", run / "car.toml"),
                   "is the vehicle file", dirs=[run])
    assert "--out" in line


@pytest.mark.parametrize("spelling", ["symlink", "hardlink", "relative", "proc-fd"])
def test_out_onto_the_log_refused_whatever_the_spelling(capsys, run, monkeypatch, spelling):
    log = run / "log.csv"
    if spelling == "symlink":
        out = run / "est.csv"
        out.symlink_to(log)
    elif spelling == "hardlink":
        out = run / "copy.csv"
        os.link(log, out)
    elif spelling == "relative":
        (run / "sub").mkdir()
        monkeypatch.chdir(run / "sub")
        out = "../sub/../log.csv"
    else:
        fd = os.open(log, os.O_RDONLY)
        out = f"/proc/self/fd/{fd}"
    refused(capsys, est_argv(log, run / "car.toml", out), "is the input log", dirs=[run])


def test_out_onto_a_hard_link_of_the_vehicle_file_or_a_plugin_refused(capsys, run):
    os.link(run / "car.toml", run / "est.csv")
    refused(capsys, est_argv(run / "log.csv", run / "car.toml", run / "est.csv"),
            "is the vehicle file", dirs=[run])
    plug = run / "my_plugin.py"
    plug.write_text("X = 1\n")
    os.link(plug, run / "plug.csv")
    refused(capsys, ["--plugin", plug, *est_argv(run / "log.csv", run / "car.toml",
                                                 run / "plug.csv")],
            "is the plug-in", dirs=[run])


def test_out_onto_a_builtin_vehicle_file_refused(capsys, run):
    shipped = builtin_vehicles()["revs250lm"]
    before = shipped.read_bytes()
    refused(capsys, est_argv(run / "log.csv", "revs250lm", shipped), "is the vehicle file",
            dirs=[run])
    assert shipped.read_bytes() == before


def test_identify_out_onto_its_log_refused(capsys, run, tmp_path):
    refused(capsys, ["identify", run / "log.csv", "--out", run / "log.csv", *geometry()],
            "is the input log", dirs=[run])
    (run / "car2.toml").symlink_to(run / "log.csv")
    refused(capsys, ["identify", run / "log.csv", "--out", run / "car2.toml", *geometry()],
            "is the input log", dirs=[run])


def test_users_files_named_like_partial_files_survive(capsys, run):
    users = [run / "est.csv.partial-999999999", run / f".est.csv.999999999-{'ab' * 8}.partial",
             run / "est.csv.partial-1"]
    for u in users:
        u.write_text("my notes")
    ran(capsys, est_argv(run / "log.csv", run / "car.toml", run / "est.csv"))
    # a failing run (bad option) leaves them too
    refused(capsys, est_argv(run / "log.csv", run / "car.toml", run / "est.csv", "ekf",
                             "--max-gap", "0.001"), "--max-gap", dirs=[run])
    assert all(u.read_text() == "my notes" for u in users)
    assert sorted(p.name for p in run.iterdir()) == sorted(
        ["log.csv", "car.toml", "est.csv", "est.csv.provenance.json", "est.csv.verdict.json"]
        + [u.name for u in users])


@pytest.mark.parametrize("name", ["est.csv.gz", "EST.CSV.GZ"])
def test_gz_output_is_gzip_compressed_and_equal_to_the_csv(capsys, run, name):
    ran(capsys, est_argv(run / "log.csv", run / "car.toml", run / "est.csv"))
    ran(capsys, est_argv(run / "log.csv", run / "car.toml", run / name))
    raw = (run / name).read_bytes()
    assert raw[:2] == b"\x1f\x8b"
    assert gzip.decompress(raw) == (run / "est.csv").read_bytes()
    a = load_log(run / name, required=("t_s", "vy_mps"), min_vx=None)
    assert np.array_equal(a.vy, load_log(run / "est.csv", required=("t_s", "vy_mps"),
                                         min_vx=None).vy)


@pytest.mark.parametrize("name, needle", [
    ("est.csv.xz", ".xz compression is not written"), ("est.csv.bz2", ".bz2 compression"),
    ("est.txt", "'.txt'"), ("est.parquet", "'.parquet'"), ("est", "has no suffix"),
    ("est.gz", "'.gz'")])
def test_output_suffix_that_is_not_written_refused(capsys, run, name, needle):
    refused(capsys, est_argv(run / "log.csv", run / "car.toml", run / name), needle,
            ".csv or .csv.gz", dirs=[run])


def test_identify_output_must_be_toml(capsys, run):
    refused(capsys, ["identify", run / "log.csv", "--out", run / "car.csv", *geometry()],
            "'.csv'", ".toml", dirs=[run])


def test_out_onto_a_device_or_fifo_refused(capsys, run):
    refused(capsys, est_argv(run / "log.csv", run / "car.toml", "/dev/null"),
            "is a character device", dirs=[run])
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)      # not replaced by a file (as root)
    os.mkfifo(run / "fifo.csv")
    refused(capsys, est_argv(run / "log.csv", run / "car.toml", run / "fifo.csv"),
            "is a FIFO", dirs=[run])


# ================================================================== 2. signals and special files
def test_fifo_log_without_writer_refused_at_once(run):
    """A FIFO with no writer would block ``open`` forever: refused before opening (the
    SIGTERM / SIGINT / SIGHUP cases are in test_real_logs.py)."""
    os.mkfifo(run / "pipe.csv")
    before = snapshot(run)
    r = subprocess.run([sys.executable, "-m", "vehicle_observers", *map(str, est_argv(
        run / "pipe.csv", run / "car.toml", run / "est.csv"))], capture_output=True,
        text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "is a FIFO" in lines[0]
    assert snapshot(run) == before


@pytest.mark.parametrize("log, needle", [("/dev/zero", "is a character device"),
                                         ("DIR", "is a directory")])
def test_device_or_directory_as_log_refused(capsys, run, log, needle):
    log = run if log == "DIR" else log
    refused(capsys, est_argv(log, run / "car.toml", run / "est.csv"), needle, dirs=[run])
    refused(capsys, ["tune", log, "--vehicle", run / "car.toml"], needle, dirs=[run])


def test_fifo_vehicle_file_and_plugin_refused(capsys, run):
    os.mkfifo(run / "veh.toml")
    refused(capsys, est_argv(run / "log.csv", run / "veh.toml", run / "est.csv"),
            "is a FIFO", dirs=[run])
    os.mkfifo(run / "plug.py")
    refused(capsys, ["--plugin", run / "plug.py", "observers"], "is a FIFO", dirs=[run])


# ================================================================== 3. identify
def test_identify_out_in_missing_folder_or_a_directory(capsys, run):
    refused(capsys, ["identify", run / "log.csv", "--out", run / "nope" / "car.toml",
                     *geometry()], "folder", "does not exist", dirs=[run])
    (run / "d.toml").mkdir()
    refused(capsys, ["identify", run / "log.csv", "--out", run / "d.toml", *geometry()],
            "is a directory", dirs=[run])


def _enospc(path, *a, **k):
    with open(path, "wb") as fh:
        fh.write(b"partly written")
    raise OSError(errno.ENOSPC, "No space left on device")


def test_full_disk_simulated_leaves_nothing(capsys, run, monkeypatch):
    """ENOSPC while writing (the write function replaced in-process): one line, the partial
    file removed, nothing else changed."""
    from vehicle_observers.data import plant

    plant_log = run / "slalom.csv"
    plant.plant_log("slalom", seed=2, quick=True).to_csv(plant_log)
    P = plant.nominal_params()
    monkeypatch.setattr(L, "_write_table", _enospc)
    monkeypatch.setattr(L, "_write_bytes", _enospc)
    refused(capsys, est_argv(run / "log.csv", run / "car.toml", run / "est.csv"),
            "--out", "the disk is full", "nothing written", dirs=[run])
    refused(capsys, ["identify", plant_log, "--out", run / "bmw.toml", "--mass", P.m,
                     "--inertia", P.I_z, "--a-f", P.a_f, "--a-r", P.a_r],
            "the disk is full", dirs=[run])


@pytest.fixture()
def tiny_fs(tmp_path):
    """A 64 kB tmpfs (root only), filled but for 8 kB; skipped where it cannot be mounted."""
    d = tmp_path / "tiny"
    d.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs",
                                            str(d)], capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        with open(d / "filler", "wb") as fh:
            try:
                fh.write(b"\0" * (64 - 8) * 1024)
            except OSError:
                pass
        yield d
    finally:
        subprocess.run(["umount", str(d)], capture_output=True)


def test_full_disk_real_tmpfs_leaves_nothing(capsys, run, tiny_fs):
    from vehicle_observers.data import plant

    refused(capsys, est_argv(run / "log.csv", run / "car.toml", tiny_fs / "est.csv"),
            "the disk is full", dirs=[run, tiny_fs])
    with open(tiny_fs / "filler", "ab") as fh:      # no room left at all
        try:
            fh.write(b"\0" * 8192)
        except OSError:
            pass
    plant_log = run / "slalom.csv"
    plant.plant_log("slalom", seed=2, quick=True).to_csv(plant_log)
    P = plant.nominal_params()
    line = refused(capsys, ["identify", plant_log, "--out", tiny_fs / "bmw.toml", "--mass",
                            P.m, "--inertia", P.I_z, "--a-f", P.a_f, "--a-r", P.a_r],
                   "bmw.toml", dirs=[run, tiny_fs])
    assert "disk is full" in line or "cannot write there" in line


@pytest.mark.parametrize("edit, needles", [
    (lambda c: c.__setitem__("delta_roadwheel_rad", 15.0 * c["delta_roadwheel_rad"]),
     ("'delta_roadwheel_rad'", "steering-wheel angle")),
    (lambda c: c.__setitem__("vx_mps", 3.6 * c["vx_mps"]), ("'vx_mps'", "km/h")),
    (lambda c: c["t_s"].__setitem__(slice(1200, None), 1000.0 * c["t_s"][1200:]),
     ("'t_s'", "row 1200", "milliseconds")),
], ids=["steering-wheel", "kmh", "ms-from-row"])
def test_identify_shares_the_unit_checks_of_estimate(capsys, tmp_path, cruise, edit, needles):
    d = tmp_path / "run"
    d.mkdir()
    p = save(cruise, d / "log.csv", edit=edit)
    a = refused(capsys, ["identify", p, "--out", d / "car.toml", *geometry()], *needles,
                dirs=[d])
    b = refused(capsys, est_argv(p, "yacine2015", d / "est.csv"), *needles, dirs=[d])
    assert a == b                   # the same check, the same line


@pytest.mark.parametrize("argv, needle", [
    (["--mass", "1e9"], "--mass 1e+09 is outside the plausible range"),
    (["--a-f", "0"], "--a-f 0 is outside"),
    (["--window", "0.1"], "--window 0.1 s holds 11 row(s)"),
    (["--window", "nan"], "--window must be"),
])
def test_identify_options_checked(capsys, run, argv, needle):
    g = geometry()
    for i in range(0, len(argv), 2):
        if argv[i] in g:
            g[g.index(argv[i]) + 1] = argv[i + 1]
        else:
            g += argv[i:i + 2]
    refused(capsys, ["identify", run / "log.csv", "--out", run / "new.toml", *g], needle,
            dirs=[run])


# ================================================================== 4. vehicle files
def _scale(text, key_values):
    for k, f in key_values:
        for line in [ln for ln in text.splitlines() if ln.split("=")[0].strip() == k]:
            v = float(line.split("=")[1].split("#")[0])
            text = text.replace(line, f"{k} = {v * f!r}")
    return text


SCRAMBLES = {
    "stiffness-x10-B": lambda t: _scale(t, [("B", 10.0)]),
    "stiffness-x10-D": lambda t: _scale(t, [("D", 10.0)]),
    "front-stiffness-x10": lambda t: t.replace("B = 4.980377161962178", "B = 49.80377161962178"),
    "axles-swapped": lambda t: t.replace("a_f = 1.1 ", "a_f = 1.44").replace(
        "a_r = 1.44", "a_r = 1.1 ", 1),
    "revs-car": lambda t: builtin_vehicles()["revs250lm"].read_text().replace(
        "vx_min = 15.0", "vx_min = 2.0") + KALMAN,
}


@pytest.fixture(scope="module")
def satory_log(tmp_path_factory):
    """40 s of the emulated Satory lap (1 kHz, the yacine2015 car)."""
    from vehicle_observers.data.scenarios import emulated_satory

    p = tmp_path_factory.mktemp("satory") / "satory.csv"
    emulated_satory(seed=0, quick=True).to_csv(p)
    return p


@pytest.mark.parametrize("scramble", list(SCRAMBLES))
def test_vehicle_file_that_cannot_be_this_car_refused(capsys, tmp_path, satory_log, scramble):
    d = tmp_path / "run"
    d.mkdir()
    veh = car_file(d / "car.toml", SCRAMBLES[scramble])
    line = refused(capsys, est_argv(satory_log, veh, d / "est.csv"), "car.toml cannot be this "
                   "car", "--accept-mismatch", dirs=[d, satory_log.parent])
    refused(capsys, ["tune", satory_log, "--vehicle", veh], "cannot be this car",
            dirs=[d, satory_log.parent])
    if "x10" in scramble:
        assert "too stiff" in line or "D / F_z" in line
    if scramble == "axles-swapped":
        assert "a_f and a_r swapped?" in line
    # on request it runs, with the problem as the one warning line, and is worse
    out, err = ran(capsys, est_argv(satory_log, veh, d / "est.csv", "ekf", "--accept-mismatch"))
    assert len(err.strip().splitlines()) == 1 and err.startswith("warning: ")


def test_another_car_on_the_real_log_refused(capsys, tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    load_revs().segment(150.0, 270.0).to_csv(d / "revs.csv")
    refused(capsys, est_argv(d / "revs.csv", "yacine2015", d / "est.csv"),
            "yacine2015.toml cannot be this car", "x its model's", dirs=[d])


def test_right_vehicle_files_are_never_refused_and_accurate(capsys, tmp_path, satory_log):
    """The shipped pairs and the plant's cars with their data-sheet files run (exit 0, no
    warning for the emulated and plant logs), and the scrambled file is worse."""
    from vehicle_observers.data import plant

    d = tmp_path / "run"
    d.mkdir()
    out, err = ran(capsys, est_argv(satory_log, car_file(d / "car.toml"), d / "e.csv"))
    assert err == ""
    # the scrambled file, run on request, is worse than the right one
    ran(capsys, est_argv(satory_log, car_file(d / "x10.toml", SCRAMBLES["stiffness-x10-B"]),
                         d / "x10.csv", "ekf", "--accept-mismatch"))
    truth = load_log(satory_log, min_vx=None).vy
    e_right, e_x10 = (rmse(load_log(d / f, required=("t_s", "vy_mps"), min_vx=None).vy, truth)
                      for f in ("e.csv", "x10.csv"))
    assert e_right < 0.5 * e_x10, (e_right, e_x10)
    load_revs().segment(150.0, 270.0).to_csv(d / "revs.csv")
    out, err = ran(capsys, est_argv(d / "revs.csv", "revs250lm", d / "r.csv"))
    assert err == ""
    for vid in (1, 2, 3):
        log = plant.plant_log("slalom", seed=4, quick=True, vehicle_id=vid)
        log.to_csv(d / f"plant{vid}.csv")
        veh = d / f"plant{vid}.toml"
        veh.write_text(_vehicle_toml(plant.nominal_params(vid)))
        out, err = ran(capsys, est_argv(d / f"plant{vid}.csv", veh, d / f"p{vid}.csv"))
        assert err == "" and "vy    RMSE" in out


def _vehicle_toml(p, unc="[uncertainty]\nstiffness_rel = 0.1\nvx_min = 2.0\nvx_max = 40.0\n"
                  "slip_max_deg = 8.0\n"):
    lines = [f"m = {p.m!r}", f"I_z = {p.I_z!r}", f"a_f = {p.a_f!r}", f"a_r = {p.a_r!r}"]
    for sect, t in (("tire_front", p.tire_f), ("tire_rear", p.tire_r)):
        lines += [f"[{sect}]", 'model = "pacejka"', f"B = {t.B!r}", f"C = {t.C!r}",
                  f"D = {t.D!r}", f"E = {t.E!r}"]
    return "\n".join(lines) + "\n" + unc


def test_speed_box_below_the_log_refused_for_interval_observers(capsys, run):
    """The box [2, 10] m/s on a log at 15 m/s: every row would be clipped."""
    veh = car_file(run / "slow.toml", lambda t: t.replace("vx_max = 17.0", "vx_max = 10.0"))
    for obs in ("interval-ifqir2017", "interval-coordinates"):
        line = refused(capsys, est_argv(run / "log.csv", veh, run / "est.csv", obs),
                       "speed box [2, 10] m/s excludes 2000 of the 2000 rows in motion",
                       "above 10 m/s", dirs=[run])
        assert "--accept-mismatch" in line
    out, err = ran(capsys, est_argv(run / "log.csv", veh, run / "est.csv", "ekf"))
    assert err == ""                       # the EKF does not read the box


def test_speed_box_clipping_a_few_rows_is_one_warning(capsys, tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    log = emulate(T=20.0, profile=lambda t: 15.0 + 3.0 * np.clip(t - 15.0, 0.0, 1.0))
    save(log, d / "log.csv")
    veh = car_file(d / "car.toml")                     # box [2, 17]: 17..18 m/s clipped
    n = int(np.sum(log.vx > 17.0))
    out, err = ran(capsys, est_argv(d / "log.csv", veh, d / "est.csv", "interval-ifqir2017"))
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: ")
    assert f"excludes {n} of the {len(log)} rows in motion" in lines[0] and "clip" in lines[0]


def test_consistency_library_both_sides():
    """The check itself: right files 'ok' (numbers inside the calibrated ranges), scrambled
    ones 'mismatch', on logs of three sources."""
    from dataclasses import replace

    from vehicle_observers.data import plant, scenarios
    from vehicle_observers.estimation.consistency import YAW_GAIN, check_vehicle_log
    from vehicle_observers.models.tires import Pacejka
    from vehicle_observers.models.vehicle import Vehicle

    def V(p):
        return Vehicle(p.name, p, {}, None, "")

    def x10(p):
        return replace(p, tire_f=Pacejka(B=10 * p.tire_f.B, C=p.tire_f.C, D=p.tire_f.D,
                                         E=p.tire_f.E),
                       tire_r=Pacejka(B=10 * p.tire_r.B, C=p.tire_r.C, D=p.tire_r.D,
                                      E=p.tire_r.E))

    revs, yac = load_vehicle("revs250lm").params, load_vehicle("yacine2015").params
    bmw = plant.nominal_params(2)
    cases = [(load_revs(), revs, (yac,)),
             (scenarios.sine_with_dwell(seed=1), yac, (revs, bmw)),
             (plant.plant_log("sine_with_dwell", seed=5, quick=True), bmw, (yac,))]
    for log, own, others in cases:
        r = check_vehicle_log(log, V(own))
        assert r.verdict == "ok", r.message()
        assert 1 / YAW_GAIN[0] <= r.yaw_gain <= YAW_GAIN[0]
        for bad in (x10(own), replace(own, a_f=own.a_r, a_r=own.a_f), *others):
            r = check_vehicle_log(log, V(bad))
            assert r.verdict == "mismatch", (log.source, bad.name)


# ================================================================== 5. changes of unit inside a log
def _from_row(col, factor, row=1200):
    def edit(c):
        c[col] = c[col].copy()
        c[col][row:] = factor * c[col][row:]
    return edit


@pytest.mark.parametrize("edit, needles", [
    (_from_row("t_s", 1000.0), ("'t_s' changes scale at row 1200 (line 1202)", "milliseconds")),
    (_from_row("vx_mps", 3.6), ("'vx_mps' changes scale at row 1200", "km/h")),
    (_from_row("delta_roadwheel_rad", np.degrees(1.0)), ("'delta_roadwheel_rad'", "degrees")),
    (_from_row("yaw_rate_radps", np.degrees(1.0)), ("'yaw_rate_radps'", "deg/s")),
], ids=["t-ms", "vx-kmh", "delta-deg", "r-degps"])
def test_change_of_unit_inside_the_log_named_with_its_row(capsys, tmp_path, cruise, edit,
                                                           needles):
    d = tmp_path / "run"
    d.mkdir()
    if "vy" in needles[0]:
        edit = _from_row("vy_mps", 3.6, row=1333)
    p = save(cruise, d / "log.csv", edit=edit)
    refused(capsys, est_argv(p, car_file(d / "car.toml"), d / "est.csv"), *needles,
            "--accept-out-of-range", dirs=[d])


@pytest.mark.parametrize("factor, why", [(1 / 9.81, "g (x1/9.81)"), (3.28, "ft")])
def test_accelerometer_unit_change_hidden_in_noise_found_by_its_gain(capsys, tmp_path, factor,
                                                                     why):
    """a_y in g from some row of the Revs log (its a_y noise 0.9 m/s^2 hides the step): the
    ratio of a_y to v_x r changes, and the row is found within 2 samples."""
    d = tmp_path / "run"
    d.mkdir()
    seg = load_revs().segment(150.0, 330.0)
    k = 11000
    cols = seg.columns()
    cols = {c: cols[c].copy() for c in ("t_s", "vx_mps", "delta_roadwheel_rad",
                                        "yaw_rate_radps", "ay_mps2")}
    cols["ay_mps2"][k:] *= factor
    write_csv(d / "log.csv", cols)
    line = refused(capsys, est_argv(d / "log.csv", "revs250lm", d / "est.csv"), "'ay_mps2'",
                   why, dirs=[d])
    row = int(line.split("at row ")[1].split()[0])
    assert abs(row - k) <= 2, line


def test_sampling_rate_change_is_not_a_change_of_unit(capsys, tmp_path):
    """100 Hz then 10 Hz (a logger reconfigured; x10 < x30) is accepted and estimated."""
    d = tmp_path / "run"
    d.mkdir()
    fine = emulate(T=30.0, profile=lambda t: np.full_like(t, 15.0))
    idx = np.r_[np.arange(0, 1500), np.arange(1500, len(fine), 10)]
    p = save(fine, d / "log.csv", edit=lambda c: [c.__setitem__(k, v[idx])
                                                  for k, v in list(c.items())])
    ran(capsys, est_argv(p, car_file(d / "car.toml"), d / "est.csv"))
    e = load_log(d / "est.csv", required=("t_s", "vy_mps"), min_vx=None)
    assert rmse(e.vy, fine.vy[idx]) < 0.3 * rmse(0 * e.vy, fine.vy[idx])


# ================================================================== 6. options against the log
@pytest.mark.parametrize("gap, ok", [("0.001", False), ("0.02", False), ("0.03", True)])
def test_max_gap_must_cover_a_few_sample_periods(capsys, run, gap, ok):
    argv = est_argv(run / "log.csv", run / "car.toml", run / "est.csv", "ekf", "--max-gap", gap)
    if ok:
        out, _ = ran(capsys, argv)
        assert "0 re-initialisation(s)" in out
        return
    refused(capsys, argv, f"--max-gap {gap} s is shorter than 3 sample periods",
            "median step 0.01 s", dirs=[run])
    refused(capsys, ["tune", run / "log.csv", "--vehicle", "yacine2015", "--max-gap", gap],
            "--max-gap", dirs=[run])


def test_tune_without_ay_says_what_it_cannot_identify(capsys, tmp_path, cruise):
    d = tmp_path / "run"
    d.mkdir()
    p = save(cruise, d / "noay.csv", columns=("t_s", "vx_mps", "delta_roadwheel_rad",
                                              "yaw_rate_radps"))
    before = snapshot(d)
    code = main(["tune", str(p), "--vehicle", "yacine2015"])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "no 'ay_mps2' column" in err and "R_ay" in err and "q_b" in err
    assert snapshot(d) == before


# ================================================================== 7. one-line usage errors
@pytest.mark.parametrize("argv, needle", [
    (["estimate", "LOG", "--vehicle", "yacine2015", "--observer", "ekf", "--out", "E",
      "--tune-window", "abc"], "argument --tune-window: invalid float value: 'abc'"),
    (["estimate", "LOG", "--vehicle", "yacine2015", "--observer", "ekf", "--out", "E",
      "--max-gap", "x"], "argument --max-gap: invalid float value: 'x'"),
    (["estimate", "LOG", "--observer", "ekf", "--out", "E"], "required: --vehicle"),
    (["tune"], "required"),
    (["frobnicate"], "invalid choice: 'frobnicate'"),
    (["identify", "LOG", "--out", "x.toml", "--mass", "heavy", "--inertia", "1", "--a-f", "1",
      "--a-r", "1"], "argument --mass: invalid float value: 'heavy'"),
    (["identify", "LOG", "--out", "x.toml", "--mass", "1", "--inertia", "1", "--a-f", "1",
      "--a-r", "1", "--nonlinear", "maybe"], "argument --nonlinear: invalid choice"),
    (["estimate", "LOG", "--vehicle", "yacine2015", "--observer", "nope", "--out", "E.csv"],
     "unknown observer 'nope'"),
])
def test_usage_errors_are_one_line(capsys, tmp_path, argv, needle):
    argv = [str(tmp_path / a) if a in ("LOG", "E", "E.csv") else a for a in argv]
    refused(capsys, argv, needle, dirs=[tmp_path])


def test_help_still_prints_and_exits_0(capsys):
    with pytest.raises(SystemExit):
        raise SystemExit(main(["estimate", "--help"]))
    assert "--accept-mismatch" in capsys.readouterr().out


# ================================================================== 8. library API
def test_drive_log_nan_refused_at_construction_naming_row_and_column():
    from vehicle_observers.core.errors import LogFormatError

    t = np.arange(4) * 0.01
    with pytest.raises(LogFormatError, match="column 'yaw_rate_radps' has 1 NaN/inf value"
                                             "\\(s\\), first at row 2"):
        DriveLog(t=t, vx=np.full(4, 10.0), delta=np.zeros(4),
                 yaw_rate=np.array([0, 0, np.nan, 0]))


# ================================================================== 9. speed: design cache
def test_interval_design_cached_on_disk_is_the_same_design(tmp_path, monkeypatch):
    from vehicle_observers.estimation import adapters

    monkeypatch.setenv("VEHICLE_OBSERVERS_CACHE", str(tmp_path / "c"))
    veh = load_vehicle("yacine2015")
    veh = type(veh)(veh.name, veh.params, {**veh.uncertainty, "vx_min": 2.0}, None, veh.path)
    monkeypatch.setattr(adapters, "_IV_CACHE", {})
    a, _ = adapters.interval_design(veh, 0.01, cache=True)
    files = list((tmp_path / "c").glob("design-ifqir2017-*.npz"))
    assert len(files) == 1
    monkeypatch.setattr(adapters, "_IV_CACHE", {})
    b, sec = adapters.interval_design(veh, 0.01, cache=True)
    assert sec < 0.5 and b is not a
    assert a.gamma == b.gamma and np.array_equal(a.lmi_margin, b.lmi_margin)
    # another sample period is another design
    monkeypatch.setattr(adapters, "_IV_CACHE", {})
    adapters.interval_design(veh, 0.02, cache=True)
    assert len(list((tmp_path / "c").glob("design-ifqir2017-*.npz"))) == 2

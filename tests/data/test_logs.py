import gzip
import os

import numpy as np
import pytest
from vehicle_observers.core.errors import LogFormatError
from vehicle_observers.data.logs import REQUIRED, DriveLog, despike, load_log, load_revs, write_csv

GOOD = "t_s,vx_mps,delta_roadwheel_rad,yaw_rate_radps,ay_mps2\n" + "\n".join(
    f"{0.01 * k:.2f},20.0,0.01,0.02,1.0" for k in range(5)) + "\n"


def write(tmp_path, text, name="log.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_revs_log_loads_with_schema():
    log = load_revs()
    assert len(log) == 55001
    assert log.t[0] == pytest.approx(149.99) and log.t[-1] == pytest.approx(699.99)
    assert log.dt == pytest.approx(0.01, abs=1e-9)
    assert 16.4 < log.vx.min() < 16.5 and 61.2 < log.vx.max() < 61.3
    assert log.vy is not None and log.ay is not None and "ay_filt_mps2" in log.extra
    # beta is exactly atan2(vy, vx) (PROVENANCE)
    np.testing.assert_allclose(log.extra["beta_rad"], np.arctan2(log.vy, log.vx), atol=1e-6)


def test_roundtrip_and_optional_columns(tmp_path):
    log = load_log(write(tmp_path, GOOD))
    assert log.ay is not None and log.vy is None and log.has("ay_mps2") and not log.has("vy_mps")
    out = tmp_path / "out.csv"
    log.to_csv(out)
    back = load_log(out)
    np.testing.assert_allclose(back.t, log.t)
    with pytest.raises(LogFormatError, match="missing column 'vy_mps' \\(EKF needs it\\)"):
        log.require("vy_mps", purpose="EKF")


def test_written_floats_read_back_bit_exact_in_batches(tmp_path, monkeypatch):
    """The writer's shortest round-trip floats come back bit-identical through the reader,
    across batch boundaries (batch of 7 rows), for awkward values (subnormal, 1e300, -0.0,
    many digits), and integer / boolean columns stay integers."""
    from vehicle_observers.data import logs as L

    monkeypatch.setattr(L, "WRITE_BATCH", 7)
    rng = np.random.default_rng(3)
    n = 50
    t = np.cumsum(rng.uniform(1e-3, 2e-2, n))
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-300, 300, n)
    x[:4] = [5e-324, 1e300, -0.0, 0.1 + 0.2]
    seen = []
    out = tmp_path / "rt.csv"
    L.write_csv(out, {"t_s": t, "x": x, "flag": np.arange(n) % 3 == 0, "k": np.arange(n)},
                progress=lambda i, m: seen.append((i, m)))
    assert seen[-1] == (n, n) and len(seen) == -(-n // 7)
    lines = out.read_text().splitlines()
    assert lines[0] == "t_s,x,flag,k" and lines[1].endswith(",1,0")
    back = L._read_columns(out, "rt.csv", lines[0].split(","), ["t_s", "x", "flag", "k"])
    assert back["t_s"].tobytes() == t.tobytes() and back["x"].tobytes() == x.tobytes()
    np.testing.assert_array_equal(back["flag"], np.arange(n) % 3 == 0)
    np.testing.assert_array_equal(back["k"], np.arange(n))


@pytest.mark.parametrize("mutate, message", [
    (lambda s: s.replace("yaw_rate_radps", "yawrate"), "missing column 'yaw_rate_radps'"),
    (lambda s: s.replace("0.02,1.0\n0.03", "nan,1.0\n0.03", 1),
     "column 'yaw_rate_radps' has 1 NaN/inf value\\(s\\), first at row 2 \\(line 4\\)"),
    (lambda s: s.replace("0.03,20.0", "0.02,20.0"), "duplicate time at row 3 \\(line 5\\): 0.02 -> 0.02"),
    (lambda s: s.replace("0.03,20.0", "0.00,20.0"), "decreasing time at row 3"),
    (lambda s: s.replace("0.04,20.0", "0.04,0.0"), "'vx_mps' must be > 0 m/s .* row 4 \\(line 6\\)"),
    (lambda s: s.replace("0.02,20.0", "0.02,fast"), "column 'vx_mps', row 2 \\(line 4\\): 'fast'"),
    (lambda s: s.replace("0.01,20.0,0.01,0.02,1.0", "0.01,20.0,0.01"), "row 1 \\(line 3\\) has 3 fields"),
    (lambda s: s.split("\n")[0] + "\n", "no data rows"),
    (lambda s: "", "empty file"),
    (lambda s: s.replace("ay_mps2", "vx_mps"), "duplicate column name"),
])
def test_bad_input_clear_errors(tmp_path, mutate, message):
    p = write(tmp_path, mutate(GOOD))
    before = p.read_bytes()
    with pytest.raises(LogFormatError, match=message):
        load_log(p)
    assert p.read_bytes() == before  # loses nothing


def test_missing_file_and_gzip(tmp_path):
    with pytest.raises(LogFormatError, match="no such file"):
        load_log(tmp_path / "nope.csv")
    gz = tmp_path / "log.csv.gz"
    with gzip.open(gz, "wt") as fh:
        fh.write(GOOD)
    assert len(load_log(gz)) == 5
    bad = tmp_path / "bad.csv.gz"
    bad.write_bytes(b"not gzip")
    with pytest.raises(LogFormatError, match="cannot read"):
        load_log(bad)


def test_vx_check_can_be_disabled(tmp_path):
    p = write(tmp_path, GOOD.replace("0.04,20.0", "0.04,0.0"))
    assert load_log(p, min_vx=None).vx[4] == 0.0


def test_segment_and_required():
    log = load_revs().segment(200.0, 201.0)
    assert len(log) == 101 and log.t[0] >= 200.0 and log.t[-1] <= 201.0
    assert set(REQUIRED) <= set(log.columns())
    with pytest.raises(ValueError, match="no samples"):
        log.segment(1000, 1001)


def test_despike_removes_isolated_spikes_only():
    x = np.sin(np.linspace(0, 3, 300)) * 0.1
    y = x.copy()
    y[[50, 200]] += 0.4
    clean, idx = despike(y, 0.05)
    np.testing.assert_array_equal(idx, [50, 200])
    np.testing.assert_allclose(clean, x, atol=2e-3)
    assert y[50] > 0.3  # input untouched
    revs = load_revs()
    _, idx = despike(revs.delta, 0.05)
    assert 671.66 < revs.t[idx].max() < 671.68


def test_write_csv_is_atomic_on_failure(tmp_path):
    out = tmp_path / "est.csv"
    with pytest.raises(ValueError):
        write_csv(out, {"a": np.arange(3), "b": np.arange(4)})
    assert not out.exists() and not list(tmp_path.iterdir())   # no partial file left


def _long_log(tmp_path, n=30000):
    t = np.arange(n) * 0.01
    cols = {"t_s": t, "vx_mps": 20 + np.sin(t), "delta_roadwheel_rad": 0.01 * np.cos(t),
            "yaw_rate_radps": 0.02 * np.sin(0.3 * t)}
    p = tmp_path / "long.csv"
    write_csv(p, cols)
    return p, cols


def test_progress_moves_while_loading_and_writing(tmp_path, monkeypatch):
    import vehicle_observers.data.logs as L

    monkeypatch.setattr(L, "WRITE_BATCH", 7000)
    seen = []
    p, cols = _long_log(tmp_path)
    write_csv(p, cols, progress=lambda k, n: seen.append((k, n)))
    assert seen == [(7000, 30000), (14000, 30000), (21000, 30000), (28000, 30000),
                    (30000, 30000)]
    gz = tmp_path / "long.csv.gz"
    gz.write_bytes(gzip.compress(p.read_bytes()))
    for f in (p, gz):
        read = []
        log = load_log(f, progress=lambda k, n: read.append((k, n)))
        assert read[-1][0] == read[-1][1] == f.stat().st_size          # ends at the file size
        assert all(a[0] <= b[0] for a, b in zip(read, read[1:]))       # never goes back
        np.testing.assert_array_equal(log.t, cols["t_s"])               # shortest round trip
        np.testing.assert_array_equal(log.delta, cols["delta_roadwheel_rad"])


def test_only_requested_columns_are_kept(tmp_path):
    p, _ = _long_log(tmp_path, 50)
    log = load_log(p, columns=("t_s",))
    assert log.delta is not None and log.extra == {}        # required ones always
    with pytest.raises(LogFormatError, match="long.csv: line 3 is longer than 131072"):
        p.write_text(p.read_text().replace("\n0.01,", "\n0.01" + "0" * 140_000 + ",", 1))
        load_log(p)


def test_atomic_output_partial_file_lifecycle(tmp_path, monkeypatch):
    """The partial file is hidden, named with a random token, recorded, and removed when the
    block ends without a commit; a later run removes a killed run's partial file (dead
    writer, recorded, same inode) but never a user's file, even one named like it."""
    import json
    import os

    from vehicle_observers.data.logs import (
        ACTIVE_PARTIALS,
        AtomicOutput,
        partials_registry,
        remove_stale_partials,
    )

    monkeypatch.setenv("VEHICLE_OBSERVERS_CACHE", str(tmp_path / "cache"))
    d = tmp_path / "out"
    d.mkdir()
    out = d / "est.csv"
    users = [d / "est.csv.partial-999999999", d / f".est.csv.999999999-{'0' * 16}.partial"]
    for f in users:
        f.write_text("a user's own file")
    with AtomicOutput(out) as sink:
        tmp = sink.tmp
        assert tmp.name.startswith(".est.csv.") and tmp.name.endswith(".partial")
        assert tmp.exists() and tmp in ACTIVE_PARTIALS
        rec = json.loads(ACTIVE_PARTIALS[tmp].read_text())
        assert rec["pid"] == os.getpid() and rec["ino"] == tmp.stat().st_ino
    assert not tmp.exists() and not out.exists() and not ACTIVE_PARTIALS   # no commit: removed
    assert not list(partials_registry().glob("*.json"))
    with pytest.raises(RuntimeError):
        with AtomicOutput(out):
            raise RuntimeError("failure while computing")
    assert not ACTIVE_PARTIALS and sorted(x.name for x in d.iterdir()) == sorted(
        u.name for u in users)
    # a killed run: its record names a dead pid
    sink = AtomicOutput(out).__enter__()
    m = ACTIVE_PARTIALS.pop(sink.tmp)
    m.write_text(json.dumps({**json.loads(m.read_text()), "pid": 999999999}))
    # a record pointing at a user's file (another inode) is not honoured
    fake = partials_registry() / f"{'1' * 16}.json"
    fake.write_text(json.dumps({**json.loads(m.read_text()), "partial": str(users[1])}))
    assert remove_stale_partials() == [sink.tmp]
    assert all(u.read_text() == "a user's own file" for u in users)
    with AtomicOutput(out) as sink:
        sink.commit({"a": np.arange(3.0)})
    assert out.read_text() == "a\n0.0\n1.0\n2.0\n" and remove_stale_partials() == []
    assert sorted(x.name for x in d.iterdir()) == sorted([out.name] + [u.name for u in users])


def test_gz_output_is_gzip_and_reads_back(tmp_path):
    import gzip as gz

    p, cols = _long_log(tmp_path, 500)
    out = tmp_path / "copy.csv.gz"
    write_csv(out, cols)
    assert out.read_bytes()[:2] == b"\x1f\x8b"
    assert gz.decompress(out.read_bytes()).decode().startswith("t_s,vx_mps,")
    back = load_log(out)
    assert back.t.tobytes() == cols["t_s"].tobytes()
    upper = tmp_path / "COPY.CSV.GZ"
    write_csv(upper, cols)
    assert upper.read_bytes()[:2] == b"\x1f\x8b"


def test_drive_log_refuses_nan_and_bad_shapes_naming_row_and_column():
    t = np.arange(5) * 0.1
    ok = dict(t=t, vx=np.full(5, 10.0), delta=np.zeros(5), yaw_rate=np.zeros(5))
    DriveLog(**ok)
    with pytest.raises(LogFormatError, match="column 'vx_mps' has 1 NaN/inf value\\(s\\), first at row 3"):
        DriveLog(**{**ok, "vx": np.array([10, 10, 10, np.nan, 10.0])})
    with pytest.raises(LogFormatError, match="column 'ay_mps2' has 2 NaN/inf"):
        DriveLog(**ok, ay=np.array([0, np.inf, 0, 0, -np.inf]))
    with pytest.raises(LogFormatError, match="column 'delta_roadwheel_rad' has 4 rows, 't_s' has 5"):
        DriveLog(**{**ok, "delta": np.zeros(4)})
    with pytest.raises(LogFormatError, match="'yaw_rate_radps' must be a 1-D numeric array"):
        DriveLog(**{**ok, "yaw_rate": np.zeros((5, 2))})
    with pytest.raises(LogFormatError, match="extra column 'x' has shape"):
        DriveLog(**ok, extra={"x": np.zeros(3)})
    DriveLog(**ok, extra={"truth": np.full(5, np.nan)})      # extra truth may hold NaN


def test_special_files_are_refused_not_read(tmp_path):
    fifo = tmp_path / "log.csv"
    os.mkfifo(fifo)
    with pytest.raises(LogFormatError, match="is a FIFO"):
        load_log(fifo)                  # no writer: reading would block forever
    with pytest.raises(LogFormatError, match="is a character device"):
        load_log("/dev/zero")           # never ends
    with pytest.raises(LogFormatError, match="is a directory"):
        load_log(tmp_path)


@pytest.mark.parametrize("edit, message", [
    (lambda c: c.__setitem__("delta_roadwheel_rad", np.degrees(c["delta_roadwheel_rad"]) * 50),
     "'delta_roadwheel_rad' .* degrees"),
    (lambda c: c.__setitem__("yaw_rate_radps", np.degrees(c["yaw_rate_radps"]) * 5),
     "'yaw_rate_radps' .* deg/s"),
    (lambda c: c.__setitem__("vx_mps", c["vx_mps"] * 5), "'vx_mps' .* km/h"),
    (lambda c: c.__setitem__("t_s", c["t_s"] * 1000), "'t_s' .* milliseconds"),
    (lambda c: c.__setitem__("t_s", c["t_s"] * 1e-3), "'t_s' .* 10 kHz"),
])
def test_plausibility_names_column_and_unit(tmp_path, edit, message):
    from vehicle_observers.data.logs import check_plausible

    p, cols = _long_log(tmp_path, 500)
    edit(cols)
    write_csv(p, cols)
    log = load_log(p)
    with pytest.raises(LogFormatError, match=message):
        check_plausible(log)
    check_plausible(log, accept=True)          # accepted on request

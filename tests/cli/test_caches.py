"""The on-disk caches (LMI designs, ``identify``'s fits, the ML noise tuning) hold data only.

A file planted in the cache folder (a pickle that would run code, an ``.npz`` naming a
function or a class outside the package, an edited or truncated entry, an entry of another
version) is never executed: it is ignored with one line naming it and rebuilt, and the
command's output is the same as with an empty cache. Cached numbers that cannot be right
(negative or NaN variances, a ``P`` that is not positive definite) are rebuilt too."""

from __future__ import annotations

import io
import json
import logging
import pickle

import numpy as np
import pytest
from conftest import KALMAN, emulate, save
from vehicle_observers.cli.main import main
from vehicle_observers.core import cache as C
from vehicle_observers.models.vehicle import builtin_vehicles

BASE = builtin_vehicles()["yacine2015"].read_text()


class _Boom:
    """Unpickling this touches the marker file (what a planted pickle could do)."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _npz(tree, meta=None, **arrays):
    text = json.dumps(tree)
    meta = meta or {"schema_version": C.SCHEMA_VERSION, "kind": "design-ifqir2017",
                    "sha256": C._digest(text, arrays)}
    buf = io.BytesIO()
    np.savez(buf, __tree__=np.array(text), __meta__=np.array(json.dumps(meta)), **arrays)
    return buf.getvalue()


def planted(kind: str, marker, good: bytes) -> bytes:
    """Bytes of a bad cache entry of class ``kind`` (``good``: the real entry)."""
    if kind == "pickle":
        return pickle.dumps(_Boom(marker))
    if kind == "object-array":               # np.load would need pickle for it
        buf = io.BytesIO()
        np.savez(buf, __tree__=np.array([_Boom(marker)], dtype=object))
        return buf.getvalue()
    if kind == "class-outside-the-package":
        return _npz({"__obj__": "subprocess:Popen", "state": {}})
    if kind == "function-of-the-package":
        return _npz({"__obj__": "vehicle_observers.cli.main:main", "state": {}})
    if kind == "checksum":                   # an edited entry
        with np.load(io.BytesIO(good), allow_pickle=False) as z:
            files = {k: z[k] for k in z.files}
        k = next(k for k in files if not k.startswith("__") and files[k].dtype.kind == "f"
                 and files[k].size)
        files[k] = files[k] + 1.0
        buf = io.BytesIO()
        np.savez(buf, **files)
        return buf.getvalue()
    if kind == "truncated":
        return good[: len(good) // 2]
    if kind == "other-version":
        return _npz({"__obj__": "vehicle_observers.observers.interval:IntervalDesign",
                     "state": {"L": 1.0}})
    if kind == "schema-version":
        with np.load(io.BytesIO(good), allow_pickle=False) as z:
            files = {k: z[k] for k in z.files}
        meta = json.loads(str(files["__meta__"]))
        files["__meta__"] = np.array(json.dumps({**meta, "schema_version": 0}))
        buf = io.BytesIO()
        np.savez(buf, **files)
        return buf.getvalue()
    raise ValueError(kind)


BAD = ("pickle", "object-array", "class-outside-the-package", "function-of-the-package",
       "checksum", "truncated", "other-version", "schema-version")


@pytest.fixture()
def run(tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    save(emulate(T=20.0, profile=lambda t: np.full_like(t, 15.0)), d / "log.csv")
    (d / "car.toml").write_text(BASE.replace("vx_min = 0.2", "vx_min = 2.0") + KALMAN)
    return d


def _estimate(run, capsys, name):
    argv = ["estimate", str(run / "log.csv"), "--vehicle", str(run / "car.toml"), "--observer",
            "interval-ifqir2017", "--out", str(run / name), "--no-progress"]
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 0, err
    return (run / name).read_bytes()


@pytest.mark.parametrize("kind", BAD)
def test_planted_design_cache_entry_never_runs_and_is_rebuilt(run, capsys, caplog, kind,
                                                              tmp_path):
    """Catches: a cache file that runs code when read (pickle), or a bad entry used (or
    ending in an internal error) instead of rebuilt."""
    from vehicle_observers.estimation import adapters

    adapters._IV_CACHE.clear()
    ref = _estimate(run, capsys, "a.csv")
    files = list((tmp_path / "cache").glob("design-ifqir2017-*.npz"))
    assert len(files) == 1 and not list((tmp_path / "cache").glob("*.pkl"))
    marker = tmp_path / "pwned"
    files[0].write_bytes(planted(kind, marker, files[0].read_bytes()))
    adapters._IV_CACHE.clear()
    with caplog.at_level(logging.WARNING, "vehicle_observers.cache"):
        again = _estimate(run, capsys, "b.csv")
    assert not marker.exists()
    assert again == ref
    assert [r.getMessage() for r in caplog.records if files[0].name in r.getMessage()], \
        caplog.text
    # rebuilt: the next run reads a valid entry without a word
    adapters._IV_CACHE.clear()
    caplog.clear()
    with caplog.at_level(logging.WARNING, "vehicle_observers.cache"):
        _estimate(run, capsys, "c.csv")
    assert not caplog.records


@pytest.mark.parametrize("edit", ["not-positive-definite", "nan"])
def test_design_entry_with_wrong_numbers_rebuilt(tmp_path, monkeypatch, edit):
    """Catches: a cached design whose P is not positive definite or whose gain is NaN used
    as if certified."""
    from vehicle_observers.estimation import adapters
    from vehicle_observers.models.vehicle import load_vehicle

    monkeypatch.setenv("VEHICLE_OBSERVERS_CACHE", str(tmp_path / "c"))
    veh = load_vehicle("yacine2015")
    veh = type(veh)(veh.name, veh.params, {**veh.uncertainty, "vx_min": 2.0}, None, veh.path)
    monkeypatch.setattr(adapters, "_IV_CACHE", {})
    a, _ = adapters.interval_design(veh, 0.01, cache=True)
    f = next((tmp_path / "c").glob("design-*.npz"))
    bad = C.load(f, "design-ifqir2017")
    if edit == "nan":
        bad.L = bad.L.copy()
        bad.L[0, 0, 0, 0] = np.nan
    else:
        bad.P = -bad.P
    assert not C.save(f, bad, "design-ifqir2017", C.check_finite)     # refused on writing
    C.save(f, bad, "design-ifqir2017")                                # planted anyway
    monkeypatch.setattr(adapters, "_IV_CACHE", {})
    b, _ = adapters.interval_design(veh, 0.01, cache=True)
    assert np.all(np.isfinite(b.L)) and np.all(b.P > 0)
    assert np.array_equal(a.L, b.L)


@pytest.mark.parametrize("kind", ["pickle", "class-outside-the-package", "truncated",
                                  "other-version"])
def test_planted_identify_cache_entry_never_runs(tmp_path, capsys, kind):
    """Catches: ``identify`` reading its cache with pickle (code planted in the cache
    folder runs) or trusting a bad entry."""
    from vehicle_observers.data import plant

    P = plant.nominal_params()
    geom = ["--mass", str(P.m), "--inertia", str(P.I_z), "--a-f", str(P.a_f), "--a-r",
            str(P.a_r)]
    log = tmp_path / "slalom.csv"
    plant.plant_log("slalom", seed=2, quick=True).to_csv(log)
    assert main(["identify", str(log), "--out", str(tmp_path / "a.toml"), *geom]) == 0
    f = next((tmp_path / "cache").glob("identify-*.npz"))
    marker = tmp_path / "pwned"
    f.write_bytes(planted(kind, marker, f.read_bytes()))
    capsys.readouterr()
    assert main(["identify", str(log), "--out", str(tmp_path / "b.toml"), *geom]) == 0
    assert not marker.exists()
    assert (tmp_path / "a.toml").read_text() == (tmp_path / "b.toml").read_text()


TUNING_EDITS = {
    "negative variance": lambda d: {**d, "theta": [-abs(d["theta"][0])] + d["theta"][1:]},
    "NaN variance": lambda d: {**d, "theta": [float("nan")] + d["theta"][1:]},
    "negative P0": lambda d: {**d, "P0": [-1.0, 0.01, 1.0]},
    "zero R": lambda d: {**d, "theta": d["theta"][:3] + [0.0] + d["theta"][4:]},
    "old layout": None,
    "not JSON": None,
}


@pytest.mark.parametrize("edit", list(TUNING_EDITS))
def test_tuning_cache_with_impossible_variances_rebuilt(tmp_path, monkeypatch, caplog, edit):
    """Catches: negative variances used silently (v_y off by metres per second), NaN
    variances failing every later run without naming the cache, an old entry's layout
    ending in an internal error."""
    import dataclasses

    from vehicle_observers.data.logs import DriveLog
    from vehicle_observers.estimation import kalman_runs as K
    from vehicle_observers.models.vehicle import load_vehicle

    monkeypatch.setenv("VEHICLE_OBSERVERS_CACHE", str(tmp_path / "c"))
    lg = emulate(T=20.0, profile=lambda t: np.full_like(t, 15.0))
    lg = DriveLog(t=lg.t, vx=lg.vx, delta=lg.delta, yaw_rate=lg.yaw_rate, ay=lg.ay)
    veh = dataclasses.replace(load_vehicle("yacine2015"), kalman=None)
    ref, _ = K.kalman_tuning(lg, veh, window_s=20.0, maxiter=20, cache=True)
    f = next((tmp_path / "c").glob("tuning-*.json"))
    doc = json.loads(f.read_text())["entry"]
    if edit == "old layout":                        # the layout before the schema version
        f.write_text(json.dumps(doc))
    elif edit == "not JSON":
        f.write_text("{\"theta\": [1, 2")
    else:
        bad = TUNING_EDITS[edit](doc)
        text = json.dumps(bad, sort_keys=True)      # a consistent checksum: the numbers decide
        import hashlib

        f.write_text(json.dumps({"meta": {"schema_version": C.SCHEMA_VERSION,
                                          "kind": "kalman-tuning",
                                          "sha256": hashlib.sha256(text.encode()).hexdigest()},
                                 "entry": bad}))
    with caplog.at_level(logging.WARNING, "vehicle_observers.cache"):
        tun, _ = K.kalman_tuning(lg, veh, window_s=20.0, maxiter=20, cache=True)
    assert [r for r in caplog.records if f.name in r.getMessage()], caplog.text
    assert tun.theta().tolist() == ref.theta().tolist() and "(cached)" not in tun.source


def test_no_pickle_is_read_back_anywhere_in_the_library():
    """Catches: a cache (or any file) read with pickle again."""
    from vehicle_observers.data.logs import repo_root

    hits = []
    for f in sorted((repo_root() / "lib").rglob("*.py")):
        for i, line in enumerate(f.read_text().splitlines(), 1):
            code = line.split("#")[0]
            if "pickle.load" in code or "import pickle" in code or "allow_pickle=True" in code:
                hits.append(f"{f.name}:{i}")
    assert hits == []

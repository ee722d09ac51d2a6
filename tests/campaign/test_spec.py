"""Campaign specs: every error is one line naming the key, raised before anything runs; the
plan enumerates every combination once; random draws depend on the task key only."""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import subprocess

import numpy as np
import pytest
from campaignkit import PY, TINY, subprocess_env
from vehicle_observers.campaign import SpecError, load_spec, run
from vehicle_observers.campaign.spec import ERROR_KEYS, dump_toml, seed_sequence, stable_hash

pytestmark = pytest.mark.xdist_group("campaign")


def _with(path: str, value):
    """TINY with ``path`` (dotted; ``None`` value deletes) replaced."""
    d = copy.deepcopy(TINY)
    *head, last = path.split(".")
    t = d
    for k in head:
        t = t.setdefault(k, {})
    if value is None:
        t.pop(last, None)
    else:
        t[last] = value
    return d


BAD = [
    ("estimators", ["ekf", "nope"], "unknown estimator 'nope'"),
    ("sensors.noise_scale", [1.0, -0.5], "key 'sensors.noise_scale' must be in [0, 1000]"),
    ("sensors.std", {"yaw_rate": -1.0}, "key 'sensors.std.yaw_rate' must be in"),
    ("errors.mass", [], "key 'errors.mass' is an empty list"),
    ("seeds", 3, "unknown key 'seeds'"),
    ("sensors.noise", [1.0], "unknown key 'sensors.noise'"),
    ("truth.plants", ["multibody:yacine2015"], "unknown car 'yacine2015' for plant 'multibody'"),
    ("truth.plants", ["wind:bmw_320i"], "unknown plant 'wind'"),
    ("truth.manoeuvres", [{"name": "slalom", "speed": 3.0}], "unknown argument 'speed'"),
    ("errors.stiffness", [-1.5], "key 'errors.stiffness' must be in [-0.9, 10]"),
    ("repetitions", 0, "key 'repetitions' must be in [1"),
    ("observer.speed_range", [[20.0, 5.0]], "needs vx_min < vx_max"),
    ("estimators", ["ts-yacine2015"], "needs log column(s) yL_m, psiL_rad"),
    ("errors.samples", 4, "only read with design = \"sample\""),
    ("lmi_map.kappa", [], "key 'lmi_map.kappa' is an empty list"),
]


@pytest.mark.parametrize("path,value,text", BAD, ids=[f"{p}={v}" for p, v, _ in BAD])
def test_spec_error_is_one_line_and_nothing_runs(tmp_path, path, value, text):
    out = tmp_path / "out"
    with pytest.raises(SpecError) as ei:
        run(_with(path, value), out, engine="serial", progress=False)
    msg = str(ei.value)
    assert text in msg and "\n" not in msg, msg
    assert not out.exists()


def test_rate_must_divide_the_plant_rate(tmp_path):
    d = _with("truth.plants", ["lpv:bmw_320i", "multibody:bmw_320i"])
    d["sensors"]["rates_hz"] = [100.0, 30.0]
    with pytest.raises(SpecError, match="30 Hz does not divide the 100 Hz native rate of plant "
                                        "'multibody'"):
        run(d, tmp_path / "out", engine="serial", progress=False)
    d["sensors"]["rates_hz"] = [100.0, 50.0, 20.0]
    assert load_spec(d).rates == (100.0, 50.0, 20.0)
    assert not (tmp_path / "out").exists()


def test_cli_spec_error_exit_2_one_line(tmp_path):
    spec = tmp_path / "bad.toml"
    spec.write_text('estimators = ["ekf"]\nrepetitions = -1\n[truth]\nplants = ["lpv:bmw_320i"]\n')
    p = subprocess.run([PY, "-m", "vehicle_observers", "campaign", str(spec), "--out",
                        str(tmp_path / "out"), "--no-progress"], capture_output=True, text=True,
                       env=subprocess_env(), timeout=120)
    assert p.returncode == 2
    assert p.stderr.count("\n") == 1 and "key 'repetitions' must be in" in p.stderr, p.stderr
    assert not (tmp_path / "out").exists()


def test_another_spec_into_the_same_folder_is_refused(tmp_path):
    small = _with("estimators", ["ekf"])
    small["repetitions"] = 1
    small.pop("lmi_map")
    small["truth"]["plants"] = ["lpv:yacine2015"]
    out = tmp_path / "out"
    run(small, out, engine="serial", progress=False)
    n = len(list((out / "results").glob("*.parquet")))
    other = copy.deepcopy(small)
    other["seed"] = 8
    with pytest.raises(SpecError, match="holds another campaign"):
        run(other, out, engine="serial", progress=False)
    assert len(list((out / "results").glob("*.parquet"))) == n
    # the same campaign written differently (TOML, comments, defaults spelled out) is accepted
    toml = "# same campaign\n" + dump_toml({**small, "references": ["open-loop-linear",
                                                                     "linear-kf"]})
    assert load_spec(toml).sha256 == load_spec(small).sha256
    assert run(toml, out, engine="serial", progress=False).run_now == 0


def test_plan_enumerates_every_combination_once():
    s = load_spec(TINY)
    tasks = [s.task(i) for i in range(s.n_tasks)]
    keys = [(t.estimator, t.plant, t.car, t.variant, t.rate, t.manoeuvre, t.noise, t.bias, t.rep)
            for t in tasks]
    want = [(e, p, c, v, r, m, n, b, k)
            for (e, p, c), v, r, m, n, b, k in itertools.product(
                s.pairs, range(len(s.variants)), s.rates, s.manoeuvres, s.noises,
                range(len(s.biases)), range(s.repetitions))]
    assert keys == want and len(set(keys)) == s.n_tasks == 64
    # 2 named estimators + the 2 references, on both cars
    assert {e for e, _, _ in s.pairs} == {"ekf", "interval-ifqir2017", "open-loop-linear",
                                          "linear-kf"}
    b = s.batches()
    assert b[0][1] == 0 and b[-1][2] == s.n_tasks and all(x[2] == y[1] for x, y in zip(b, b[1:]))
    assert [v.error_dict["stiffness"] for v in s.variants] == [0.0, 0.15]
    with pytest.raises(IndexError):
        s.task(s.n_tasks)


def test_auto_batch_size_keeps_large_campaigns_at_a_few_thousand_tasks():
    d = _with("repetitions", 20000)          # 640 000 simulations
    d.pop("batch_size")
    s = load_spec(d)
    assert s.n_tasks == 640_000 and len(s.batches()) <= 2000 and s.batch_size == 320
    d["repetitions"] = 200                   # 6400 simulations: 64 per task
    assert load_spec(d).batch_size == 64
    d["repetitions"] = 1                     # 32 simulations: one per task
    assert load_spec(d).batch_size == 1


def test_all_skips_estimators_a_plant_cannot_feed():
    d = _with("estimators", "all")
    d["truth"]["plants"] = ["lpv:bmw_320i", "yaw-drift:yacine2015"]
    s = load_spec(d)
    ts = [(p, c) for e, p, c in s.pairs if e == "ts-yacine2015"]
    assert ts == [("yaw-drift", "yacine2015")]       # needs the vision channels
    assert {e for e, p, _ in s.pairs if p == "lpv"} >= {"ekf", "ukf", "rts", "linear-kf"}


def test_seed_of_a_key_is_the_sha256_of_its_canonical_json():
    key = ("log", "lpv", "bmw_320i", "slalom(duration=6.0)", 1.0, 0, 100.0, 3)
    h = hashlib.sha256(json.dumps(key, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    assert stable_hash(key) == h
    ss = seed_sequence(7, key)
    assert ss.entropy == [7, *(int(h[i:i + 8], 16) for i in range(0, 32, 8))]
    # another process with another hash salt draws the same numbers
    code = ("from vehicle_observers.campaign.spec import seed_sequence; import numpy as np; "
            f"print(np.random.default_rng(seed_sequence(7, {key!r})).random(3).tolist())")
    env = subprocess_env()
    env["PYTHONHASHSEED"] = "12345"
    p = subprocess.run([PY, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert json.loads(p.stdout) == np.random.default_rng(ss).random(3).tolist()


def test_sampled_errors_are_keyed_per_draw():
    d = _with("errors", {"design": "sample", "samples": 3, "mass": [-0.1, 0.1],
                         "friction": [-0.3, 0.0]})
    a = load_spec(d).variants
    d["errors"]["samples"] = 5
    b = load_spec(d).variants
    assert [v.errors for v in a] == [v.errors for v in b[:3]]     # draw j does not move
    for v in b:
        e = v.error_dict
        assert -0.1 <= e["mass"] <= 0.1 and -0.3 <= e["friction"] <= 0.0
        assert all(e[k] == 0.0 for k in ERROR_KEYS if k not in ("mass", "friction"))
    assert len({v.errors for v in b}) == 5


def test_an_estimator_restricted_to_some_plants():
    d = _with("estimators", ["ekf", {"name": "interval-ifqir2017", "plants": ["lpv:yacine2015"]}])
    s = load_spec(d)
    assert [(p, c) for e, p, c in s.pairs if e == "interval-ifqir2017"] == [("lpv", "yacine2015")]
    assert len([1 for e, _, _ in s.pairs if e == "ekf"]) == 2
    d["estimators"][1]["plants"] = ["lpv:vw_vanagon"]
    with pytest.raises(SpecError, match="names 'lpv:vw_vanagon', not one of truth.plants"):
        load_spec(d)


def test_spec_sources(tmp_path):
    with pytest.raises(SpecError, match="no such campaign spec file"):
        load_spec(tmp_path / "missing")
    with pytest.raises(SpecError, match="not valid TOML"):
        load_spec("estimators = [")
    bad = tmp_path / "when.toml"
    bad.write_text('estimators = ["ekf"]\nwhen = 2026-12-01\n[truth]\nplants = ["lpv:bmw_320i"]\n')
    with pytest.raises(SpecError, match="values must be strings, finite numbers"):
        load_spec(bad)

"""Campaigns with a plug-in written outside the repository: loaded by path, option sweeps,
results tied to the code that made them, a plug-in truth plant, the shipped specs."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from campaignkit import ROOT, same_bits, subprocess_env
from plugin_sources import AX_PLUGIN, CAMPAIGN_PLUGIN

#: reads the campaign logs' ax_mps2; a truth plant "kinematic" (no tyre slip dynamics)
PLUGIN = CAMPAIGN_PLUGIN


def spec_text(plants='"lpv:bmw_320i"'):
    return textwrap.dedent(f'''
        name = "open"
        seed = 3
        repetitions = 2
        batch_size = 2
        estimators = [{{name = "ax-vy-c", options = {{gain = [1.0, 4.0]}}}}]
        references = ["open-loop-linear"]

        [truth]
        plants = [{plants}]
        manoeuvres = [{{name = "slalom", duration = 6.0}}]
        ''')


def campaign(*argv):
    p = subprocess.run([sys.executable, "-m", "vehicle_observers", *map(str, argv)],
                       capture_output=True, text=True, env=subprocess_env(), cwd=ROOT,
                       timeout=600)
    return p.returncode, p.stdout, p.stderr


@pytest.fixture()
def setup(tmp_path):
    (tmp_path / "ax_campaign_obs.py").write_text(PLUGIN)
    (tmp_path / "spec.toml").write_text(spec_text())
    return tmp_path


def test_plugin_option_sweep_and_resume_after_an_edit(setup):
    """Catches: a campaign refusing ``--plugin`` or a ``.py`` plug-in; options not reaching
    ``build`` (the two gains must give different v_y errors) or not a sweep axis of the
    report; a resume after the plug-in's source changed silently keeping the old rows (it
    must refuse, naming the plug-in), and ``--recompute`` rewriting rows the edit does not
    affect (the reference's batch files keep their bytes) or keeping the old ones."""
    from vehicle_observers.campaign import read_results

    d = setup
    plug, out = d / "ax_campaign_obs.py", d / "run"
    args = ("campaign", d / "spec.toml", "--out", out, "--plugin", plug, "--engine", "serial",
            "--no-progress")
    code, o, err = campaign(*args)
    assert code == 0, err
    table = read_results(out)
    res = table.to_pylist()
    assert all(r["ok"] for r in res), [r["error"] for r in res if not r["ok"]]
    by = {}
    for r in res:
        by.setdefault(r["estimator"], []).append(r)
    assert set(by) == {"ax-vy-c[gain=1.0]", "ax-vy-c[gain=4.0]", "open-loop-linear"}
    assert {json.loads(r["options"])["gain"] for r in res if r["options"]} == {1.0, 4.0}
    e1 = [r["rmse_vy"] for r in by["ax-vy-c[gain=1.0]"]]
    e4 = [r["rmse_vy"] for r in by["ax-vy-c[gain=4.0]"]]
    assert all(a != b for a, b in zip(e1, e4))
    prov = json.loads((out / "provenance.json").read_text())
    assert set(prov["plugins"]) == {"ax_campaign_obs.py"}
    code, o, err = campaign("campaign", "report", out)
    assert code == 0 and "ax-vy-c[gain=1.0]" in o and "ax-vy-c[gain=4.0]" in o, err

    ref_files = {}
    for r in by["open-loop-linear"]:
        f = out / "results" / f"batch-{r['batch']:06d}.parquet"
        ref_files[f] = f.read_bytes()
    plug.write_text(PLUGIN.replace("- self.k * z", "- 2.0 * self.k * z"))
    code, o, err = campaign(*args)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "plug-in ax_campaign_obs.py: source changed" in err and "--recompute" in err
    assert not same_bits(read_results(out), table)         # nothing touched
    code, o, err = campaign(*args, "--recompute")
    assert code == 0, err
    new_table = read_results(out)
    new = new_table.to_pylist()
    assert len(new) == len(res)
    import pyarrow.compute as pc

    ref = pc.equal(table["estimator"], "open-loop-linear")
    assert not same_bits(table.filter(ref), new_table.filter(ref))
    for a, b in zip(res, new):
        if a["estimator"] != "open-loop-linear":   # gain doubled by the edit
            assert a["rmse_vy"] != b["rmse_vy"]
    for f, data in ref_files.items():
        if all(r["estimator"] == "open-loop-linear" for r in res if r["batch"] == int(f.stem[6:])):
            assert f.read_bytes() == data
    code, o, err = campaign(*args)                         # now the same code: resumes
    assert code == 0 and "0 simulation(s) run now" in o, err


def test_plugin_truth_plant(setup):
    """Catches a plant list closed to plug-ins (the if/elif chain): a registered plant runs
    like the built-in ones, with its own columns; an unknown plant names the registered
    ones."""
    from vehicle_observers.campaign import read_results

    d = setup
    (d / "spec.toml").write_text(spec_text('"kinematic:bmw_320i"'))
    code, o, err = campaign("campaign", d / "spec.toml", "--out", d / "run", "--plugin",
                            d / "ax_campaign_obs.py", "--engine", "serial", "--no-progress")
    assert code == 0, err
    res = read_results(d / "run").to_pylist()
    assert {r["plant"] for r in res} == {"kinematic"} and all(r["ok"] for r in res)
    # the kinematic truth is the open-loop bicycle's own low-speed limit only approximately:
    # its v_y error is finite and below the truth's v_y range
    assert all(np.isfinite(r["rmse_vy"]) for r in res)
    (d / "spec.toml").write_text(spec_text('"nope:bmw_320i"'))
    code, o, err = campaign("campaign", d / "spec.toml", "--out", d / "run2", "--plugin",
                            d / "ax_campaign_obs.py", "--engine", "serial")
    assert code == 2 and "unknown plant 'nope'" in err and "kinematic" in err, err


def test_shipped_specs_load_and_the_small_one_runs(tmp_path):
    """Catches a README campaign command naming a spec the repository does not ship, or a
    shipped spec that no longer validates (the larger one is only checked, the small one
    run)."""
    from vehicle_observers.campaign import load_spec, read_results, run

    readme = (ROOT / "README.md").read_text()
    for name in ("small", "large"):
        p = ROOT / "data" / "campaigns" / f"{name}.toml"
        assert f"data/campaigns/{name}.toml" in readme
        s = load_spec(p)
        assert s.n_tasks == {"small": 24, "large": 4800}[name], s.summary()
    res = run(ROOT / "data" / "campaigns" / "small.toml", tmp_path / "small", engine="serial",
              progress=False)
    assert res.run_now == 24 and res.failed == 0
    assert len(read_results(tmp_path / "small")) == 24


#: the plug-in of PLUGIN with an overflow in its step (a RuntimeWarning at every step; the
#: estimate itself stays finite)
WARNING_PLUGIN = AX_PLUGIN.format(name="ax-vy-warns").replace(
    "+ 0.0 * ax)", "+ 0.0 * ax + 0.0 * float(np.float64(1e308) * 10.0 > 0.0))")


def test_dask_campaign_with_a_plugin_records_warnings_and_uncertainty(tmp_path):
    """Catches: a Dask campaign that cannot run a plug-in estimator loaded from a ``.py``
    path (its workers do not import it), warnings silenced instead of recorded in the rows
    (the overflowing plug-in must show RuntimeWarnings, one per step, counted the same on
    both engines: the rows are compared bit for bit), a report that leaves them out, and
    coverage / NEES written as NaN for an estimator without a standard deviation (the
    report must say n/a) or missing for one that has it (``ekf``: pooled over the samples,
    recomputed here from the rows)."""
    pytest.importorskip("distributed")
    from campaignkit import TINY
    from vehicle_observers.campaign import read_results, report, run

    (tmp_path / "ax_warn_obs.py").write_text(WARNING_PLUGIN)
    spec = {**TINY, "name": "plugin-dask", "estimators": ["ax-vy-warns", "ekf"],
            "repetitions": 1, "references": ["open-loop-linear"], "errors": None,
            "truth": {"plants": ["lpv:yacine2015"],
                      "manoeuvres": [{"name": "slalom", "duration": 4.0, "vx": 12.0}]},
            "sensors": {"distribution": "uniform", "std": {"vx": 0.0}, "bias": [{}]},
            "lmi_map": None}
    spec = {k: v for k, v in spec.items() if v is not None}
    plug = (str(tmp_path / "ax_warn_obs.py"),)
    run(spec, tmp_path / "serial", engine="serial", progress=False, plugins=plug)
    run(spec, tmp_path / "dask", engine="dask", workers=1, progress=False, plugins=plug)
    a, b = read_results(tmp_path / "serial"), read_results(tmp_path / "dask")
    assert same_bits(a, b) == []
    rows = a.to_pylist()
    assert all(r["ok"] for r in rows), [r["error"] for r in rows if not r["ok"]]
    warn = [r for r in rows if r["estimator"] == "ax-vy-warns"]
    assert warn and all(r["warnings"] > 100 for r in warn)
    kinds = json.loads(warn[0]["warning_kinds"])
    assert list(kinds) == ["RuntimeWarning"] and "overflow" in kinds["RuntimeWarning"]["first"]
    assert all(r["warnings"] == 0 for r in rows if r["estimator"] != "ax-vy-warns")
    t = report.tables(tmp_path / "serial")
    w = {r["estimator"]: r for r in t["warnings"]}
    assert set(w) == {"ax-vy-warns"} and w["ax-vy-warns"]["count"] == sum(r["warnings"]
                                                                          for r in warn)
    u = {r["estimator"]: r for r in t["uncertainty"]}
    assert u["ax-vy-warns"]["coverage_2sigma"] == report.NA == u["ax-vy-warns"]["mean_nees"]
    assert u["open-loop-linear"]["mean_nees"] == report.NA
    ekf = [r for r in rows if r["estimator"] == "ekf"]
    n = np.array([r["samples"] for r in ekf], float)
    cov = np.array([r["coverage_vy"] for r in ekf])
    assert np.all((cov >= 0) & (cov <= 1))
    assert u["ekf"]["coverage_2sigma"] == pytest.approx(np.sum(cov * n) / n.sum(), rel=1e-12)
    assert u["ekf"]["mean_nees"] == pytest.approx(
        np.sum([r["nees_vy"] for r in ekf] * n) / n.sum(), rel=1e-12)

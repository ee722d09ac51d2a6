"""Notebook 08 (robustness campaigns), quick mode: determinism, the interval observers'
guarantee, the LMI map against the analytic Metzler bound, the exercises' solutions, computed
verdicts."""

from __future__ import annotations

import nbformat
import pytest
from vehicle_observers.data.logs import repo_root
from vehicle_observers.models.vehicle import load_vehicle

pytestmark = [pytest.mark.notebook, pytest.mark.xdist_group("nb08")]

NB = "08_robustness"


@pytest.fixture(scope="module")
def m(run_notebook):
    return run_notebook(NB)


def _claims(m):
    return {c["item"]: c for c in m["_doc"]["claims"]}


def test_live_campaign_is_the_same_on_one_process_and_two_workers(m):
    assert m["live_identical"] == 1 and m["live_workers"] == 2
    assert m["live_tasks"] == 64 and m["live_failed"] == 8
    assert _claims(m)["rows independent of where and in which order tasks ran"]["verdict"] == \
        "reproduced"


def test_interval_guarantee_holds_where_assumed(m):
    assert m["guaranteed_runs"] >= 2 and m["guaranteed_enclosure_min"] == 1.0
    c = _claims(m)["enclosure 100 % wherever the plant is inside the stiffness box"]
    assert c["verdict"] == "reproduced"
    assert c["proves_little"] == (m["guaranteed_runs"] < 10)


def test_lmi_map_against_the_metzler_bound(m):
    y = load_vehicle("yacine2015")
    cf, cr = y.params.tire_f.cornering_stiffness, y.params.tire_r.cornering_stiffness
    bound = (cr * y.params.a_r - cf * y.params.a_f) / (cr * y.params.a_r + cf * y.params.a_f)
    assert m["lmi_yacine2015_metzler_bound"] == pytest.approx(bound, rel=1e-3)
    assert m["exercise_metzler_bound_by_hand"] == pytest.approx(bound, rel=1e-3)
    assert bound - m["lmi_rel_step"] < m["lmi_yacine_k0_max_feasible_rel"] <= bound
    # kappa = 0 certifies the BMW only below its (small) Metzler bound; kappa = 0.1 far beyond
    assert m["lmi_bmw_320i_metzler_bound"] < 0.02
    assert m["lmi.bmw_320i.k0.1.5-40.max_feasible_rel"] > 5 * m["lmi_bmw_320i_metzler_bound"]
    v = _claims(m)
    assert v["Theorem 2 without a change of coordinates: the Metzler bound"]["verdict"] == "reproduced"
    assert v["the change of coordinates certifies the BMW beyond the Metzler bound"]["verdict"] == \
        "reproduced"


def test_failures_and_regions(m):
    assert m["failure_rate.interval-ifqir2017"] == 0.5
    assert all(m[f"failure_rate.{e}"] == 0.0 for e in ("ekf", "rts", "interval-coordinates",
                                                        "open-loop-linear", "linear-kf"))
    # on its own model the open loop is the truth up to RK4 vs Euler and input noise
    assert m["lpv_nominal_best_ratio_open_loop"] > 1
    v = _claims(m)["multi-body plant, exact vehicle file: best observer <= 0.8 x open loop"]
    want = "reproduced" if m["multibody_nominal_best_ratio_open_loop"] <= 0.8 else (
        "partly" if m["multibody_nominal_best_ratio_open_loop"] < 1 else "differs")
    assert v["verdict"] == want


def test_cli_exercise(m):
    assert m["exercise_first_run_now"] == 64 and m["exercise_second_run_now"] == 0
    assert m["exercise_other_spec_exit"] == 2


def test_claims_and_files(m):
    doc = m["_doc"]
    assert len(doc["claims"]) == 8
    for f in ("error_effect_multibody.png", "error_effect_lpv.png", "conservatism_map.png",
              "lmi_feasibility.png", "failures.png"):
        assert (m["_dir"] / f).exists()


def test_notebook_teaches():
    nb = nbformat.read(str(repo_root() / "notebooks" / f"{NB}.ipynb"), as_version=4)
    src = [c.source for c in nb.cells]
    assert "What you will learn" in src[0] and len(src[0].split()) < 300
    assert sum("knobs" in c.metadata.get("tags", []) for c in nb.cells) == 1
    ex = [s for s in src if s.startswith("**Exercise")]
    sol = [s for s in src if s.startswith("**Solution")]
    assert len(ex) == 2 and len(sol) == 2
    assert any(s.startswith("## Appendix") for s in src)

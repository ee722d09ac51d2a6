"""Section 01 executed in quick mode: the report's metrics and verdicts asserted against theory
and the papers, the lesson's cells (stubs not attempted, the numpy loop equal to the compiled
one) and the solutions (every checker says correct).

Exactness: the TS forms are algebraically identical to the nonlinear models inside the
sector, so the only differences are floating-point round-off (<= 1e-9 relative is the
bar; the observed values are ~1e-14). Revs numbers are for the quick-mode 100 s segment of
the log (150-250 s): friction identified on 150-200 s, fit judged on 200-250 s.
"""

import re

import nbformat
import numpy as np
import pytest
from vehicle_observers.data.scenarios import NOISE_STD
from vehicle_observers_papers.yacine_2015 import constants as Y

pytestmark = [pytest.mark.notebook, pytest.mark.xdist_group("nb01")]


@pytest.fixture(scope="module")
def m(run_notebook):
    return run_notebook("01_ts_exactness_report")


def _claim(m, item_start: str) -> dict:
    (c,) = [c for c in m["_doc"]["claims"] if c["item"].startswith(item_start)]
    return c


def test_sector_bounds_match_paper(m):
    """The chosen Pacejka tyres give the printed sector (Sec. IV) over 8 deg; catches a tyre
    built from the wrong bound or a slip range in degrees where radians are due."""
    assert m["sector_front_from_tyre"] == pytest.approx([3.3e4, 4.2e4], rel=1e-9)
    assert m["sector_rear_from_tyre"] == pytest.approx([3.3e4, 4.9e4], rel=1e-9)
    # the Pacejka slope at zero slip B C D is the upper bound (closed form of (16) at 0)
    B, C, D, _ = m["pacejka_front_BCDE"]
    assert B * C * D == pytest.approx(4.2e4, rel=1e-3)


def test_exactness_inside_sector(m):
    """Round-off agreement on a run that uses most of the 8 deg sector (a wrong premise factor
    gives differences of order 1e-2 and more, see tests/papers/test_nb01_ts_exactness.py)."""
    assert m["yacine_max_rel_rhs_diff"] <= 1e-9
    assert m["yacine_max_rel_traj_diff"] <= 1e-9
    assert m["yacine_convex_sum_residual"] <= 1e-12
    assert 6.0 < m["yacine_exactness_max_slip_deg"] <= 8.0  # the run uses most of the sector
    assert m["bicycle_max_rel_rhs_diff"] <= 1e-9
    assert m["bicycle_max_rel_traj_diff"] <= 1e-9
    c = _claim(m, "Sec. III-B")
    assert c["verdict"] == "reproduced" and c["proves_little"] is False  # slip >= 6 of 8 deg
    assert _claim(m, "Fig. 2 (TS states")["verdict"] == "reproduced"


def test_bicycle_premise_bounds_hold_their_closed_forms(m):
    """z1 = (g/p) sin(x3)/x3 <= g/p = 16.35 (at x3 = 0, where the run starts); z3 = (c/p) cos(x3) v
    <= c v / p = 8.33; the bounds are the run's ranges widened by 1 %. Catches a premise with a
    wrong factor (g, p, c or v)."""
    (z1lo, z1hi), _, (z3lo, z3hi) = m["bicycle_premise_bounds"]
    assert z1hi == pytest.approx(9.81 / 0.6 + 0.01 * (z1hi - z1lo) / 1.02, rel=1e-3)
    assert z3hi == pytest.approx(0.5 * 10 / 0.6 + 0.01 * (z3hi - z3lo) / 1.02, rel=1e-3)


def test_outside_sector_is_detected_and_not_exact(m):
    """Past 8 deg the clipped blend is the line M_f2 alpha above the saturating tyre: not exact."""
    assert m["outside_max_slip_deg"] > 8.0
    assert m["outside_share"] > 0.05
    assert m["outside_max_rel_diff_clipped"] > 0.1  # clipped weights lose exactness


def test_fig1_on_the_paper_car_is_limited_by_the_gyro_noise(m):
    """Fig. 1 graded on the paper's car and sensors: a model equal to the car leaves, against the
    gyro, a residual whose RMS is the gyro's noise standard deviation (scenarios.NOISE_STD, 0.002
    rad/s); the TS v_y follows the truth to a few mm/s (only the small-angle slip (4) differs),
    while the linear bicycle (zero-slip stiffnesses) drifts where the tyres leave their linear
    range. Catches a TS model with a wrong premise factor or sign (its residual would exceed the
    noise) and a Fig. 1 graded on a fitted parameter."""
    assert m["fig1_ts_yaw_rmse"] == pytest.approx(NOISE_STD["yaw_rate"], rel=0.1)
    assert m["fig1_ts_vy_rmse"] < 0.005
    assert m["fig1_lin_vy_rmse"] > 3 * m["fig1_ts_vy_rmse"]
    assert m["fig1_ts_out_of_bounds"] < 10          # only the first samples at 0.2 m/s (noisy v_x)
    # the mismatched car: the models keep the paper's car, so their residual exceeds the noise
    assert m["fig1_mm_ts_yaw_rmse"] > 3 * NOISE_STD["yaw_rate"]
    c = _claim(m, "Fig. 1 (TS model")
    assert c["kind"] == "paper" and c["verdict"] == "reproduced" and c["proves_little"] is False
    assert c["value"] == pytest.approx(m["fig1_ts_yaw_corr"], abs=1e-4)


def test_revs_row_is_a_diagnostic_judged_on_the_held_out_half(m):
    """The Revs 250 LM log is another car: a diagnostic, identified on the first half and judged
    on the second. Relaxation (0.1 m at 10-50 m/s: < 10 ms) barely changes the yaw rate, and the
    TS form integrates to the nonlinear (13) trajectory with relaxation to round-off."""
    assert m["revs_duration"] == pytest.approx(100.0, abs=0.1)
    assert m["revs_t_split"] == pytest.approx(200.0, abs=0.1)   # half of 150..250 s
    assert m["revs_ts_out_of_bounds"] == 0
    assert m["revs_ts_vs_nl_rel"] < 1e-9
    assert 1.0 <= m["revs_mu"] <= 3.0     # the search interval of identify_friction
    assert abs(m["revs_heldout_ts_yaw_rmse"] - m["revs_heldout_nl_yaw_rmse"]) < 0.005
    assert _claim(m, "Fig. 1 on a real log")["kind"] == "diagnostic"
    assert _claim(m, "open-loop linear bicycle")["verdict"] != "reproduced"  # needs the 550 s run


def test_claims_use_rules_and_keep_the_ichalal_item(m):
    """Ichalal Fig. 2 keeps its item text (notebook 04 refers to it as the primary row)."""
    assert all(c["rule"] != "(hand-written verdict)" for c in m["_doc"]["claims"])
    assert {c["item"] for c in m["_doc"]["claims"]} == {
        "Sec. III-B: TS model (24) exact on the sector",
        "Fig. 1 (TS model with relaxation fits measurements)",
        "Fig. 1 on a real log of another car (Revs 250 LM)",
        "open-loop linear bicycle check", "Fig. 2 (TS states equal nonlinear states)"}


def test_front_sector_at_8_deg_closed_form(m):
    """Independent evaluation of (16) with E = 0: f(a) = D sin(C atan(B a)) / a at 8 deg is the
    lower bound the report records."""
    B, C, D, E = m["pacejka_front_BCDE"]
    assert E == 0.0
    a = np.radians(8.0)
    assert m["sector_front_from_tyre"][0] == pytest.approx(D * np.sin(C * np.arctan(B * a)) / a, rel=1e-3)
    assert Y.tire_f.B == pytest.approx(B, rel=1e-3)


# ------------------------------------------------------------------ lesson and solutions -----

def _outputs(path, tag=None):
    nb = nbformat.read(str(path), as_version=4)
    cells = [c for c in nb.cells
             if c.cell_type == "code" and (tag is None or tag in c.metadata.get("tags", []))]
    return cells


def _html(cell):
    return "".join(o.get("data", {}).get("text/html", "") for o in cell.get("outputs", []))


def _text(cell):
    return "".join(o.get("text", "") for o in cell.get("outputs", []) if o.get("output_type") == "stream")


def test_lesson_stubs_are_not_attempted_and_hold_no_solution(run_notebook):
    """Four exercises, each a stub its checker reports 'not attempted'; no solution cell in the
    lesson (the worked solutions live in the solutions notebook)."""
    les = run_notebook("01_ts_exactness")
    stubs = _outputs(les["_executed"], "exercise")
    assert len(stubs) == 4 and not _outputs(les["_executed"], "solution")
    for k, st in enumerate(stubs, start=1):
        assert f"Exercise 01.{k}" in _html(st) and 'data-status="not attempted"' in _html(st)
        assert "..." in st.source and f"ex.check_{k}(" in st.source


def test_lesson_numpy_loop_lands_on_the_compiled_trajectory(run_notebook):
    """The lesson's RK4 loop of the TS form (24) in plain numpy and the compiled loop agree to
    round-off per state (a loop holding the inputs differently would differ by 1e-4 and more)."""
    les = run_notebook("01_ts_exactness")
    (cell,) = [c for c in _outputs(les["_executed"]) if "numpy loop vs compiled" in c.source]
    gaps = [float(g) for g in _text(cell).split(":")[-1].split(",")]
    assert len(gaps) == 4 and max(gaps) < 1e-12


def test_solutions_are_correct(run_notebook):
    """Every checker call of the solutions notebook answers 'correct' (the checkers compute their
    answers independently: tests/papers/test_yacine2015_exercises_01.py)."""
    sol = run_notebook("01_ts_exactness_solutions")
    statuses = [s for c in _outputs(sol["_executed"])
                for s in re.findall(r'data-status="([a-z ]+)"', _html(c))]
    assert statuses == ["correct"] * 4

"""The regeneration check flags what changed beyond the declared precision, and only that."""

import json

from vehicle_observers.results.check import compare_dirs, compare_doc, drift_table


def _doc(metrics, verdicts=("reproduced",)):
    return {"notebook": "99_x", "metrics": metrics,
            "claims": [{"paper": "P", "item": f"i{k}", "verdict": v} for k, v in enumerate(verdicts)]}


def m(value, **kw):
    return {"value": value, "digits": kw.pop("digits", 4), **kw}


def test_identical_documents_have_no_drift():
    d = _doc({"a": m(83.72), "v": m([1.0, 2.5])})
    assert compare_doc(d, d) == []


def test_one_unit_in_the_last_stored_digit_is_within_tolerance():
    dr = compare_doc(_doc({"a": m(83.72)}), _doc({"a": m(83.73)}))
    assert len(dr) == 1 and dr[0].ok


def test_a_larger_move_is_flagged_unless_a_tolerance_is_declared():
    dr = compare_doc(_doc({"a": m(83.72)}), _doc({"a": m(84.61)}))
    assert len(dr) == 1 and not dr[0].ok
    tol = m(83.72, rtol=0.02, why="LMI solution")
    assert compare_doc(_doc({"a": tol}), _doc({"a": m(84.61)}))[0].ok
    assert not compare_doc(_doc({"a": tol}), _doc({"a": m(86.0)}))[0].ok


def test_vectors_compare_elementwise():
    assert compare_doc(_doc({"v": m([1.0, 2.0])}), _doc({"v": m([1.0, 2.001])}))[0].ok
    assert not compare_doc(_doc({"v": m([1.0, 2.0])}), _doc({"v": m([1.0, 2.1])}))[0].ok
    assert not compare_doc(_doc({"v": m([1.0, 2.0])}), _doc({"v": m([1.0])}))[0].ok


def test_verdict_change_and_missing_metric_or_claim_are_flagged():
    dr = compare_doc(_doc({"a": m(1.0)}, ("reproduced",)), _doc({"a": m(1.0)}, ("partly",)))
    assert [d.ok for d in dr] == [False] and "identical verdict" in dr[0].tolerance
    dr = compare_doc(_doc({"a": m(1.0), "b": m(2.0)}), _doc({"a": m(1.0)}))
    assert len(dr) == 1 and not dr[0].ok and dr[0].regenerated == "(absent)"
    dr = compare_doc(_doc({"a": m(1.0)}, ("reproduced", "differs")), _doc({"a": m(1.0)}))
    assert len(dr) == 1 and not dr[0].ok


def test_compare_dirs_and_table(tmp_path):
    for root, val in ((tmp_path / "c", 1.0), (tmp_path / "r", 1.5)):
        (root / "99_x").mkdir(parents=True)
        (root / "99_x" / "metrics.json").write_text(json.dumps(_doc({"a": m(val)})))
    dr = compare_dirs(tmp_path / "c", tmp_path / "r")
    assert len(dr) == 1 and not dr[0].ok
    assert "**NO**" in drift_table(dr)
    assert drift_table([]).startswith("no drift")

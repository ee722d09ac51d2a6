"""The LMI-layer bench's plumbing (no timing is asserted: wall-clock numbers belong to
``make bench``): the compiled map and the reference map decide the same points, the file
says what was measured, bad input exits 2."""

import json

from vehicle_observers.bench import lmi_layer


def test_compiled_and_reference_maps_agree_and_file_is_written(tmp_path, capsys):
    """Both parametric maps of a small grid count the same certified and infeasible points
    (catches a compiled map that drops or invents feasible points), and the JSON holds the
    split of the compiled map's time."""
    out = tmp_path / "t.json"
    assert lmi_layer.main(["--points", "12", "--repeat", "1", "--dmvt-rows", "0",
                           "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    ref, pm = doc["parametric_map_reference"], doc["parametric_map"]
    assert (ref["certified"], ref["infeasible"]) == (pm["certified"], pm["infeasible"])
    assert ref["points"] == pm["points"] >= 12
    assert pm["certified"] > 0
    for k in ("build_s", "solve_s", "certify_s", "solver_s", "solver_wall_s"):
        assert pm[k] > 0
    assert "disagree" not in capsys.readouterr().err
    # each bisection timed both ways reaches the same optimum through as many solver calls
    # (catches a compiled bisection that skips or adds steps, or a clock that misses calls)
    assert len(doc["maximise_decay"]) == len(lmi_layer.bisection_designs())
    for row in doc["maximise_decay"].values():
        b, a = row["before"], row["after"]
        assert b["optimum"] == a["optimum"] and b["status"] == a["status"] == "certified"
        assert b["solver_calls"] == a["solver_calls"] >= 10
        assert a["solver_wall_s"] > 0 and a["total_s"] > a["solver_wall_s"]
    # notebook 04's radius bisections are skipped here (their sweep costs seconds; the two
    # paths are compared in tests/observers/test_dmvt_compiled.py)
    assert doc["disk_bisection_04"] is None


def test_bad_points_exit_2(capsys):
    """Too few points, or no timed run, is refused in one line with exit status 2."""
    assert lmi_layer.main(["--points", "2"]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert lmi_layer.main(["--repeat", "0"]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert lmi_layer.main(["--dmvt-rows", "9"]) == 2
    assert capsys.readouterr().err.count("\n") == 1

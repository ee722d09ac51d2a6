"""The checks the Lab tests apply, on hand-made inputs (no server, no browser)."""

from labkit import lab_problems, teaching_problems


def _cells(*spec):
    return [{"cell_type": t, "source": s, "tags": tags} for t, s, tags in spec]


def test_teaching_cells_found():
    cells = _cells(("code", "alpha = 0.5  # decay rate", ["knobs"]),
                   ("markdown", "**Exercise 1.** Halve alpha.", []),
                   ("markdown", "**Solution 1.** The bound doubles.", []),
                   ("markdown", "  **Exercise 2.** Double R.", []),
                   ("markdown", "**Solution 2.** ...", []))
    assert teaching_problems("02", cells) == []


def test_missing_teaching_cells_reported():
    cells = _cells(("code", "alpha = 0.5", []), ("markdown", "Exercise 1: no bold", []),
                   ("markdown", "**Exercise 2.** Double R.", []))
    assert teaching_problems("02", cells) == [
        "02: 0 cells tagged 'knobs' (want exactly 1)",
        "02: 1 exercises (want at least 2 markdown cells '**Exercise N.**')",
        "02: 0 solutions for 1 exercises ('**Solution N.**')"]
    two_knobs = _cells(("code", "a = 1", ["knobs"]), ("code", "b = 1", ["knobs", "x"]))
    assert teaching_problems("03", two_knobs)[0] == "03: 2 cells tagged 'knobs' (want exactly 1)"


def test_lab_problems():
    assert lab_problems("04", [], 3, ["a", "b"]) == []
    assert lab_problems("04", ["cell 3: ValueError: x"], 1, ["a", "b"], ["Error displaying widget"]) == [
        "04: error output: cell 3: ValueError: x",
        "04: 1 rendered images for 2 saved figures (a, b)",
        "04: widget error placeholder: Error displaying widget"]
    assert lab_problems("04", [], 0, None) == [
        "04: wrote no metrics.json (the run did not reach rep.write())"]

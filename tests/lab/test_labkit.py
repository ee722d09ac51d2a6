"""The checks the Lab tests apply, on hand-made inputs (no server, no browser)."""

from labkit import lab_problems, teaching_problems


def _cells(*spec):
    return [{"cell_type": t, "source": s, "tags": tags} for t, s, tags in spec]


def test_teaching_cells_found():
    cells = _cells(("code", "alpha = 0.5  # decay rate", ["knobs"]),
                   ("markdown", "**Try this.** Halve alpha: the bound doubles.", []),
                   ("code", "T.animation(fig, update, 30)", ["animation"]))
    assert teaching_problems("02", cells) == []
    moved = {"changed": True, "value": "0.12", "before": 10, "after": 12}
    assert teaching_problems("03_interval_observer", cells, moved) == []


def test_missing_teaching_cells_reported():
    cells = _cells(("code", "alpha = 0.5", []), ("markdown", "Try this: not bold", []))
    assert teaching_problems("02", cells) == [
        "02: 0 cells tagged 'knobs' (want exactly 1)",
        "02: no '**Try this.**' prompt under a figure",
        "02: no cell tagged 'animation' (an HTML5 animation of the observer)"]
    two_knobs = _cells(("code", "a = 1", ["knobs"]), ("code", "b = 1", ["knobs", "x"]))
    assert teaching_problems("03", two_knobs)[0] == "03: 2 cells tagged 'knobs' (want exactly 1)"


def test_a_slider_notebook_needs_a_live_figure_that_changes():
    cells = _cells(("code", "a = 1", ["knobs"]), ("markdown", "**Try this.** x", []),
                   ("code", "anim", ["animation"]))
    assert teaching_problems("04_bicycle_dmvt", cells, None) == [
        "04_bicycle_dmvt: no live figure (slider above a redrawn image) in the page"]
    stuck = {"changed": False, "value": "2.00", "before": 10, "after": 10}
    assert teaching_problems("05_sliding_mode_observers", cells, stuck) == [
        "05_sliding_mode_observers: moving the slider to 2.00 did not change the figure"]


def test_lab_problems():
    assert lab_problems("04", [], 3, ["a", "b"]) == []
    assert lab_problems("04", ["cell 3: ValueError: x"], 1, ["a", "b"], ["Error displaying widget"]) == [
        "04: error output: cell 3: ValueError: x",
        "04: 1 rendered images for 2 saved figures (a, b)",
        "04: widget error placeholder: Error displaying widget"]
    assert lab_problems("04", [], 0, None) == [
        "04: saved no figure record (metrics.json of a report, figure_data.json of a lesson): the run "
        "did not get that far"]


def test_xdist_groups_share_a_worker(tmp_path):
    """``make test`` runs ``-n 2 --dist loadgroup``: tests of one ``xdist_group`` (the Lab
    server's, a notebook's) must run on one worker, or the server and the notebooks are started
    twice (pytest 9.2 with xdist 3.8 silently drops the groups; pytest is pinned to 9.1)."""
    import subprocess
    import sys

    (tmp_path / "test_a.py").write_text(
        "import pytest\npytestmark = pytest.mark.xdist_group('g1')\n"
        + "".join(f"def test_{i}():\n    pass\n" for i in range(4)))
    (tmp_path / "test_b.py").write_text(
        "import pytest\n@pytest.mark.parametrize('x', [pytest.param(1, marks="
        "pytest.mark.xdist_group('g1')), 2, 3])\ndef test_b(x):\n    pass\n")
    out = subprocess.run([sys.executable, "-m", "pytest", "-n", "2", "--dist", "loadgroup", "-v",
                          "-p", "no:cacheprovider", "-p", "no:randomly", str(tmp_path)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300).stdout
    workers = {ln.split()[0] for ln in out.splitlines() if "PASSED" in ln and "@g1" in ln}
    grouped = [ln for ln in out.splitlines() if "PASSED" in ln and "@g1" in ln]
    assert len(grouped) == 5 and len(workers) == 1, out[-2000:]

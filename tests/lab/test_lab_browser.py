"""The notebooks in a real browser: JupyterLab (one server, ``make lab``) opened in headless
Chromium, every notebook (quick parameters injected) run with Run > Run All Cells.

Asserted per notebook: the project's kernel ran it, no cell has an error output, at least as many
rendered images as figures saved (metrics.json "files"), no widget error placeholder, and the
teaching is there: one cell tagged ``knobs``, a ``**Try this.**`` prompt, an animation, real
exercises (stub, checker, hidden solution), no warning or object repr in the page, and in the
notebooks with a live figure, moving its slider (keyboard, as a user) changes the image. A
screenshot per notebook goes to ``build/screenshots/`` (and ``<name>-slider.png`` after the
move).

A tiny synthetic notebook that saves a figure without showing it must fail the same check (and
its twin that shows it must pass): the test can fail.

Chromium is the system one (Debian package ``chromium``), driven by Playwright over the DevTools
protocol; without it the module is skipped with one line saying how to enable it
(``VO_REQUIRE_BROWSER=1``, set by ``.ci/run``, turns that skip into a failure).
"""

from __future__ import annotations

import nbformat
import pytest
from labkit import (
    KERNEL,
    ROOT,
    cells_notebook,
    chromium_path,
    require_browser,
    run_in_lab,
    start_chromium,
    stop,
    teaching_problems,
)
from nbformat.v4 import new_code_cell, new_notebook
from test_executed_notebooks import exercise_problems, output_problems

require_browser("JupyterLab browser test")

from vehicle_observers.results import pipeline  # noqa: E402

NOTEBOOKS = [p.stem for p in pipeline.notebooks(kinds=("lesson",))]   # what a student opens

pytestmark = [pytest.mark.xdist_group("lab"), pytest.mark.slow]
SHOTS = ROOT / "build" / "screenshots"

@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """A Playwright browser context on the system Chromium (own process, ended by its pid)."""
    from playwright.sync_api import sync_playwright

    proc, cdp = start_chromium(chromium_path(), tmp_path_factory.mktemp("chromium"))
    try:
        with sync_playwright() as p:
            b = p.chromium.connect_over_cdp(cdp)
            yield b.contexts[0]
            b.close()
    finally:
        stop(proc)


@pytest.fixture(scope="module")
def lab_run(lab, browser):
    """``lab_run(name)`` -> :class:`labkit.LabRun`, one run per notebook."""
    server, figures = lab
    cache = {}

    def _run(name):
        if name not in cache:
            cache[name] = run_in_lab(browser, server, name, figures, SHOTS)
        return cache[name]

    return _run


def _synthetic(path, show: bool):
    """Saves one figure with :class:`Report`; ``show=False`` keeps it off the page."""
    nb = new_notebook()
    nb.metadata["kernelspec"] = {"name": KERNEL, "display_name": "Python (vehicle-observers)",
                                 "language": "python"}
    nb.cells = [new_code_cell("import matplotlib.pyplot as plt\n"
                              "from vehicle_observers.results.reporting import Report\n"
                              f"rep = Report({path.stem!r}, {str(path.parent / 'figures')!r}, "
                              f"show={show})\n"
                              "fig, ax = plt.subplots(figsize=(3, 2))\nax.plot([0, 1], [0, 1])\n"
                              "rep.savefig(fig, 'fig1')\nrep.write();")]
    nbformat.write(nb, str(path))


@pytest.mark.parametrize("show", [True, False], ids=["shown", "hidden"])
def test_check_fails_when_a_saved_figure_is_not_shown(lab, browser, show):
    server, _ = lab
    name = f"zz_synthetic_{'shown' if show else 'hidden'}"
    _synthetic(server.root_dir / f"{name}.ipynb", show)
    run = run_in_lab(browser, server, name, server.root_dir / "figures", SHOTS)
    assert run.figures == ["fig1"] and run.errors == []
    if show:
        assert run.images == 1 and run.problems() == []
    else:
        assert run.images == 0
        assert run.problems() == [f"{name}: 0 rendered images for 1 saved figures (fig1)"]


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_notebook_runs_in_lab_and_shows_its_figures(name, lab_run):
    run = lab_run(name)
    assert run.kernel == KERNEL
    assert run.screenshot.exists()
    problems = run.problems()
    assert not problems, "; ".join(problems) + f" (screenshot: {run.screenshot})"


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_notebook_teaches_in_lab(name, lab_run):
    """Knobs, a live figure that redraws when its slider moves, an animation, real exercises,
    and nothing a student should not see (warnings, object reprs), all in the page."""
    run = lab_run(name)
    unrendered = [i for i, c in enumerate(run.cells) if not c["rendered"]]
    assert not unrendered, f"{name}: markdown cells {unrendered} not rendered in the page"
    nb = cells_notebook(run.cells)
    problems = (teaching_problems(name, run.cells, run.slider) + exercise_problems(nb)
                + output_problems(nb, []))
    assert not problems, "; ".join(problems) + f" (screenshots: {run.screenshot.parent})"


def _live_notebook(path, redraws: bool):
    """A live figure whose drawing uses the slider's value (``redraws``) or ignores it."""
    nb = new_notebook()
    nb.metadata["kernelspec"] = {"name": KERNEL, "display_name": "Python (vehicle-observers)",
                                 "language": "python"}
    slope = "k" if redraws else "1.0"
    nb.cells = [new_code_cell("import matplotlib.pyplot as plt\n"
                              "from vehicle_observers.results import teaching as T\n"
                              "def draw(k):\n    fig, ax = plt.subplots(figsize=(3, 2))\n"
                              f"    ax.plot([0, 1], [0, {slope}])\n    ax.set_ylim(0, 3)\n"
                              "    return fig\n"
                              "T.live_figure(draw, k=T.slider(1.0, 0.0, 3.0, 0.5, 'slope'))")]
    nbformat.write(nb, str(path))


@pytest.mark.parametrize("redraws", [True, False], ids=["redraws", "ignores"])
def test_slider_check_fails_when_the_figure_ignores_the_slider(lab, browser, redraws):
    server, _ = lab
    name = f"zz_live_{'redraws' if redraws else 'ignores'}"
    _live_notebook(server.root_dir / f"{name}.ipynb", redraws)
    run = run_in_lab(browser, server, name, server.root_dir / "figures", SHOTS)
    assert run.slider is not None and run.slider["value"] == "1.50"
    assert run.slider["changed"] is redraws
    problems = teaching_problems(name, run.cells, run.slider)
    assert any("did not change the figure" in p for p in problems) is (not redraws)

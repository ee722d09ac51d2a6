"""Executed notebooks show what they save.

Every executed notebook (papermill, quick and full mode) holds at least one image output per
figure it saves (the ``.png`` files listed in its ``metrics.json`` "files") and no output that is
a bare path (``PosixPath('.../fig.png')``) or a numpy scalar repr (``np.float64(0.28)``).

- quick mode: the copies the notebook tests execute (``run_notebook`` in ``conftest.py``, shared
  per test session, so each notebook runs once);
- full mode: the copies of the last ``make figures`` / ``make html`` in ``build/notebooks/``,
  against the committed ``figures/<notebook>/metrics.json``; skipped with the reason when there
  is no copy or it was executed from an older version of the notebook.

They also hold no warning or log text on stderr and no object repr as a cell's result, and
every exercise is real (:func:`exercise_problems`: a stub its checker finds empty, then a hidden
solution it finds correct, at least three per notebook).

The checker itself is tested on small synthetic notebooks (one that saves a figure without
showing it must fail).
"""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import nbformat
import pytest
from nbformat.v4 import new_code_cell, new_notebook, new_output
from vehicle_observers.data.logs import repo_root
from vehicle_observers.results import pipeline
from vehicle_observers.results.reporting import figure_checks_path

ROOT = repo_root()
NOTEBOOKS = [p.stem for p in pipeline.notebooks(ROOT, kinds=tuple(pipeline.NOTEBOOK_KINDS))]
FULL_BUILD = ROOT / "build" / "notebooks"

#: an output that is a path object or a lone file path
_PATH_RE = re.compile(r"^(?:(?:Posix|Windows|Pure\w*)?Path\(.*\)|'?(?:[\w.~-]*/)+[\w.-]+\.\w{2,4}'?)$")
#: a numpy scalar repr (numpy >= 2 prints ``np.float64(0.28)``)
_NP_SCALAR_RE = re.compile(r"\bnp\.(?:float|int|uint|complex|bool|longdouble|str_)\w*\(")

#: an object repr shown as a cell's result: a dataclass-like ``Name(field=...)``, a default
#: ``<module.Class object at 0x...>``, a raw numpy array or a dict dump
_REPR_RE = re.compile(r"^(?:[A-Z]\w*\(\w+=|<[\w.]+ object at 0x|array\(\[|\{['\"])")
#: the status line of :func:`vehicle_observers.results.teaching.check`
_STATUS_RE = re.compile(r'data-status="([a-z ]+)"')

#: notebooks that fail the check today: {(notebook, mode): reason}; strict, so an entry must go
#: as soon as its notebook is fixed
_KNOWN: dict[str, str] = {}
KNOWN_FAILURES: dict[tuple[str, str], str] = {
    (nb, mode): f"{nb}: {why}" for nb, why in _KNOWN.items() for mode in ("quick", "full")}


def saved_figures(metrics_json: Path) -> list[str]:
    """Figure names (PNG files without extension) a notebook's ``metrics.json`` lists."""
    files = json.loads(Path(metrics_json).read_text())["files"]
    return sorted(f[:-4] for f in files if f.endswith(".png"))


def _text(out, key="text/plain") -> str:
    if out.output_type == "stream":
        return "".join(out.text)
    v = out.get("data", {}).get(key, "")
    return "".join(v) if isinstance(v, list) else v


def output_problems(nb: nbformat.NotebookNode, figures: list[str],
                    figures_dir: Path | None = None) -> list[str]:
    """What an executed notebook does wrong, as one line per problem (empty when fine).

    ``figures``: names of the PNG figures the run saved; the notebook must hold at least as many
    ``image/png`` outputs. With ``figures_dir`` the message names the saved figures whose bytes
    appear in no image output."""
    problems, images = [], []
    for i, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        for out in cell.get("outputs", []):
            if out.output_type == "error":
                problems.append(f"cell {i}: error output {out.ename}: {out.evalue}")
                continue
            if "image/png" in out.get("data", {}):
                images.append(out.data["image/png"])
            rich = {"text/html", "image/png", "text/markdown", "text/latex"} & set(out.get("data", {}))
            text = _text(out).strip()
            if not text or (rich and out.output_type != "stream"):
                continue
            if out.output_type == "stream" and out.get("name") == "stderr":
                problems.append(f"cell {i}: warning or log text on stderr: {text[:80]!r}")
            elif _NP_SCALAR_RE.search(text):
                problems.append(f"cell {i}: numpy scalar repr in the output: {text[:80]!r}")
            elif out.output_type != "stream" and _REPR_RE.match(text):
                problems.append(f"cell {i}: object repr as the cell's output: {text[:80]!r}")
            elif out.output_type != "stream" and _PATH_RE.match(text):
                problems.append(f"cell {i}: output is a bare path: {text[:80]!r}")
            elif out.output_type == "stream" and _PATH_RE.match(text) and "\n" not in text:
                problems.append(f"cell {i}: printed a bare path: {text[:80]!r}")
    if len(images) < len(figures):
        msg = f"{len(images)} image outputs for {len(figures)} saved figures"
        if figures_dir is not None:
            shown = {"".join(b).replace("\n", "") for b in images}
            missing = [f for f in figures if (Path(figures_dir) / f"{f}.png").exists() and
                       base64.b64encode((Path(figures_dir) / f"{f}.png").read_bytes()).decode()
                       not in shown]
            msg += f"; not shown: {', '.join(missing) or '(cannot tell)'}"
        problems.append(msg)
    return problems


def _statuses(cell) -> list[str]:
    return [m for out in cell.get("outputs", [])
            for m in _STATUS_RE.findall(_text(out, "text/html"))]


def _exercise_starts(cells) -> list[int]:
    return [i for i, c in enumerate(cells) if c.cell_type == "markdown"
            and c.source.lstrip().startswith("**Exercise")]


def _block(cells, i):
    """The cells after cell ``i`` up to the next section heading or exercise."""
    block = []
    for c in cells[i + 1:]:
        if c.cell_type == "markdown" and (c.source.lstrip().startswith(("#", "**Exercise"))):
            break
        block.append(c)
    return block


def exercise_problems(nb: nbformat.NotebookNode, minimum: int = 3) -> list[str]:
    """What an executed lesson's exercises do wrong, one line per problem (empty when fine).

    An exercise is a markdown cell starting ``**Exercise N.**`` followed (before the next
    markdown cell that starts a section or an exercise) by one code cell tagged ``exercise``, a
    stub with ``# your code here`` whose checker said ``not attempted``
    (:func:`vehicle_observers.results.teaching.check`), and a markdown cell pointing to its
    ``**Solution and discussion:**`` in the section's solutions notebook. At least ``minimum``
    exercises, numbered in order; no solution in the lesson (no cell tagged ``solution``, no
    markdown solution), so Run All never executes one and the exported page never shows one."""
    problems = []
    cells = nb.cells
    starts = _exercise_starts(cells)
    if len(starts) < minimum:
        problems.append(f"{len(starts)} exercises (want at least {minimum} '**Exercise N.**' cells)")
    sol_cells = [i for i, c in enumerate(cells) if c.cell_type == "code"
                 and "solution" in c.metadata.get("tags", [])]
    if sol_cells:
        problems.append(f"cells {sol_cells}: solution code in the lesson (Run All would execute it; "
                        "it belongs in the solutions notebook)")
    shown = [i for i, c in enumerate(cells) if c.cell_type == "markdown"
             and c.source.lstrip().startswith("**Solution") and "solutions" not in c.source]
    if shown:
        problems.append(f"cells {shown}: a solution in plain sight (markdown '**Solution')")
    for n, i in enumerate(starts, 1):
        label = cells[i].source.lstrip()[:20].split(".**")[0].strip("* ")
        if label != f"Exercise {n}":
            problems.append(f"cell {i}: '{label}' is exercise number {n} in order")
        block = _block(cells, i)
        stubs = [c for c in block if c.cell_type == "code" and "exercise" in c.metadata.get("tags", [])]
        if len(stubs) != 1:
            problems.append(f"cell {i} ({label}): {len(stubs)} 'exercise' code cells after it (want one)")
            continue
        stub = stubs[0]
        if "# your code here" not in stub.source:
            problems.append(f"cell {i} ({label}): the stub has no '# your code here'")
        if _statuses(stub) != ["not attempted"]:
            problems.append(f"cell {i} ({label}): the stub's checker said {_statuses(stub)} "
                            f"(want ['not attempted'])")
        if not any(c.cell_type == "markdown" and "Solution and discussion" in c.source
                   and "solutions" in c.source for c in block):
            problems.append(f"cell {i} ({label}): no 'Solution and discussion' pointer to the "
                            "solutions notebook")
    return problems


def solution_problems(nb: nbformat.NotebookNode, exercises: int) -> list[str]:
    """What an executed solutions notebook does wrong: every exercise ``1..exercises`` of its
    lesson is solved by code that calls its checker (``check_N(``) and the checker says
    ``correct``."""
    problems = []
    for n in range(1, exercises + 1):
        cells = [c for c in nb.cells if c.cell_type == "code" and f"check_{n}(" in c.source]
        if not cells:
            problems.append(f"no worked solution of Exercise {n} (no call of check_{n})")
            continue
        st = [x for c in cells for x in _statuses(c)]
        if not st or st[-1] != "correct":
            problems.append(f"Exercise {n}: the solution's checker said {st} (want 'correct' last)")
    return problems


#: a lesson shows at most this many rows in one table (a figure and a two-line summary say more)
MAX_TABLE_ROWS = 12
_ROW_RE = re.compile(r"<tr\b", re.I)
_EMPTY_CELL_RE = re.compile(r"<td[^>]*>\s*(?:None|nan|NaN|-?inf)\s*</td>")


def lesson_output_problems(nb: nbformat.NotebookNode) -> list[str]:
    """Curated outputs of an executed lesson: no HTML table longer than
    :data:`MAX_TABLE_ROWS` body rows, no None/nan/inf cell, no dict or solver dump."""
    problems = []
    for i, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        for out in cell.get("outputs", []):
            page = _text(out, "text/html")
            for table in re.findall(r"<table\b.*?</table>", page, re.S | re.I):
                rows = len(_ROW_RE.findall(table)) - len(re.findall(r"<thead\b", table, re.I))
                if rows > MAX_TABLE_ROWS:
                    problems.append(f"cell {i}: a table of {rows} rows (at most {MAX_TABLE_ROWS})")
                if _EMPTY_CELL_RE.search(table):
                    problems.append(f"cell {i}: a table cell shows None/nan/inf")
            text = _text(out)
            if re.search(r"\b(?:OPTIMAL|optimal_inaccurate|solve time|objective \d)", text):
                problems.append(f"cell {i}: a solver dump in the output: {text[:60]!r}")
            if re.search(r"/tmp/|tmp[a-z0-9_]{6,}/", text):
                problems.append(f"cell {i}: a temporary path in the output")
    return problems


def code_sources(nb: nbformat.NotebookNode) -> list[str]:
    """Code cell sources without papermill's injected parameters (to compare versions)."""
    return [c.source for c in nb.cells if c.cell_type == "code"
            and "injected-parameters" not in c.metadata.get("tags", [])]


def _param(name: str, mode: str):
    marks = [pytest.mark.xdist_group(f"nb{name[:2]}")] if mode == "quick" else []
    if (name, mode) in KNOWN_FAILURES:
        marks.append(pytest.mark.xfail(strict=True, reason=KNOWN_FAILURES[(name, mode)]))
    return pytest.param(name, marks=marks, id=name)


# ---------------------------------------------------------------- the checker itself ----------

def _png_bytes(fig_dir: Path, name: str, slope: float = 1.0) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 1))
    ax.plot([0, 1], [0, slope])
    fig.savefig(fig_dir / f"{name}.png")
    plt.close(fig)
    return (fig_dir / f"{name}.png").read_bytes()


def _executed(outputs: list) -> nbformat.NotebookNode:
    nb = new_notebook()
    for i, outs in enumerate(outputs):
        c = new_code_cell("x", execution_count=i + 1)
        c.outputs = outs
        nb.cells.append(c)
    return nb


def test_checker_accepts_a_notebook_that_shows_its_figure(tmp_path):
    png = base64.b64encode(_png_bytes(tmp_path, "fig1")).decode()
    nb = _executed([[new_output("display_data", data={"image/png": png, "text/plain": "<Image>"})],
                    [new_output("execute_result", data={"text/html": "<table></table>",
                                                        "text/plain": "np.float64(1.0)"},
                                execution_count=2)]])
    assert output_problems(nb, ["fig1"], tmp_path) == []


def test_checker_rejects_a_saved_but_not_shown_figure(tmp_path):
    _png_bytes(tmp_path, "fig1")
    png = base64.b64encode(_png_bytes(tmp_path, "other", slope=-1.0)).decode()
    nb = _executed([[new_output("display_data", data={"image/png": png})]])
    assert output_problems(nb, ["fig1"], tmp_path) == []  # one image for one figure: count holds
    problems = output_problems(nb, ["fig1", "fig2"], tmp_path)
    assert problems == ["1 image outputs for 2 saved figures; not shown: fig1"]


@pytest.mark.parametrize("text, kind", [
    ("PosixPath('/repo/figures/02_premise_estimation/fig2.png')", "bare path"),
    ("'../figures/01_ts_exactness/fig1.png'", "bare path"),
    ("np.float64(2.8921737574951814)", "numpy scalar"),
    ("{'rmse': np.float64(0.1), 'n': 3}", "numpy scalar"),
])
def test_checker_rejects_path_and_numpy_reprs(text, kind):
    nb = _executed([[new_output("execute_result", data={"text/plain": text}, execution_count=1)]])
    (problem,) = output_problems(nb, [])
    assert kind in problem and "cell 0" in problem


def test_checker_rejects_a_printed_path_and_an_error_but_not_prose():
    nb = _executed([[new_output("stream", name="stdout", text="figures/x/fig1.png\n")],
                    [new_output("error", ename="ValueError", evalue="bad", traceback=[])],
                    [new_output("stream", name="stdout", text="RMSE of v_y: 0.28 m/s\n")],
                    [new_output("execute_result", data={"text/plain": "0.28"}, execution_count=4)]])
    assert output_problems(nb, []) == ["cell 0: printed a bare path: 'figures/x/fig1.png'",
                                       "cell 1: error output ValueError: bad"]


def _status(st):
    return [new_output("display_data", data={"text/html": f'<div data-status="{st}">x</div>',
                                              "text/plain": "Exercise"})]


def _exercise_nb(stub_status="not attempted", solution_cell=False, solution_md=False,
                 pointer=True) -> nbformat.NotebookNode:
    nb = new_notebook()
    for n in (1, 2, 3):
        nb.cells.append(nbformat.v4.new_markdown_cell(f"**Exercise {n}.** Do it."))
        stub = new_code_cell("def f():\n    ...  # your code here\nex.check(f)",
                             metadata={"tags": ["exercise"]})
        stub.outputs = _status(stub_status)
        nb.cells.append(stub)
        if pointer:
            nb.cells.append(nbformat.v4.new_markdown_cell(
                f"**Solution and discussion:** see `solutions/99_x_solutions.ipynb`, Exercise {n}."))
        if solution_cell:
            sol = new_code_cell("def f():\n    return 1\nex.check(f)",
                                metadata={"tags": ["solution"], "jupyter": {"source_hidden": True}})
            sol.outputs = _status("correct")
            nb.cells.append(sol)
        if solution_md:
            nb.cells.append(nbformat.v4.new_markdown_cell(f"**Solution {n}.** It is 1."))
    return nb


def test_exercise_checker_accepts_stubs_pointing_to_the_solutions():
    assert exercise_problems(_exercise_nb()) == []


@pytest.mark.parametrize("kw, words", [
    ({"stub_status": "correct"}, "stub's checker said ['correct']"),
    ({"solution_cell": True}, "solution code in the lesson"),
    ({"solution_md": True}, "in plain sight"),
    ({"pointer": False}, "no 'Solution and discussion' pointer"),
])
def test_exercise_checker_rejects(kw, words):
    """Catches a lesson whose Run All executes (or whose page shows) a solution."""
    problems = exercise_problems(_exercise_nb(**kw))
    assert problems and any(words in p for p in problems), problems


def test_exercise_checker_wants_three_and_in_order():
    nb = _exercise_nb()
    assert exercise_problems(nb, minimum=4)[0].startswith("3 exercises")
    nb.cells[3].source = "**Exercise 5.** Wrong number."
    assert any("'Exercise 5' is exercise number 2" in p for p in exercise_problems(nb))


def test_solutions_checker_wants_every_exercise_solved_correctly():
    """Catches a solutions notebook that misses an exercise or whose solution is wrong."""
    nb = new_notebook()
    for n, st in ((1, "correct"), (2, "not yet")):
        nb.cells.append(nbformat.v4.new_markdown_cell(f"**Exercise {n}.** Worked solution."))
        c = new_code_cell(f"ex.check_{n}(f)")
        c.outputs = _status(st)
        nb.cells.append(c)
    assert solution_problems(nb, 2) == ["Exercise 2: the solution's checker said ['not yet'] "
                                        "(want 'correct' last)"]
    assert solution_problems(nb, 3)[-1] == "no worked solution of Exercise 3 (no call of check_3)"


def test_lesson_output_checker_rejects_long_tables_and_empty_cells():
    """Catches 30-row tables full of None/nan and solver dumps in a lesson."""
    rows = "".join(f"<tr><td>{k}</td><td>{'nan' if k == 3 else k}</td></tr>" for k in range(20))
    nb = _executed([[new_output("display_data", data={"text/html": f"<table><thead><tr><th>a</th>"
                                                                  f"</tr></thead>{rows}</table>",
                                                      "text/plain": "t"})],
                    [new_output("stream", name="stdout", text="status OPTIMAL, solve time 0.3 s\n")]])
    problems = lesson_output_problems(nb)
    assert problems == ["cell 0: a table of 20 rows (at most 12)", "cell 0: a table cell shows None/nan/inf",
                        "cell 1: a solver dump in the output: 'status OPTIMAL, solve time 0.3 s\\n'"]


@pytest.mark.parametrize("text, kind", [
    ("Judgement(verdict='reproduced', value=0.031000000000000028)", "object repr"),
    ("<vehicle_observers.design.lmi.Certificate object at 0x7f00>", "object repr"),
    ("array([[1., 2.],\n       [3., 4.]])", "object repr"),
    ("{'gamma': 0.3, 'P': [[1, 0], [0, 1]]}", "object repr"),
])
def test_checker_rejects_object_reprs(text, kind):
    nb = _executed([[new_output("execute_result", data={"text/plain": text}, execution_count=1)]])
    (problem,) = output_problems(nb, [])
    assert kind in problem


def test_checker_rejects_warnings_on_stderr():
    nb = _executed([[new_output("stream", name="stderr",
                                text="UserWarning: Solution may be inaccurate.\n")]])
    (problem,) = output_problems(nb, [])
    assert "stderr" in problem


# ---------------------------------------------------------------- the notebooks ---------------

def _kind(name: str) -> str:
    return pipeline.notebook_kind(pipeline.notebook_path(name, ROOT))


def figures_of(name: str, section_dir: Path) -> tuple[list[str], Path]:
    """``(figure names, folder)`` a run of notebook ``name`` saved into ``section_dir`` (the
    run's ``figures/<section>/``): a report's are listed in its ``metrics.json``, a lesson's in
    ``lesson/figure_data.json``; solutions save none."""
    kind = _kind(name)
    if kind == "report":
        return saved_figures(section_dir / "metrics.json"), section_dir
    fd = section_dir / "lesson" / "figure_data.json"
    if kind == "lesson" and fd.exists():
        return sorted(json.loads(fd.read_text())), section_dir / "lesson"
    return [], section_dir / "lesson"


QUICK = [_param(n, "quick") for n in NOTEBOOKS]
LESSONS = [_param(n, "quick") for n in NOTEBOOKS if _kind(n) == "lesson"]
SOLUTIONS = [_param(n, "quick") for n in NOTEBOOKS if _kind(n) == "solutions"]


@pytest.mark.notebook
@pytest.mark.parametrize("name", QUICK)
def test_quick_executed_notebook_shows_its_figures(name, run_notebook):
    m = run_notebook(name)
    nb = nbformat.read(str(m["_executed"]), as_version=4)
    figures, folder = figures_of(name, m["_dir"])
    problems = output_problems(nb, figures, folder)
    assert not problems, f"{name} (quick): " + "; ".join(problems)


@pytest.mark.notebook
@pytest.mark.parametrize("name", QUICK)
def test_quick_run_figures_label_every_axis_with_a_unit(name, run_notebook):
    """Every saved figure passes :func:`vehicle_observers.results.plotting.label_problems`
    (checked by ``Report.savefig`` / ``Lesson.savefig`` on the figure itself, written to
    ``reporting.figure_checks_path(<the run's figures folder>)``)."""
    m = run_notebook(name)
    figures, folder = figures_of(name, m["_dir"])
    if not figures:
        pytest.skip(f"{name} saves no figure")
    checks = figure_checks_path(folder)
    assert checks.exists(), f"{name}: no {checks} written by the run"
    assert json.loads(checks.read_text())["figures_dir"] == str(Path(folder).resolve())
    problems = [f"{fig}: {p}" for fig, ps in json.loads(checks.read_text())["problems"].items()
                for p in ps]
    assert not problems, f"{name}: " + "; ".join(problems)


@pytest.mark.notebook
@pytest.mark.parametrize("name", LESSONS)
def test_quick_executed_lesson_has_real_exercises_and_curated_outputs(name, run_notebook):
    """Every exercise of a lesson: a stub the checker finds empty and a pointer to its worked
    solution, none executed or shown in the lesson; tables short, no None/nan, no solver dump."""
    m = run_notebook(name)
    nb = nbformat.read(str(m["_executed"]), as_version=4)
    problems = exercise_problems(nb) + lesson_output_problems(nb)
    assert not problems, f"{name}: " + "; ".join(problems)


@pytest.mark.notebook
@pytest.mark.parametrize("name", SOLUTIONS)
def test_quick_executed_solutions_solve_every_exercise_of_their_lesson(name, run_notebook):
    """The solutions notebook (run by the tests, never by the lesson's Run All) solves every
    exercise of its lesson, each checker saying ``correct``."""
    lesson = nbformat.read(str(pipeline.notebook_path(pipeline.section_of(name), ROOT)), as_version=4)
    m = run_notebook(name)
    nb = nbformat.read(str(m["_executed"]), as_version=4)
    problems = solution_problems(nb, len(_exercise_starts(lesson.cells)))
    assert not problems, f"{name}: " + "; ".join(problems)


@pytest.mark.parametrize("name", [_param(n, "full") for n in NOTEBOOKS if _kind(n) != "solutions"])
def test_full_executed_notebook_shows_its_figures(name):
    executed = FULL_BUILD / f"{name}.ipynb"
    if not executed.exists():
        pytest.skip("no full-mode executed copy in build/notebooks/ (run `make figures` or "
                    "`make html` first to check them)")
    nb = nbformat.read(str(executed), as_version=4)
    params = nb.metadata.get("papermill", {}).get("parameters", {})
    current = nbformat.read(str(pipeline.notebook_path(name, ROOT)), as_version=4)
    if params.get("quick") or code_sources(nb) != code_sources(current):
        pytest.skip(f"{name}: build/notebooks/ copy is from another notebook version or quick "
                    "mode (run `make figures`)")
    section = pipeline.section_of(name)
    sec_dir = Path(params.get("figures_dir") or ROOT / "figures") / section
    if not sec_dir.exists():
        sec_dir = ROOT / "figures" / section
    figures, folder = figures_of(name, sec_dir)
    problems = output_problems(nb, figures, folder)
    assert not problems, f"{name} (full): " + "; ".join(problems)


# ---------------------------------------------------------------- HTML for lecturers ----------

def test_html_of_an_executed_notebook_embeds_its_figures(tmp_path):
    png = _png_bytes(tmp_path, "fig1")
    nb = _executed([[new_output("display_data", data={"image/png": base64.b64encode(png).decode()})]])
    nb.cells.insert(0, nbformat.v4.new_markdown_cell("# Observer $\\hat x$"))
    nbformat.write(nb, str(tmp_path / "01_demo.ipynb"))
    (out,) = pipeline.write_html([tmp_path / "01_demo.ipynb"], tmp_path / "html")
    assert out == tmp_path / "html" / "01_demo.html"
    html = out.read_text(encoding="utf-8")
    assert html.count(f"data:image/png;base64,{base64.b64encode(png).decode()}") == 1
    assert "Observer" in html and "<title>01_demo</title>" in html
    with pytest.raises(FileNotFoundError, match="02_missing.ipynb"):
        pipeline.write_html([tmp_path / "02_missing.ipynb"], tmp_path / "html")

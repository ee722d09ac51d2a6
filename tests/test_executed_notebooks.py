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
NOTEBOOKS = [p.stem for p in pipeline.notebooks(ROOT)]
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


def exercise_problems(nb: nbformat.NotebookNode, minimum: int = 3) -> list[str]:
    """What an executed notebook's exercises do wrong, one line per problem (empty when fine).

    An exercise is a markdown cell starting ``**Exercise N.**`` followed (before the next
    markdown cell that starts a section or an exercise) by a code cell tagged ``exercise``, a
    stub with ``# your code here`` whose checker said ``not attempted``, then a code cell tagged
    ``solution`` with its source hidden in JupyterLab whose checker said ``correct``
    (:func:`vehicle_observers.results.teaching.check`). At least ``minimum`` exercises; no
    solution in plain sight (a markdown cell starting ``**Solution``)."""
    problems = []
    cells = nb.cells
    starts = [i for i, c in enumerate(cells) if c.cell_type == "markdown"
              and c.source.lstrip().startswith("**Exercise")]
    if len(starts) < minimum:
        problems.append(f"{len(starts)} exercises (want at least {minimum} '**Exercise N.**' cells)")
    shown = [i for i, c in enumerate(cells) if c.cell_type == "markdown"
             and c.source.lstrip().startswith("**Solution")]
    if shown:
        problems.append(f"cells {shown}: a solution in plain sight (markdown '**Solution')")
    for n, i in enumerate(starts, 1):
        label = cells[i].source.lstrip()[:20].split(".**")[0].strip("* ")
        if label != f"Exercise {n}":
            problems.append(f"cell {i}: '{label}' is exercise number {n} in order")
        block = []
        for c in cells[i + 1:]:
            if c.cell_type == "markdown" and (c.source.lstrip().startswith(("#", "**Exercise"))):
                break
            block.append(c)
        stubs = [c for c in block if c.cell_type == "code" and "exercise" in c.metadata.get("tags", [])]
        sols = [c for c in block if c.cell_type == "code" and "solution" in c.metadata.get("tags", [])]
        if len(stubs) != 1 or len(sols) != 1:
            problems.append(f"cell {i} ({label}): {len(stubs)} 'exercise' and {len(sols)} 'solution' "
                            f"code cells after it (want one of each)")
            continue
        stub, sol = stubs[0], sols[0]
        if "# your code here" not in stub.source:
            problems.append(f"cell {i} ({label}): the stub has no '# your code here'")
        if _statuses(stub) != ["not attempted"]:
            problems.append(f"cell {i} ({label}): the stub's checker said {_statuses(stub)} "
                            f"(want ['not attempted'])")
        if not sol.metadata.get("jupyter", {}).get("source_hidden"):
            problems.append(f"cell {i} ({label}): the solution's source is not hidden")
        if _statuses(sol) != ["correct"]:
            problems.append(f"cell {i} ({label}): the solution's checker said {_statuses(sol)} "
                            f"(want ['correct'])")
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


def _exercise_nb(stub_status="not attempted", sol_status="correct", hidden=True,
                 solution_md=False) -> nbformat.NotebookNode:
    def status(st):
        return [new_output("display_data", data={"text/html": f'<div data-status="{st}">x</div>',
                                                  "text/plain": "Exercise"})]
    nb = new_notebook()
    for n in (1, 2, 3):
        nb.cells.append(nbformat.v4.new_markdown_cell(f"**Exercise {n}.** Do it."))
        stub = new_code_cell("def f():\n    ...  # your code here\nex.check(f)",
                             metadata={"tags": ["exercise"]})
        stub.outputs = status(stub_status)
        sol = new_code_cell("def f():\n    return 1\nex.check(f)",
                            metadata={"tags": ["solution"], "jupyter": {"source_hidden": hidden}})
        sol.outputs = status(sol_status)
        nb.cells += [stub, sol]
        if solution_md:
            nb.cells.append(nbformat.v4.new_markdown_cell(f"**Solution {n}.** It is 1."))
    return nb


def test_exercise_checker_accepts_stub_then_hidden_solution():
    assert exercise_problems(_exercise_nb()) == []


@pytest.mark.parametrize("kw, words", [
    ({"stub_status": "correct"}, "stub's checker said ['correct']"),
    ({"sol_status": "not yet"}, "solution's checker said ['not yet']"),
    ({"hidden": False}, "source is not hidden"),
    ({"solution_md": True}, "in plain sight"),
])
def test_exercise_checker_rejects(kw, words):
    problems = exercise_problems(_exercise_nb(**kw))
    assert problems and any(words in p for p in problems), problems


def test_exercise_checker_wants_three_and_in_order():
    nb = _exercise_nb()
    assert exercise_problems(nb, minimum=4)[0].startswith("3 exercises")
    nb.cells[3].source = "**Exercise 5.** Wrong number."
    assert any("'Exercise 5' is exercise number 2" in p for p in exercise_problems(nb))


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

@pytest.mark.notebook
@pytest.mark.parametrize("name", [_param(n, "quick") for n in NOTEBOOKS])
def test_quick_executed_notebook_shows_its_figures(name, run_notebook):
    m = run_notebook(name)
    nb = nbformat.read(str(m["_executed"]), as_version=4)
    if pipeline.notebook_kind(pipeline.notebook_path(name)) == "lesson" \
            and not (m["_dir"] / "metrics.json").exists():   # a split section's lesson
        folder = m["_dir"] / "lesson"
        figures = sorted(p.stem for p in folder.glob("*.png"))
    else:
        folder = m["_dir"]
        figures = saved_figures(m["_dir"] / "metrics.json")
    problems = output_problems(nb, figures, folder)
    assert not problems, f"{name} (quick): " + "; ".join(problems)


@pytest.mark.notebook
@pytest.mark.parametrize("name", [_param(n, "quick") for n in NOTEBOOKS])
def test_quick_run_figures_label_every_axis_with_a_unit(name, run_notebook):
    """Every saved figure passes :func:`vehicle_observers.results.plotting.label_problems`
    (checked by ``Report.savefig`` on the figure itself, written by ``Report.write`` to
    ``reporting.figure_checks_path(<the run's figures folder>)``)."""
    m = run_notebook(name)
    folder = m["_dir"]
    if not (folder / "metrics.json").exists() and (folder / "lesson").is_dir():
        folder = folder / "lesson"                 # a split section's lesson (teaching.Lesson)
    elif not saved_figures(folder / "metrics.json"):
        pytest.skip(f"{name} saves no figure")
    checks = figure_checks_path(folder)
    assert checks.exists(), f"{name}: no {checks} written by the run"
    assert json.loads(checks.read_text())["figures_dir"] == str(Path(folder).resolve())
    problems = [f"{fig}: {p}" for fig, ps in json.loads(checks.read_text())["problems"].items()
                for p in ps]
    assert not problems, f"{name}: " + "; ".join(problems)


@pytest.mark.notebook
@pytest.mark.parametrize("name", [_param(n, "quick") for n in NOTEBOOKS])
def test_quick_executed_notebook_has_real_exercises(name, run_notebook):
    """Every exercise: a stub the checker finds empty, then a hidden solution it finds correct."""
    kind = pipeline.notebook_kind(pipeline.notebook_path(name))
    if kind == "report":
        pytest.skip(f"{name}: a report holds no exercises (they are in its lesson)")
    m = run_notebook(name)
    nb = nbformat.read(str(m["_executed"]), as_version=4)
    if kind == "lesson" and pipeline.notebook_path(f"{name}_solutions").exists():
        # split section: stubs here say "not attempted", the solutions notebook "correct"
        sol = nbformat.read(str(run_notebook(f"{name}_solutions")["_executed"]), as_version=4)
        status = lambda book: [o["data"]["text/html"] for c in book.cells
                               for o in c.get("outputs", []) if "vo-check" in
                               "".join(o.get("data", {}).get("text/html", ""))]
        stubs, sols = status(nb), status(sol)
        assert len(stubs) == len(sols) >= 3, name
        assert all('data-status="not attempted"' in "".join(h) for h in stubs), name
        assert all('data-status="correct"' in "".join(h) for h in sols), name
        return
    problems = exercise_problems(nb)
    assert not problems, f"{name}: " + "; ".join(problems)


@pytest.mark.parametrize("name", [_param(n, "full") for n in NOTEBOOKS])
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
    fig_dir = Path(params.get("figures_dir") or ROOT / "figures") / section
    if not (fig_dir / "metrics.json").exists():
        fig_dir = ROOT / "figures" / section
    if pipeline.notebook_kind(pipeline.notebook_path(name, ROOT)) == "lesson" \
            and (ROOT / "notebooks" / "reports" / f"{section}_report.ipynb").exists():
        fig_dir = fig_dir / "lesson"               # a split section: the lesson's own figures
        figures = sorted(p.stem for p in fig_dir.glob("*.png"))
    else:
        figures = saved_figures(fig_dir / "metrics.json")
    problems = output_problems(nb, figures, fig_dir)
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
